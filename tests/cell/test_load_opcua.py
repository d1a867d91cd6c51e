"""OPC UA sources in cell files: their keys, node keys and units, every mistake named."""

from __future__ import annotations

from pathlib import Path

from server.cell import load_cell
from tests.cell.test_load import problems, write

SOURCE = '[[source]]\nname = "robots"\ntype = "opcua"\n'
ROBOT = """
[[robot]]
name = "lifter"
source = "robots"
joints = [ { node = "nsu=urn:acme:cell;s=Lift.Z" }, { node = "ns=3;i=6012", unit = "rad" } ]

[robot.kinematics]
type = "axis_group"

[[robot.kinematics.axes]]
name = "z"
type = "linear"

[[robot.kinematics.axes]]
name = "turn"
parent = "z"
"""


def test_a_joint_without_unit_takes_its_nodes_engineering_units(tmp_path: Path) -> None:
    cell = load_cell(write(tmp_path, SOURCE + ROBOT), env={}, cache_dir=tmp_path / "cache")
    (source,) = cell.sources
    assert (source.type, source.url, source.user, source.folder) == ("opcua", None, "", tmp_path)
    z, turn = cell.robots[0].joints
    # Delivered in millimetres (linear) by the connector, from whatever the node declares.
    assert (z.node, z.source_unit, z.unit_from_device) == ("nsu=urn:acme:cell;s=Lift.Z", "mm", True)
    assert (turn.source_unit, turn.unit_from_device) == ("rad", False)  # the cell's unit wins


def test_a_ctrlx_joint_without_unit_stays_in_degrees(tmp_path: Path) -> None:
    text = '[[source]]\nname = "robots"\n' + ROBOT.replace(
        '{ node = "nsu=urn:acme:cell;s=Lift.Z" }', '{ node = "z" }'
    )
    assert problems(write(tmp_path, text)) == [
        "robot[0] \"lifter\".joints[0].unit: joint 'z' is linear: unit must be mm or m, not 'deg'"
    ]


def test_opcua_keys_and_node_keys_are_checked(tmp_path: Path) -> None:
    (tmp_path / "robot.der").write_bytes(b"not a certificate")
    source = SOURCE + (
        'url = "https://robot:4840"\nsecurity = "Encrypt"\npassword_env = "ROBOT_PW"\n'
        'server_certificate = "robot.der"\n'
    )
    robot = ROBOT.replace("nsu=urn:acme:cell;s=Lift.Z", "ns=x;s=Lift.Z").replace(
        '{ node = "ns=3;i=6012", unit = "rad" }',
        '{ node = "{urn:acme}Cell/{urn:acme", unit = "rad", setpoint = "nsu=;i=1" }',
    )
    path = write(tmp_path, source + robot)
    assert problems(path, env={"ROBOT_PW": "pw"}) == [
        "source[0] \"robots\".security: must be 'None', 'Sign' or 'SignAndEncrypt', not "
        "'Encrypt' (did you mean 'SignAndEncrypt'?)",
        'source[0] "robots".url: an OPC UA server\'s address starts with opc.tcp://, not '
        "'https://robot:4840'",
        'source[0] "robots".user: required with password_env (else the session is anonymous)',
        f'source[0] "robots".server_certificate: {tmp_path / "robot.der"} holds no certificate '
        "(PEM or DER)",
        'robot[0] "lifter".joints[0].node: not a valid OPC UA NodeId (invalid literal for int() '
        "with base 10: 'x')",
        'robot[0] "lifter".joints[1].node: a namespace URI {... is not closed',
        'robot[0] "lifter".joints[1].setpoint: nsu= needs the namespace\'s URI',
        'robot[0] "lifter".joints[0].setpoint: give every joint a setpoint node, or none',
    ]


def test_a_user_needs_its_password_variable(tmp_path: Path) -> None:
    path = write(tmp_path, SOURCE + 'url = "opc.tcp://robot:4840"\nuser = "operator"\n' + ROBOT)
    assert problems(path) == ["source[0] \"robots\".password_env: required with user 'operator'"]
    path = write(
        tmp_path,
        SOURCE + 'url = "opc.tcp://robot"\nuser = "operator"\npassword_env = "ROBOT_PW"\n' + ROBOT,
    )
    (source,) = load_cell(path, env={"ROBOT_PW": "pw"}, cache_dir=tmp_path / "cache").sources
    assert (source.user, source.password) == ("operator", "pw")
