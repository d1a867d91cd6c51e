"""The mock serves Bosch Rexroth's Node-RED ctrlX client as a device does.

The client is the real one: ``lib/`` of node-red-contrib-ctrlx-automation 1.9.10
(MIT), vendored unmodified in ``node_red_ctrlx/`` (its ORIGIN.md), with its npm
dependencies pinned there. Under Node 20, ``node_red_ctrlx/drive.js`` calls its
``CtrlxCore`` (login, read, browse, metadata, write, create, delete, subscribe,
logout) as the Data Layer Request and Subscribe nodes do, against the mock over
HTTPS on a free loopback port, and prints what each call gave.
"""

from __future__ import annotations

import asyncio
import json
import re
import shutil
import time
from pathlib import Path
from typing import Any
from urllib.parse import quote, urlsplit

from server.mock_ctrlx import build_app
from tests.ctrlx.helpers import KIN12, Mock, running

NODE = shutil.which("node")
CLIENT = Path(__file__).resolve().parent / "node_red_ctrlx"
NOPE = "motion/axs/nope/state/values/actual/pos"
DTEST = "plc/app/Application/sym/PLC_PRG/dTest"
HEX8 = re.compile(r"[0-9A-F]{8}")
ENCODE_URI_SAFE = ";,/?:@&=+$-_.!~*'()#"
"""What JavaScript's ``encodeURI`` (ECMA-262) leaves as it is besides letters and digits."""
FILETIME_EPOCH_S = 11644473600
DRIVE_LIMIT_S = 60.0
EVENTS = "/automation/api/v2/events/"


def is_number(value: Any) -> bool:
    """A JSON number (JavaScript writes 2.0 as 2)."""
    return isinstance(value, int | float) and not isinstance(value, bool)


async def drive(mock: Mock, plan: list[list[Any]]) -> list[dict[str, Any]]:
    """Each step's outcome (``{"ok": result}`` or ``{"error": ...}``), login first, logout last."""
    assert NODE is not None, "node is missing: Node 20 runs Bosch Rexroth's client"
    installed = CLIENT / "node_modules" / "launchdarkly-eventsource"
    assert installed.is_dir(), f"run `npm ci` in {CLIENT} (the README's test command does)"
    url = urlsplit(mock.url)
    proc = await asyncio.create_subprocess_exec(
        NODE,
        str(CLIENT / "drive.js"),
        f"{url.hostname}:{url.port}",
        "boschrexroth",
        "boschrexroth",
        json.dumps(plan),
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    try:
        out, err = await asyncio.wait_for(proc.communicate(), DRIVE_LIMIT_S)
    finally:
        if proc.returncode is None:
            proc.kill()
            await proc.wait()
    assert proc.returncode == 0, err.decode()
    results: list[dict[str, Any]] = json.loads(out)
    return results


async def test_node_red_requests_work_as_on_a_device(tmp_path: Path) -> None:
    target = {"type": "object", "value": {"axsPos": [5.0, -5.0]}}
    plan = [
        ["read", KIN12[0]],
        ["read", DTEST, {"type": "double", "value": 1.0}],
        ["browse", "motion/axs"],
        ["metadata", KIN12[0]],
        ["write", DTEST, {"type": "double", "value": 2.5}],
        ["write", "motion/axs/kin12_a0/cmd/reset"],  # no argument: no body at all
        ["create", "motion/grp/kin12/cmd/reset"],
        ["create", "motion/grp/kin12/cmd/pos-abs", target],
        ["read", NOPE],
        ["delete", KIN12[0]],
        ["write", "motion/grp/kin12/cmd/pos-abs"],
    ]
    async with running(tls_dir=tmp_path) as mock:
        login, *steps, logout = await drive(mock, plan)
    (read, read_with_data, browse, metadata, write, reset, create_reset, create, missing,
     delete, no_argument) = steps  # fmt: skip
    decoded = login["ok"]["token_decoded"]
    assert decoded["exp"] - decoded["iat"] == 3600
    assert read["ok"]["type"] == "double" and is_number(read["ok"]["value"])
    assert read_with_data["ok"] == {"type": "double", "value": 0.0}
    assert "kin12_a0" in browse["ok"]["value"]
    assert metadata["ok"]["value"]["unit"] == "deg"
    assert write["ok"] == {"type": "double", "value": 2.5}
    assert reset == {"ok": None} and create_reset == {"ok": None}
    assert create["ok"]["value"] == {"axsPos": [5.0, -5.0]}
    problem = missing["error"]
    assert problem["problem"] is True
    assert (problem["status"], problem["title"], problem["instance"]) == (
        404,
        "DL_INVALID_ADDRESS",
        NOPE,
    )
    assert HEX8.fullmatch(problem["mainDiagnosisCode"])
    assert HEX8.fullmatch(problem["detailedDiagnosisCode"])
    assert problem["severity"] == "Error" and problem["dynamicDescription"] == NOPE
    assert (delete["error"]["status"], delete["error"]["instance"]) == (403, KIN12[0])
    assert no_argument["error"]["status"] == 400
    assert logout == {"ok": None}
    # The client builds its paths with encodeURI; the mock's log shows the exact requests.
    assert ("PUT", quote(f"/automation/api/v2/nodes/{DTEST}", ENCODE_URI_SAFE), 200) in mock.log
    assert ("DELETE", "/identity-manager/api/v2/auth/token", 204) in mock.log


async def test_node_red_subscription_delivers_updates_and_errors_naming_their_node(
    tmp_path: Path,
) -> None:
    # The options as the subscription's configuration node hands them to the client: the
    # editor's strings through parseInt (ctrlx-config-subscription.js), in ms and µs.
    options = {
        "publishIntervalMs": 20,
        "errorIntervalMs": 100,
        "keepaliveIntervalMs": 1000,
        "samplingIntervalUs": 20000,
        "queueBehaviour": "DiscardOldest",
        "queueSize": 10,
    }
    app = build_app(subscription_lifetime_s=0.3)
    async with running(app, tls_dir=tmp_path) as mock:
        _, subscribed, _ = await drive(mock, [["subscribe", [*KIN12, NOPE], options, 3, 10_000]])
        await expired(mock)
    updates, errors = subscribed["ok"]["updates"], subscribed["ok"]["errors"]
    assert ("POST", EVENTS, 201) in mock.log
    streams = [p for m, p, _ in mock.log if m == "GET" and p.startswith(EVENTS)]
    assert len(streams) == 1, streams
    assert re.fullmatch(EVENTS + r"node-red-[-0-9a-f]{36}", streams[0]), streams
    for node in KIN12:
        assert len(updates[node]) >= 3 and {u["node"] for u in updates[node]} == {node}
        assert all(u["type"] == "double" and is_number(u["value"]) for u in updates[node])
        newest_s = updates[node][-1]["timestamp"] / 1e7 - FILETIME_EPOCH_S
        assert abs(newest_s - time.time()) < 5.0
    assert updates[NOPE] == []
    # The Subscribe node's configuration routes an error to the node its instance names.
    assert errors and all(
        e["problem"] and e["instance"] == NOPE and e["status"] == 404 for e in errors
    ), errors


async def expired(mock: Mock) -> None:
    """The client never deletes its subscription; the mock forgets it after its lifetime."""
    async with asyncio.timeout(5):
        while len(mock.state.subscriptions):
            await asyncio.sleep(0.05)
