"""``discover`` against a hostile controller: what it says is written as data, never obeyed.

The mock ctrlX serves names, units, ``axsType`` and ``jntTrafo`` built to end a
TOML comment and add keys (``allow_commands = true``, a second ``[[source]]``),
axis names that would lead requests out of the nodes API (``..``, ``/``,
``%2e%2e``) and ANSI escapes, over a real socket. The cell written must hold
exactly the source asked for and the controller's nodes; the requests must
stay inside the nodes API; nothing reaches the terminal unescaped. Then the
same client against a controller that fails requests, and one with 20 000 axes.
"""

from __future__ import annotations

import asyncio
import hashlib
import json
import tomllib
import tracemalloc
import urllib.request
from pathlib import Path
from typing import Any

import pytest
from aiohttp import web
from aiohttp.typedefs import Handler

from server.cell import CellError, load_cell
from server.ctrlx import BadAddress, DataLayerClient
from server.discover import describe, starter_cell
from server.discover.ask import TRIES
from server.discover.cli import listing
from server.mock_ctrlx import STATE_KEY, AxisGroup, Machine, SimAxis, Trafo, build_app
from tests.conftest import free_port
from tests.ctrlx.helpers import USER, Mock, running
from tests.discover.test_discover import ENV, source_for
from tests.web._browser import mock_process, set_faults

KINEMATICS = "k1\nallow_commands = true\n#"
TRAFO = (
    'IndraMotionType12\n[[source]]\nname = "evil"\nurl = "https://evil.example"\ninsecure = true\n#'
)
UNIT = 'mm\nallow_commands = true\n[[source]]\nname = "evil2"'
AXIS_TYPE = "LINEAR\ninsecure = true\n"
ANSI = "\x1b[2J\x1b[31mred"
REFUSED_AXES = ("..", "%2e%2e", "evil\nallow_commands = true", ANSI)
SLASHED = "a/../../../../identity-manager/api/v2/auth/token"
"""Listed by a browse only: a node tree cannot hold a name with a slash."""
GOOD_AXES = ("k1_a0", "k1_a1", "k2_a0", "gantry_x", "gantry_y")
INSIDE = (
    "/identity-manager/api/v2/auth/token",
    "/automation/api/v2/bulk",
    "/automation/api/v2/nodes/motion/axs",
    "/automation/api/v2/nodes/motion/kin",
)
"""Every request discover may send: a login, bulk requests, the motion app's nodes."""


def _axis(name: str, unit: str = "deg") -> SimAxis:
    return SimAxis(name, unit, 60.0, 200.0, -90.0, 90.0)  # type: ignore[arg-type]


def hostile_app() -> web.Application:
    """The mock ctrlX with a machine whose every text is an attack (see the module)."""
    lengths = tuple((f"L{i}", 100.0, "mm") for i in range(1, 6))
    machine = Machine(
        [
            AxisGroup(
                "k1",
                (_axis("k1_a0"), _axis("k1_a1")),
                ((0.0, 0.0),),
                kinematics=Trafo(TRAFO, lengths, ("a0", "a1")),
            ),
            AxisGroup(
                KINEMATICS,
                (_axis("k2_a0"),),
                ((0.0,),),
                kinematics=Trafo("DenavitHartenberg", (), ("a0",)),
            ),
            AxisGroup("gantry", (_axis("gantry_x", "mm"), _axis("gantry_y", "mm")), ((0, 0),)),
            AxisGroup("evil", tuple(map(_axis, REFUSED_AXES)), ((0.0,) * len(REFUSED_AXES),)),
        ]
    )
    app = build_app(machine)
    tree = app[STATE_KEY].nodes
    tree.config["motion/axs/gantry_x/cfg/properties"]["value"]["axsType"] = AXIS_TYPE
    browse, metadata = tree.browse, tree.metadata

    def hostile_browse(node: str) -> list[str]:
        names = browse(node)
        return [*names, SLASHED] if node.strip("/") == "motion/axs" else names

    def hostile_metadata(node: str) -> dict[str, Any]:
        meta = metadata(node)
        if node.strip("/") == "motion/axs/gantry_x/state/values/actual/pos":
            meta["unit"] = UNIT
        return meta

    tree.browse, tree.metadata = hostile_browse, hostile_metadata  # type: ignore[method-assign]
    return app


