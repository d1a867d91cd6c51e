"""The mock serves a client that calls the API exactly as Node-RED's ctrlX nodes do.

See ``node_red.py`` for what is imitated and why (the real npm package could
not be installed). Runs over HTTPS on a free loopback port; the blocking
client runs in a thread.
"""

from __future__ import annotations

import asyncio
import re
import time
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from server.mock_ctrlx import build_app
from tests.clients.node_red import (
    ConfigSubscription,
    CtrlxCore,
    CtrlxProblemError,
    encode_uri,
    filetime_to_ms,
)
from tests.ctrlx.helpers import KIN12, Mock, running

NOPE = "motion/axs/nope/state/values/actual/pos"
DTEST = "plc/app/Application/sym/PLC_PRG/dTest"
HEX8 = re.compile(r"[0-9A-F]{8}")


def requests_and_commands(core: CtrlxCore) -> dict[str, Any]:
    """The Data Layer Request node's operations, as its examples use them."""
    seen: dict[str, Any] = {"login": core.log_in()}
    seen["read"] = core.datalayer_read(KIN12[0])
    seen["read_with_data"] = core.datalayer_read(DTEST, {"type": "double", "value": 1.0})
    seen["browse"] = core.datalayer_read("motion/axs", kind="browse")
    seen["metadata"] = core.datalayer_read(KIN12[0], kind="metadata")
    seen["write"] = core.datalayer_write(DTEST, {"type": "double", "value": 2.5})
    seen["reset"] = core.datalayer_write("motion/axs/kin12_a0/cmd/reset")  # no body at all
    seen["create_reset"] = core.datalayer_create("motion/grp/kin12/cmd/reset")
    target = {"type": "object", "value": {"axsPos": [5.0, -5.0]}}
    seen["create"] = core.datalayer_create("motion/grp/kin12/cmd/pos-abs", target)
    for name, call in [
        ("missing", lambda: core.datalayer_read(NOPE)),
        ("delete", lambda: core.datalayer_delete(KIN12[0])),
        ("no_argument", lambda: core.datalayer_write("motion/grp/kin12/cmd/pos-abs")),
    ]:
        try:
            call()
        except CtrlxProblemError as err:
            seen[name] = err
    return seen


def subscribe(core: CtrlxCore, deadline_s: float = 10.0) -> tuple[ConfigSubscription, dict]:
    """Three Data Layer Subscribe nodes on one subscription, one of them on a bad node."""
    config = ConfigSubscription()
    got: dict[str, dict[str, list[Any]]] = {}
    for node_id, path in (("a", KIN12[0]), ("b", KIN12[1]), ("c", NOPE)):
        got[node_id] = {"updates": [], "errors": []}

        def callback(err: Exception | None, data: Any, mine: dict = got[node_id]) -> None:
            mine["errors" if err else "updates"].append(err or data)

        config.register(node_id, path, callback)
    # The settings as Node-RED keeps them: strings from the editor.
    options = {"publishIntervalMs": "20", "errorIntervalMs": "100", "keepaliveIntervalMs": "1000",
               "samplingIntervalUs": "20000", "queueBehaviour": "DiscardOldest",
               "queueSize": "10"}  # fmt: skip
    stream_path = core.create_subscription(config.paths(), options)
    source = core.open_event_source(stream_path)
    end = time.monotonic() + deadline_s
    try:
        while time.monotonic() < end:
            event, data = source.next_event()
            if event == "update":
                config.on_update(data)
            elif event == "error":
                config.on_error(data)
            if (
                len(got["a"]["updates"]) >= 3
                and len(got["b"]["updates"]) >= 3
                and got["c"]["errors"]
            ):
                break
    finally:
        source.close()
    return config, got


async def test_node_red_requests_work_as_on_a_device(tmp_path: Path) -> None:
    async with running(tls_dir=tmp_path) as mock:
        url = urlsplit(mock.url)
        core = CtrlxCore(str(url.hostname), int(url.port or 443), "boschrexroth", "boschrexroth")
        seen = await asyncio.wait_for(asyncio.to_thread(requests_and_commands, core), 30)
        await asyncio.to_thread(core.log_out)
    decoded = seen["login"]["token_decoded"]
    assert decoded["exp"] - decoded["iat"] == 3600
    assert seen["read"]["type"] == "double" and isinstance(seen["read"]["value"], float)
    assert seen["read_with_data"] == {"type": "double", "value": 0.0}
    assert "kin12_a0" in seen["browse"]["value"]
    assert seen["metadata"]["value"]["unit"] == "deg"
    assert seen["write"] == {"type": "double", "value": 2.5}
    assert seen["reset"] is None and seen["create_reset"] is None
    assert seen["create"]["value"] == {"axsPos": [5.0, -5.0]}
    missing = seen["missing"]
    assert (missing.status, missing.title, missing.instance) == (404, "DL_INVALID_ADDRESS", NOPE)
    assert HEX8.fullmatch(missing.main_diagnosis_code)
    assert HEX8.fullmatch(missing.detailed_diagnosis_code)
    assert missing.severity == "Error" and missing.dynamic_description == NOPE
    assert (seen["delete"].status, seen["delete"].instance) == (403, KIN12[0])
    assert seen["no_argument"].status == 400
    # Node-RED's paths go through encodeURI; the log shows the exact requests.
    assert ("PUT", encode_uri(f"/automation/api/v2/nodes/{DTEST}"), 200) in mock.log
    assert ("DELETE", "/identity-manager/api/v2/auth/token", 204) in mock.log


async def test_node_red_subscription_routes_errors_by_instance(tmp_path: Path) -> None:
    app = build_app(subscription_lifetime_s=0.3)
    async with running(app, tls_dir=tmp_path) as mock:
        url = urlsplit(mock.url)
        core = CtrlxCore(str(url.hostname), int(url.port or 443), "boschrexroth", "boschrexroth")
        await asyncio.to_thread(core.log_in)
        config, got = await asyncio.wait_for(asyncio.to_thread(subscribe, core), 30)
        await expired(mock)
    assert ("POST", "/automation/api/v2/events/", 201) in mock.log
    for node_id, node in (("a", KIN12[0]), ("b", KIN12[1])):
        updates = got[node_id]["updates"]
        assert len(updates) >= 3 and {u["node"] for u in updates} == {node}
        assert got[node_id]["errors"] == []  # a bad node must not spoil the others
        assert abs(filetime_to_ms(updates[-1]["timestamp"]) / 1000 - time.time()) < 5.0
    assert got["c"]["updates"] == []
    errors = got["c"]["errors"]
    assert errors and all(e.instance == NOPE and e.status == 404 for e in errors)
    assert config.resets == 0  # every error named its node: the subscription stayed up


async def expired(mock: Mock) -> None:
    """The Node-RED client never deletes; the mock forgets the subscription after its lifetime."""
    async with asyncio.timeout(5):
        while len(mock.state.subscriptions):
            await asyncio.sleep(0.05)
