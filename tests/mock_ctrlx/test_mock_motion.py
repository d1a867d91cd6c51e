"""The mock's motion tree and system metrics: as a controller shows them, and as the spec says.

Every node under ``motion`` and ``framework`` is walked with browse and
metadata requests over HTTP, and each answer is validated against the
vendored ctrlX data-layer description (``tests.mock_ctrlx.spec``).
"""

from __future__ import annotations

from typing import Any

import aiohttp
import numpy as np
import pytest

from server.ctrlx import encode_node_path
from server.mock_ctrlx import Machine, NodeTree, Snapshot, build_app
from tests.ctrlx.helpers import running
from tests.mock_ctrlx.spec import DL, DL_API, FIXED_DL, NODE, component
from tests.mock_ctrlx.test_mock_conformance import exchange, login

SELECTED = {None: "Data", "browse": "BrowseData", "metadata": "MetaData"}


async def ask(
    http: aiohttp.ClientSession, mock: Any, token: str, node: str, kind: str | None
) -> dict[str, Any]:
    """GET ``node`` (read, browse or metadata); request and answer checked against the spec."""
    path = f"{DL}/nodes/{encode_node_path(node)}"
    params = {"type": kind} if kind else None
    status, body = await exchange(
        http, mock, DL_API, "GET", path, NODE, token=token, params=params, validate_body=False
    )
    assert status == 200, (node, kind, body)
    # ReadNode's 200 is oneOf three overlapping schemas: check the one the query selects.
    component(FIXED_DL, SELECTED[kind]).validate(body)
    assert isinstance(body, dict)
    return body


async def test_the_motion_tree_and_metrics_answer_as_the_spec_says() -> None:
    async with running() as mock, aiohttp.ClientSession() as http:
        token = await login(http, mock)
        seen: dict[str, dict[str, Any]] = {}
        pending = ["motion", "framework"]
        while pending:
            node = pending.pop()
            meta = (await ask(http, mock, token, node, "metadata"))["value"]
            seen[node] = meta
            if meta["operations"]["browse"]:
                children = (await ask(http, mock, token, node, "browse"))["value"]
                pending += [f"{node}/{child}" for child in children]
            if meta["operations"]["read"]:
                meta["read"] = await ask(http, mock, token, node, None)
        axes = ["iiwa_a1", "kin12_a0", "pos_turn"]
        for axis in axes:
            for leaf in ("actual/pos", "ipo/pos"):
                node = f"motion/axs/{axis}/state/values/{leaf}"
                assert seen[node]["unit"] == "deg"
                assert seen[node]["read"]["type"] == "double"
            properties = seen[f"motion/axs/{axis}/cfg/properties"]["read"]["value"]
            assert properties["axsType"] == "ROTATIONAL"
        listed = seen["motion/state/axs-list"]["read"]["value"]
        assert len(listed) == 11 and set(axes) <= set(listed)
        assert seen["motion/state/kin-list"]["read"]["value"] == ["kin12", "iiwa"]
        kin = seen["motion/kin/iiwa/cfg"]["read"]["value"]
        assert [a["axsName"] for a in kin["axsCfg"]] == [f"iiwa_a{i}" for i in range(1, 8)]
        assert [a["acsIndex"] for a in kin["axsCfg"]] == list(range(7))
        (trafo,) = kin["mcs"]["axsTrafoSets"]
        assert trafo["jntTrafo"] == "DenavitHartenberg"
        params = {
            p["name"]: (p["valueDouble"], p["unit"]) for p in trafo["param"]["groups"][0]["param"]
        }
        assert params["d1"] == (340.0, "mm") and params["alpha2"] == (90.0, "deg")
        limits = seen["motion/axs/kin12_a0/cfg/lim"]["read"]["value"]
        assert (limits["posMin"], limits["posMax"], limits["posMinUnit"]) == (-40.0, 40.0, "deg")
        assert "posMin" not in seen["motion/axs/pos_turn/cfg/lim"]["read"]["value"]  # endless
        cpu = seen["framework/metrics/system/cpu-utilisation-percent"]
        assert cpu["unit"] == "%" and 0.0 <= cpu["read"]["value"] <= 100.0