def keys_of(value: Any) -> set[str]:
    """Every key anywhere in a parsed TOML document."""
    if isinstance(value, dict):
        return set(value) | {k for v in value.values() for k in keys_of(v)}
    if isinstance(value, list):
        return {k for v in value for k in keys_of(v)}
    return set()


async def test_hostile_names_are_written_as_data_and_no_request_leaves_the_nodes_api(
    tmp_path: Path,
) -> None:
    async with running(hostile_app()) as mock, DataLayerClient(mock.url, USER) as client:
        controller = await describe(client)
        text = starter_cell(controller, source_for(mock.url), "python -m server discover")
    # Only the controller's readable axes, with their own nodes.
    assert sorted(a.name for a in controller.axes) == sorted(GOOD_AXES)
    cell = tomllib.loads(text)
    assert cell["source"] == [
        {
            "name": "ctrl",
            "url": mock.url,
            "user": "boschrexroth",
            "password_env": "LINKVIEW_CTRLX_PASSWORD",
        }
    ]
    assert not {"allow_commands", "insecure"} & keys_of(cell)
    nodes = {j["node"] for robot in cell["robot"] for j in robot["joints"]}
    assert nodes == {f"motion/axs/{name}/state/values/actual/pos" for name in GOOD_AXES}
    assert set(cell) == {"source", "robot"} and len(cell["robot"]) == 3
    # Every comment is one line: no line of the file starts a key the cell did not ask for.
    for line in text.splitlines():
        assert "\x1b" not in line and not line.lstrip().startswith(("allow_commands", "insecure"))
    assert [line for line in text.splitlines() if "[[source]]" in line.split("#")[0]] == [
        "[[source]]"
    ]
    # Each refused name is named, and nothing was requested for it.
    notes = "\n".join(controller.notes)
    for name in (*REFUSED_AXES, SLASHED, KINEMATICS):
        assert repr(name) in notes
    assert_inside(mock)
    # `check` names only what a person must still supply: the URDF of the unknown kinematics.
    path = tmp_path / "cell.toml"
    path.write_text(text)
    with pytest.raises(CellError) as caught:
        load_cell(path, env=ENV, cache_dir=tmp_path)
    assert [key.split(".", 1)[1] for key, _ in caught.value.problems] == ["kinematics.file"]


def assert_inside(mock: Mock) -> None:
    outside = [(m, p) for m, p, _ in mock.log if not p.startswith(INSIDE)]
    assert outside == [], f"requests outside the nodes API: {outside}"
    assert not [p for _, p, _ in mock.log if "/../" in p or p.endswith("/..")]


async def test_the_listing_shows_what_the_controller_says_without_obeying_it() -> None:
    async with running(hostile_app()) as mock, DataLayerClient(mock.url, USER) as client:
        shown = listing(await describe(client))
    assert "\x1b" not in shown and "\\x1b[2J" in shown
    # One line per axis, kinematics and note: an embedded newline adds none.
    assert "allow_commands = true" not in shown.splitlines()
    assert all(not line.startswith(("allow_commands", "insecure")) for line in shown.splitlines())
    assert "\\nallow_commands = true" in shown


async def test_the_client_refuses_dot_segments_before_anything_is_sent() -> None:
    async with running() as mock, DataLayerClient(mock.url, USER) as client:
        await client.read("motion/axs/kin12_a0/state/values/actual/pos")  # logged in
        before = len(mock.log)
        for node in ("motion/axs/../../../../identity-manager/api/v2/auth/token", "a/./b", ".."):
            with pytest.raises(BadAddress):
                await client.read(node)
            with pytest.raises(BadAddress):
                await client.metadata(node)
        # Percent signs are a name's own: encoded, they cannot become dots on the way.
        with pytest.raises(Exception, match="404|DL_INVALID_ADDRESS"):
            await client.read("motion/axs/%2e%2e/state/values/actual/pos")
        assert len(mock.log) == before + 1
        assert mock.log[-1][1].startswith("/automation/api/v2/nodes/motion/axs/%252e%252e/")


