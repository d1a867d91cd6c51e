"""linkview's OPC UA client against the mock over loopback: streams, faults, logins, units."""

from __future__ import annotations

import asyncio
import math
import statistics
import time
from pathlib import Path

import numpy as np
import pytest
from cryptography import x509
from cryptography.hazmat.primitives import hashes

from server.mock_ctrlx import AxisGroup, Machine, SimAxis
from server.mock_opcua import MOCK_URI
from server.opcua import UnitRule
from server.sources import Sample, SourceError
from tests.opcua.helpers import IIWA, KIN12, actual, following, running

DI = "http://opcfoundation.org/UA/DI/"
ROBOTICS = "http://opcfoundation.org/UA/Robotics/"


def data_samples(samples: list[Sample]) -> list[Sample]:
    """One sample per device time (the last values are delivered again while nothing changes)."""
    return list({s.t_source: s for s in samples}.values())


def values(sample: Sample, keys: list[str]) -> np.ndarray:
    read = [sample.values[k] for k in keys]
    assert not any(isinstance(v, Exception) for v in read), read
    return np.array(read, dtype=np.float64)


async def test_a_robot_streams_the_simulated_positions_from_one_20_ms_subscription(
    opcua_cache: Path,
) -> None:
    machine = Machine()
    async with running(opcua_cache, machine) as mock, following(mock.url, IIWA) as run:
        await run.samples_after(80)
        follower = run.connector._follower
        assert follower is not None and follower.interval_s <= 0.02  # the revised interval
    samples = data_samples(run.samples)
    for sample in samples[-40:]:
        # The mock wrote the machine's position at the instant it sent as SourceTimestamp
        # (to the microsecond: 60 deg/s moves 6e-5 deg in that).
        expected = machine.group_positions("iiwa", sample.t_source)
        np.testing.assert_allclose(values(sample, IIWA), expected, atol=1e-3)
    stamps = sorted({s.t_source for s in samples})
    # The device's clock: one sample per 20 ms publishing cycle.
    assert statistics.median(np.diff(stamps)) == pytest.approx(0.02, abs=0.002)


async def test_a_dropped_session_is_named_and_a_new_session_streams(opcua_cache: Path) -> None:
    async with running(opcua_cache) as mock:
        async with following(mock.url, KIN12) as run:
            await run.samples_after(5)
            await mock.drop_sessions()
            error = await run.ended()
        assert isinstance(error, SourceError)
        assert "BadSessionIdInvalid" in str(error) and mock.url in str(error)
        async with following(mock.url, KIN12) as again:
            await again.samples_after(5)


async def test_a_restarted_server_is_followed_again_though_its_namespaces_moved(
    opcua_cache: Path,
) -> None:
    machine = Machine()
    async with running(opcua_cache, machine) as mock:
        async with following(mock.url, KIN12) as run:
            await run.samples_after(5)
            before = await _namespace_index(run, MOCK_URI)
            await mock.restart()
            error = await run.ended()
        assert isinstance(error, SourceError) and "connection closed" in str(error)
        async with following(mock.url, KIN12) as again:
            (sample,) = await again.samples_after(1)
            assert await _namespace_index(again, MOCK_URI) == before + 1
        expected = machine.group_positions("kin12", sample.t_source)
        np.testing.assert_allclose(values(sample, KIN12), expected, atol=1e-3)


async def _namespace_index(run: object, uri: str) -> int:
    session = run.connector._session  # type: ignore[attr-defined]
    namespaces = await session.client.get_namespace_array()
    return int(namespaces.index(uri))


async def test_a_stalled_server_is_named(opcua_cache: Path) -> None:
    async with running(opcua_cache) as mock, following(mock.url, KIN12) as run:
        await run.samples_after(5)
        mock.stall()
        error = await run.ended(timeout_s=15.0)
        mock.stall(False)
    assert isinstance(error, SourceError)
    assert "stopped answering" in str(error) or "stalled" in str(error)


async def test_a_wrong_password_is_bad_user_access_denied_naming_the_user(
    opcua_cache: Path,
) -> None:
    users = {"operator": "s3cret"}
    async with running(opcua_cache, users=users, anonymous=False) as mock:
        async with following(mock.url, KIN12, user="operator", password="wrong-pw") as run:
            error = await run.ended()
        assert "BadUserAccessDenied" in str(error) and "'operator'" in str(error)
        assert "wrong-pw" not in str(error)
        async with following(mock.url, KIN12) as anonymous:
            error = await anonymous.ended()
        assert "BadIdentityTokenRejected" in str(error)
        async with following(mock.url, KIN12, user="operator", password="s3cret") as right:
            await right.samples_after(3)


