"""OPC UA sources in a running cell: health names what fails, sessions come back, embedded mocks."""

from __future__ import annotations

import asyncio
import contextlib
import time
from pathlib import Path

import numpy as np
import pytest

from server.cell import load_cell
from server.mock_ctrlx import Machine
from server.runtime import Runtime
from server.stream import SourceHealth
from tests.conftest import wait_until
from tests.opcua.helpers import IIWA, running

IIWA_DH = (
    '{ type = "dh", d = [340.0, 0.0, 400.0, 0.0, 400.0, 0.0, 126.0], a = [0.0, 0.0, 0.0, 0.0, '
    "0.0, 0.0, 0.0], alpha_deg = [-90.0, 90.0, 90.0, -90.0, -90.0, 90.0, 0.0], limits = "
    "[[-170.0, 170.0], [-120.0, 120.0], [-170.0, 170.0], [-120.0, 120.0], [-170.0, 170.0], "
    "[-120.0, 120.0], [-175.0, 175.0]] }"
)


def cell_text(
    keys: str, nodes: list[str] = IIWA, source: str = "line1", robot: str = "iiwa7"
) -> str:
    """One OPC UA source with ``keys`` and an LBR iiwa on ``nodes`` (no unit: each node's
    EngineeringUnits; the mock's are degrees)."""
    joints = ", ".join(f'{{ node = "{n}" }}' for n in nodes)
    return (
        f'[[source]]\nname = "{source}"\ntype = "opcua"\n{keys}\n\n[[robot]]\nname = "{robot}"\n'
        f'source = "{source}"\nkinematics = {IIWA_DH}\njoints = [{joints}]\n'
    )


async def started(tmp_path: Path, text: str, env: dict[str, str] | None = None) -> Runtime:
    path = tmp_path / "cell.toml"
    path.write_text(text)
    return await Runtime.start(load_cell(path, env=env or {}, cache_dir=tmp_path / "cache"))


async def error_of(health: SourceHealth, timeout_s: float = 15.0) -> str:
    await wait_until(lambda: health.current_state() == "error", timeout_s)
    assert health.error is not None
    return health.error


async def test_a_dropped_session_is_named_in_health_and_streams_again_within_2_s(
    opcua_cache: Path, tmp_path: Path
) -> None:
    machine = Machine()
    async with running(opcua_cache, machine) as mock:
        runtime = await started(tmp_path, cell_text(f'url = "{mock.url}"'))
        try:
            health = runtime.healths()[0]
            await wait_until(lambda: health.robots.get("iiwa7") and health.robots["iiwa7"].ok)
            values = health.robots["iiwa7"].values
            assert values is not None and np.all(np.abs(values) <= 180.0)  # degrees, as read
            # The error state lasts only until the new session's first sample (well under a
            # second): each error is recorded as marked, with the status shown then, rather
            # than looked for by polling.
            shown: list[str | None] = []
            mark_error = health.mark_error

            def marked(error: str) -> bool:
                changed = mark_error(error)
                shown.append(health.status().error)  # what /api/health and the page show
                return changed

            health.mark_error = marked  # type: ignore[method-assign]
            await mock.drop_sessions()
            dropped = time.monotonic()
            await wait_until(lambda: bool(shown), 15.0)
            assert "BadSessionIdInvalid" in str(shown[0]), shown
            frames = health.robots["iiwa7"].frames
            with contextlib.suppress(TimeoutError):  # a slow machine: the assert says how slow
                await wait_until(
                    lambda: (
                        health.current_state() == "connected"
                        and health.robots["iiwa7"].frames > frames + 5
                    ),
                    20.0,
                )
            took = time.monotonic() - dropped
            assert took < 2.0, f"{took:.1f} s, then {health.current_state()}: {health.error}"
        finally:
            await runtime.stop()


async def test_wrong_credentials_are_named_in_health(opcua_cache: Path, tmp_path: Path) -> None:
    async with running(opcua_cache, users={"operator": "s3cret"}, anonymous=False) as mock:
        source = f'url = "{mock.url}"\nuser = "operator"\npassword_env = "LINE1_PW"'
        runtime = await started(tmp_path, cell_text(source), env={"LINE1_PW": "nope"})
        try:
            error = await error_of(runtime.healths()[0])
        finally:
            await runtime.stop()
    assert error == (
        f"{mock.url}: BadUserAccessDenied: the server refused user 'operator' "
        "(wrong user or password?)"
    )


async def test_an_untrusted_certificate_is_named_in_health_with_the_line_to_add(
    opcua_cache: Path, tmp_path: Path
) -> None:
    async with running(opcua_cache) as mock:
        runtime = await started(tmp_path, cell_text(f'url = "{mock.url}"\nsecurity = "Sign"'))
        try:
            error = await error_of(runtime.healths()[0])
        finally:
            await runtime.stop()
        assert "SHA-1 thumbprint" in error
        assert "add server_certificate = \"line1-server.der\" to source 'line1'" in error
        assert (tmp_path / "line1-server.der").read_bytes() == mock.certificate_file.read_bytes()
        # The line added, the same cell streams signed, with linkview's certificate beside it.
        text = cell_text(
            f'url = "{mock.url}"\nsecurity = "Sign"\nserver_certificate = "line1-server.der"'
        )
        runtime = await started(tmp_path, text)
        try:
            health = runtime.healths()[0]
            await wait_until(lambda: health.current_state() == "connected", 15.0)
        finally:
            await runtime.stop()
    assert (tmp_path / "linkview-opcua-client.der").is_file()


async def test_an_embedded_mock_streams_the_cells_nodes_and_moves_over_opc_ua(
    opcua_cache: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("LINKVIEW_CACHE_DIR", str(opcua_cache))
    nodes = [f"nsu=urn:example:cell;s=Robot1.Joint{i}" for i in range(1, 8)]
    runtime = await started(tmp_path, cell_text("", nodes))
    try:
        health = runtime.healths()[0]
        assert health.mock and health.url.startswith("opc.tcp://127.0.0.1:")
        await wait_until(lambda: health.robots.get("iiwa7") and health.robots["iiwa7"].ok, 30.0)
        robot = runtime.robots[0]
        target = np.radians([10.0, 20.0, -10.0, -30.0, 5.0, 15.0, 0.0])
        await runtime.move(robot, target.tolist())

        def arrived() -> bool:
            values = health.robots["iiwa7"].values
            return values is not None and bool(np.allclose(values, np.degrees(target), atol=1e-6))

        await wait_until(arrived, 20.0)
    finally:
        await runtime.stop()


async def test_a_source_failing_leaves_the_others_streaming(
    opcua_cache: Path, tmp_path: Path
) -> None:
    async with running(opcua_cache) as mock:
        text = cell_text(f'url = "{mock.url}"') + cell_text(
            'url = "opc.tcp://127.0.0.1:9"', source="gone", robot="other"
        )
        runtime = await started(tmp_path, text)
        try:
            live, gone = runtime.healths()
            await wait_until(lambda: live.current_state() == "connected")
            error = await error_of(gone)
            assert "connection refused" in error
            frames = live.robots["iiwa7"].frames
            await asyncio.sleep(0.5)
            assert live.robots["iiwa7"].frames > frames
        finally:
            await runtime.stop()