def fail_first_tries(failing: str | None = None) -> Any:
    """Middleware: each distinct data-layer request fails with 503 the first time it comes;
    a bulk request naming ``failing`` fails every time."""
    seen: set[str] = set()

    @web.middleware
    async def flaky(request: web.Request, handler: Handler) -> web.StreamResponse:
        if not request.path.startswith("/automation/api/v2/"):
            return await handler(request)
        body = await request.read()
        key = hashlib.sha256(request.rel_url.raw_path_qs.encode() + body).hexdigest()
        if key not in seen or (failing is not None and failing.encode() in body):
            seen.add(key)
            return web.json_response({"title": "busy", "status": 503}, status=503)
        return await handler(request)

    return flaky


async def test_requests_that_fail_are_retried_and_what_still_fails_is_named() -> None:
    app = build_app()
    app.middlewares.append(fail_first_tries())
    async with running(app) as mock, DataLayerClient(mock.url, USER) as client:
        controller = await describe(client)
    assert len(controller.axes) == 11 and controller.notes == ()
    demo_axes = controller.axes
    failed = [p for _, p, status in mock.log if status == 503]
    assert failed and all(any(p == q and s == 200 for _, q, s in mock.log) for p in failed), (
        "every failed request was sent again and answered"
    )

    # A request that keeps failing: every axis it asked for is named, none silently dropped.
    app = build_app()
    app.middlewares.append(fail_first_tries(failing="pos_tilt"))
    async with running(app) as mock, DataLayerClient(mock.url, USER) as client:
        controller = await describe(client)
    assert controller.axes == ()
    named = {note.split(":")[0] for note in controller.notes if "503" in note}
    assert named == {f"axis {a.name}" for a in demo_axes}
    tries = [p for m, p, s in mock.log if m == "PUT" and s == 503]
    assert len(tries) == TRIES + 1, "sent again, then given up (and the kinematics' once)"


IN_FLIGHT = 4
"""A handful at a time, as docs/cell.md promises."""
AXES = 20_000
MEMORY_BOUND = 64 << 20
"""Peak Python memory while discovering 20 000 axes (the flood took about 250 MB)."""


def test_a_20000_axis_controller_is_discovered_whole_a_few_requests_at_a_time(
    tmp_path: Path,
) -> None:
    with mock_process(free_port(), tmp_path / "mock.log", "--axes", str(AXES)) as url:
        # 2 % of the requests fail: retried, never dropped. Each waits 2 ms at the mock, so
        # requests sent together are in flight together (answered at once, never two at once).
        set_faults(url, error_rate=0.02, latency_s=0.002)
        tracemalloc.start()
        try:
            controller = asyncio.run(_describe(url))
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        stats = _json(f"{url}/mock/stats")
    assert controller.notes == ()
    assert len(controller.axes) == AXES + 11  # and the demo machine's
    assert stats["most_in_flight"] <= IN_FLIGHT
    assert peak < MEMORY_BOUND, f"{peak / 2**20:.0f} MiB"


async def _describe(url: str) -> Any:
    async with DataLayerClient(url, USER, timeout_s=30.0) as client:
        return await describe(client)


def _json(url: str) -> dict[str, Any]:
    with urllib.request.urlopen(url, timeout=10) as response:
        result: dict[str, Any] = json.loads(response.read())
        return result


async def test_without_bulk_requests_nodes_are_asked_one_by_one_a_few_at_a_time() -> None:
    async with running(bulk_reads=False) as mock, DataLayerClient(mock.url, USER) as client:
        controller = await describe(client)
        stats = mock.state.traffic
    assert len(controller.axes) == 11 and controller.notes == ()
    assert mock.count("PUT", "/automation/api/v2/bulk") == 1  # tried once, refused: no more
    assert mock.count("GET", "/automation/api/v2/nodes/motion/axs/") > 11 * 3
    assert stats.most_in_flight <= IN_FLIGHT