def test_setpoints_lead_the_actual_positions_by_the_lag() -> None:
    lag = 0.05
    machine = Machine(lag_s=lag)
    tree = NodeTree(machine)
    actual = "motion/axs/iiwa_a1/state/values/actual/pos"
    setpoint = "motion/axs/iiwa_a1/state/values/ipo/pos"
    moving = 0
    for t in np.linspace(1000.0, 1010.0, 101):
        ahead = tree.read(setpoint, Snapshot(machine, t))["value"]
        assert ahead == pytest.approx(tree.read(actual, Snapshot(machine, t + lag))["value"])
        moving += ahead != tree.read(actual, Snapshot(machine, t))["value"]
    assert moving > 50, "the axis moves, so setpoint and actual differ most of the time"
    ipo = tree.read("motion/axs/iiwa_a1/state/values/ipo", Snapshot(machine, 1000.0))
    assert ipo["value"] == {"ipoPos": tree.read(setpoint, Snapshot(machine, 1000.0))["value"],
                            "ipoPosUnit": "deg"}  # fmt: skip
    with pytest.raises(ValueError, match="lag"):
        Machine(lag_s=-0.1)


async def test_a_command_moves_the_setpoint_first_and_the_actual_after() -> None:
    now, lag = [2000.0], 0.1
    machine = Machine(clock=lambda: now[0], lag_s=lag, hold_s=60.0)
    start = machine.group_setpoints("pos", now[0])[0]
    app = build_app(machine)
    async with running(app) as mock, aiohttp.ClientSession() as http:
        token = await login(http, mock)
        base = "motion/axs/pos_tilt"
        body = {"type": "object", "value": {"axsPos": start + 30.0}}
        path = f"{DL}/nodes/{base}/cmd/pos-abs"
        status, _ = await exchange(http, mock, DL_API, "PUT", path, NODE, token=token, body=body)
        assert status == 200

        async def value(leaf: str) -> float:
            body = await ask(http, mock, token, f"{base}/state/values/{leaf}", None)
            return float(body["value"])

        now[0] += 0.05
        setpoint = await value("ipo/pos")
        assert setpoint > start + 1e-3  # the setpoint is on its way ...
        now[0] += lag
        assert await value("actual/pos") == pytest.approx(setpoint)  # ... the drive follows
        now[0] += 10.0
        for leaf in ("ipo/pos", "actual/pos"):
            assert await value(leaf) == pytest.approx(start + 30.0)


async def test_system_metrics_change_and_add_up() -> None:
    now = [1.0e9]
    app = build_app(Machine(clock=lambda: now[0]))
    names = ["cpu-utilisation-percent", "memtotal-mb", "memused-mb", "memfree-mb",
             "membuffers-mb", "memcache-mb", "memused-percent"]  # fmt: skip
    async with running(app) as mock, aiohttp.ClientSession() as http:
        token = await login(http, mock)
        readings = []
        for _ in range(3):
            values = {}
            for name in names:
                body = await ask(http, mock, token, f"framework/metrics/system/{name}", None)
                values[name] = body["value"]
            readings.append(values)
            now[0] += 7.3
    assert len({r["cpu-utilisation-percent"] for r in readings}) == 3
    assert len({r["memused-mb"] for r in readings}) == 3
    for r in readings:
        parts = r["memused-mb"] + r["memfree-mb"] + r["membuffers-mb"] + r["memcache-mb"]
        assert parts == pytest.approx(r["memtotal-mb"])
        assert r["memused-percent"] == pytest.approx(
            100 * r["memused-mb"] / r["memtotal-mb"], abs=0.05
        )