@pytest.mark.parametrize("mode", ["None", "Sign", "SignAndEncrypt"])
async def test_each_security_mode_streams(opcua_cache: Path, tmp_path: Path, mode: str) -> None:
    own = tmp_path / "linkview-opcua-client.der"
    async with running(opcua_cache) as mock:
        trusted = None if mode == "None" else mock.certificate_file
        settings = {"security": mode, "server_certificate": trusted, "client_certificate": own}
        async with following(mock.url, KIN12, **settings) as run:
            await run.samples_after(3)
            policy = run.connector._session.client.security_policy  # type: ignore[union-attr]
            assert policy.Mode.name.rstrip("_") == mode  # asyncua spells None as None_
            assert policy.URI.endswith("#Basic256Sha256" if mode != "None" else "#None")
            made = own.read_bytes() if mode != "None" else b""
        async with following(mock.url, KIN12, **settings) as again:
            await again.samples_after(3)
    if mode == "None":
        assert not own.exists()  # no certificate needed, none made
    else:  # made once, kept beside the cell, reused
        assert own.read_bytes() == made
        assert (tmp_path / "linkview-opcua-client.key.pem").stat().st_mode & 0o077 == 0


async def test_an_untrusted_server_certificate_is_refused_with_its_thumbprint(
    opcua_cache: Path, tmp_path: Path
) -> None:
    own = tmp_path / "linkview-opcua-client.der"
    async with running(opcua_cache) as mock:
        settings = {"security": "Sign", "client_certificate": own, "source": "line1"}
        async with following(mock.url, KIN12, **settings) as run:
            error = await run.ended()
        der = mock.certificate_file.read_bytes()
        print_ = x509.load_der_x509_certificate(der).fingerprint(hashes.SHA1())
        assert ":".join(f"{b:02X}" for b in print_) in str(error)
        saved = tmp_path / "line1-server.der"
        assert saved.read_bytes() == der
        assert "add server_certificate = \"line1-server.der\" to source 'line1'" in str(error)
        # Trusted as the message says, then changed on the server: refused again, anew.
        settings["server_certificate"] = saved
        async with following(mock.url, KIN12, **settings) as trusted:
            await trusted.samples_after(3)
        await mock.change_certificate()
        async with following(mock.url, KIN12, **settings) as changed:
            error = await changed.ended()
        new = x509.load_der_x509_certificate(mock.certificate_file.read_bytes())
        assert new.fingerprint(hashes.SHA1()) != print_
        assert ":".join(f"{b:02X}" for b in new.fingerprint(hashes.SHA1())) in str(error)


async def test_a_missing_node_spoils_only_its_own_value(opcua_cache: Path) -> None:
    system = f"{{{DI}}}DeviceSet/{{{MOCK_URI}}}linkview-mock/{{{ROBOTICS}}}MotionDevices"
    by_path = f"{system}/{{{MOCK_URI}}}kin12/{{{ROBOTICS}}}Axes/{{{MOCK_URI}}}kin12_a0/" + (
        f"{{{DI}}}ParameterSet/{{{ROBOTICS}}}ActualPosition"
    )
    no_device = f"{system}/{{{MOCK_URI}}}nosuch/{{{ROBOTICS}}}Axes"
    no_node = f"nsu={MOCK_URI};s=kin12.nosuch"
    no_namespace = "nsu=urn:nowhere;s=kin12"
    keys = [KIN12[0], by_path, no_device, no_node, no_namespace]
    async with running(opcua_cache) as mock, following(mock.url, keys) as run:
        (sample,) = await run.samples_after(1)
    assert sample.values[by_path] == sample.values[KIN12[0]]
    assert str(sample.values[no_device]) == (
        f"{no_device}: BadNoMatch: no '{{{MOCK_URI}}}nosuch' under {system}"
    )
    assert str(sample.values[no_node]) == f"{no_node}: BadNodeIdUnknown"
    assert "has no namespace 'urn:nowhere'" in str(sample.values[no_namespace])


