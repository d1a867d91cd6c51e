"""``discover rtde://HOST[:PORT] --model ur5e``: a UR controller's version and arm, a starter cell.

RTDE says which controller answers (its version) and where the joints are,
not which arm is attached: the user names the model. The cell has one
``rtde`` source and one robot with no joint list (RTDE's ``actual_q`` in
order, ``target_q`` as setpoint). Its kinematics is UR's description
package (``ur_description``) where linkview's package search finds one
above the cell file, and else UR's published DH table for the model, drawn
without meshes (a ``TODO`` says so). The file is written by ``writer``:
every value the device or the command line gave is a TOML string, escaped,
and what it says in comments is one line.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
from pathlib import Path
from typing import Any

from tomlkit.items import Table

from ..rtde import RtdeConnector, RtdeSettings
from ..rtde.wire import rtde_address
from ..sources import Sample, SourceError
from ..text import printable
from ..urdf._paths import Packages
from .ur_models import MODELS, UrModel
from .writer import CellDocument, comment, inline, plain_name, table

DESCRIPTION_PACKAGE = "ur_description"
DESCRIPTION_FILE = "urdf/ur.urdf.xacro"
"""UR's description package builds every arm from one xacro with the ``ur_type`` argument."""


def main(argv: list[str]) -> int:
    """Run ``discover rtde://...``; returns the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m server discover",
        description="Read a Universal Robots controller over RTDE (its version, the arm's "
        "joints) and write a starter cell for the arm you name.",
    )
    parser.add_argument("url", help="the controller, rtde://HOST[:PORT] (port 30004)")
    parser.add_argument(
        "--model", required=True, choices=sorted(MODELS), help="the arm (RTDE does not say)"
    )
    parser.add_argument("-o", "--output", default="cell.toml", metavar="FILE")
    parser.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    parser.add_argument("--source", default=None, help="name of the cell's [[source]]")
    args = parser.parse_args(argv)
    try:
        host, port = rtde_address(args.url)
    except ValueError as exc:
        parser.error(str(exc))
    output = Path(args.output)
    if output.exists() and not args.force:
        parser.error(f"{output} exists; give another --output or --force")
    try:
        device, sample = asyncio.run(_read(host, port))
    except SourceError as exc:
        print(printable(f"linkview: {exc}"), file=sys.stderr)
        return 1
    joints = [sample.values.get(f"actual_q[{i}]") for i in range(6)]
    shown = ", ".join(f"{q:.4f}" if isinstance(q, float) else "?" for q in joints)
    print(printable(f"rtde://{host}:{port}: {device}; actual_q [{shown}] rad"))
    name = args.source or plain_name(host, "ur")
    command = f"python -m server discover {args.url} --model {args.model}"
    text = starter_cell(args.url, name, MODELS[args.model], device, output, command)
    output.write_text(text, encoding="utf-8")
    print(f"wrote {output}: check it with `python -m server check {output}`; TODOs need a person")
    return 0


async def _read(host: str, port: int) -> tuple[str, Sample]:
    """What the controller says of itself, and one sample of its joints."""
    connector = RtdeConnector(RtdeSettings(host, port, give_up_s=0.0))
    got: asyncio.Future[Sample] = asyncio.get_running_loop().create_future()

    def deliver(sample: Sample) -> None:
        if not got.done():
            got.set_result(sample)

    follow = asyncio.create_task(
        connector.follow([f"actual_q[{i}]" for i in range(6)], 0.02, deliver)
    )
    try:
        waits: set[asyncio.Future[Any]] = {follow, got}
        done, _ = await asyncio.wait(waits, timeout=10.0, return_when="FIRST_COMPLETED")
        if follow in done:
            follow.result()  # raises its SourceError
        if got not in done:
            raise SourceError(f"rtde://{host}:{port}: no data package within 10 s")
        return connector.device or "no robot or safety mode", got.result()
    finally:
        follow.cancel()
        await asyncio.gather(follow, return_exceptions=True)
        await connector.close()


def starter_cell(
    url: str, source: str, model: UrModel, device: str, output: Path, command: str
) -> str:
    """The TOML text of the starter cell (see the module doc)."""
    cell = CellDocument(
        f"A starter cell written by `{command}`.",
        f"The controller said: {device}.",
        "Check it with `python -m server check FILE`; docs/cell.md has every key.",
    )
    cell.add("source", table(name=source, type="rtde", url=url))
    robot = table(
        f"A Universal Robots {model.name.upper()}: RTDE does not say which arm it is; "
        "this is the --model given.",
        name=model.name,
        source=source,
    )
    robot.add(comment("TODO: where the robot stands in the cell (mm, deg)."))
    robot.add("base", inline({"xyz": [0.0, 0.0, 0.0], "rpy_deg": [0.0, 0.0, 0.0]}))
    robot.add(comment("No joint list: RTDE's actual_q in order; target_q is the setpoint."))
    robot.add("kinematics", _kinematics(model, output))
    cell.add("robot", robot)
    return cell.text()


def _kinematics(model: UrModel, output: Path) -> Table:
    """UR's description package if the search finds it above ``output``, else the DH table."""
    folder = output.resolve().parent
    package = Packages({}, folder).find(DESCRIPTION_PACKAGE)
    if package is not None and (package / DESCRIPTION_FILE).is_file():
        return table(
            f"UR's description package, found at {package}.",
            type="urdf",
            file=os.path.relpath(package / DESCRIPTION_FILE, folder),
            args=inline({"ur_type": model.name, "name": model.name}),
        )
    return table(
        f"TODO: no {DESCRIPTION_PACKAGE} package above this file: UR's published DH table, "
        "drawn without meshes. Put UR's description package beside the cell for meshes.",
        type="dh",
        d=list(model.d_mm),
        a=list(model.a_mm),
        alpha_deg=list(model.alpha_deg),
        limits=[list(pair) for pair in model.limits_deg],
    )