async def test_nodes_in_degrees_radians_and_millimetres_arrive_in_their_joints_units(
    opcua_cache: Path,
) -> None:
    node = {unit: f"nsu=urn:test:units;s=Cell.{unit}_axis" for unit in ("deg", "rad", "mm")}
    axes = tuple(
        SimAxis(f"{unit}_axis", unit, 1.0, 2.0, -1.0, 1.0, node=node[unit])  # type: ignore[arg-type]
        for unit in ("deg", "rad", "mm")
    )
    machine = Machine([AxisGroup("mixed", axes, ((0.0, 0.0, 0.0), (1.0, -1.0, 1.0)))])
    units = {
        node["deg"]: UnitRule("deg", from_device=True),
        node["rad"]: UnitRule("deg", from_device=True),  # a rotary joint the cell has in deg
        node["mm"]: UnitRule("m", from_device=True),
    }
    async with running(opcua_cache, machine) as mock:
        async with following(mock.url, list(node.values()), units=units) as run:
            # 3 s of the demo's cycle: 0.6 s once fell within its dwell at 0, where no unit shows.
            samples = data_samples(await run.samples_after(150, 30.0))
        async with following(
            mock.url, [node["rad"]], units={node["rad"]: UnitRule("rad", False)}
        ) as kept:
            (held,) = await kept.samples_after(1)
            assert "says its values are in radians" not in (kept.connector.warning or "")
    moving = [s for s in samples if abs(machine.position("rad_axis", s.t_source)) > 0.1]
    assert moving, "the axes were at rest throughout"
    for sample in moving:
        deg, rad, mm = (
            machine.position(f"{u}_axis", sample.t_source) for u in ("deg", "rad", "mm")
        )
        assert sample.values[node["deg"]] == pytest.approx(deg, abs=1e-4)
        assert sample.values[node["rad"]] == pytest.approx(math.degrees(rad), abs=1e-4)
        assert sample.values[node["mm"]] == pytest.approx(mm / 1000.0, abs=1e-7)
    assert held.values[node["rad"]] == pytest.approx(
        machine.position("rad_axis", held.t_source), abs=1e-5
    )


async def test_a_server_that_refuses_subscriptions_is_read_each_period(opcua_cache: Path) -> None:
    machine = Machine()
    async with running(opcua_cache, machine, subscriptions=False) as mock:
        async with following(mock.url, KIN12) as run:
            samples = await run.samples_after(10)
            warning = run.connector.warning
    assert warning is not None and "BadTooManySubscriptions" in warning
    for sample in samples:
        expected = machine.group_positions("kin12", sample.t_source)
        np.testing.assert_allclose(values(sample, KIN12), expected, atol=1e-3)


async def test_a_move_calls_the_motion_devices_method(opcua_cache: Path) -> None:
    machine = Machine()
    async with running(opcua_cache, machine) as mock, following(mock.url, KIN12) as run:
        await run.samples_after(1)
        run.connector.commands["motion/grp/kin12/cmd/pos-abs"] = (
            f"nsu={MOCK_URI};s=kin12.MoveJoints"
        )
        await run.connector.move("motion/grp/kin12/cmd/pos-abs", [10.0, -10.0])
        later = machine.now() + 10.0  # the move has ended, the 30 s hold has not
        np.testing.assert_allclose(machine.group_setpoints("kin12", later), [10.0, -10.0])
        with pytest.raises(SourceError, match="BadOutOfRange"):
            await run.connector.move(f"nsu={MOCK_URI};s=kin12.MoveJoints", [90.0, 0.0])
        with pytest.raises(SourceError) as refused:  # a ctrlX-style default: no such method
            await run.connector.move("motion/grp/other/cmd/pos-abs", [0.0, 0.0])
        assert str(refused.value) == (
            "motion/grp/other/cmd/pos-abs: BadNoMatch: no 'motion' under the Objects folder; "
            "give the robot a command_node naming the OPC UA method that moves it"
        )


def test_axis_names_build_the_keys_the_helpers_use() -> None:
    assert actual("iiwa", "iiwa_a1") == IIWA[0]


async def test_a_robot_at_rest_keeps_streaming_its_last_values_with_their_time(
    opcua_cache: Path,
) -> None:
    still = SimAxis("still", "deg", 1.0, 1.0, -90.0, 90.0)
    machine = Machine([AxisGroup("rest", (still,), ((12.5,),))])
    key = actual("rest", "still")
    async with running(opcua_cache, machine) as mock, following(mock.url, [key]) as run:
        samples = await run.samples_after(30)  # the server sends nothing while nothing changes
        start, began = len(run.samples), time.monotonic()
        await asyncio.sleep(1.0)
        held, elapsed = len(run.samples) - start, time.monotonic() - began
    assert held <= elapsed / 0.02 + 1  # one a period at most: repeats never pile up
    assert {s.values[key] for s in samples} == {12.5}
    assert len({s.t_source for s in samples}) == 1  # no newer time than the server gave
