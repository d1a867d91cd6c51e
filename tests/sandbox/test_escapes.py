"""A cell folder's xacro file can run no code, read no secret and no file outside its folders.

Each attack is a line of a xacro file in a test cell, checked with ``python -m
server check`` while linkview's secrets are set: it is refused with an error
that says what, the marker file it would create never appears, and no secret's
value is in anything ``check`` prints. The code-running payloads are real: the
same files run their command under the ``xacro`` command itself.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from server.cell import load_cell
from tests.sandbox.hostile import check, hostile_cell, secret_env

# python.type and python.vars reach object's subclasses, a function of the os module,
# its globals through the descriptor's __get__, and os.system (no "__" in a name).
VARS_TYPE = """
<xacro:property name="T" value="${{python.type}}"/>
<xacro:property name="V" value="${{python.vars}}"/>
<xacro:property name="fn" value="${{[V(c)['__init__'] for c in V(T)['__subclasses__'](T.mro(T)[1])
  if V(c).get('__module__') == 'os' and '__init__' in V(c)][0]}}"/>
<xacro:property name="gd" value="${{V(T(fn))['__globals__']}}"/>
<link name="${{V(T(gd))['__get__'](gd, fn)['system']('touch {marker}')}}"/>
"""
# A running generator's frame: f_back leads to xacro's own frames and its module's globals.
GENERATOR = """
<xacro:property name="g" value="${{[a.append(x.gi_frame.f_back.f_back.f_back.f_globals
  for x in a) or python.list(a[0]) for a in [[]]][0][0]}}"/>
<link name="${{g['os'].system('touch {marker}')}}"/>
"""
FRAME = """
<link name="${{(x for x in [1]).gi_frame.f_back.f_globals['os'].system('touch {marker}')}}"/>
"""
# str.format walks attributes named in the format string: os.environ's text, secrets and all
# (the format string is a property: xacro ends an expression at its first closing brace).
FORMAT = """
<xacro:property name="f" value="{{0.__globals__[os].environ}}"/>
<link name="${{f.format(xacro.tokenize)}}"/>
"""
FORMAT_MAP = """
<xacro:property name="f" value="{{t.__globals__[os].environ}}"/>
<link name="${{f.format_map(dict(t=xacro.tokenize))}}"/>
"""
ENV = """<link name="secret_$(env LINKVIEW_CTRLX_PASSWORD)"/>"""
HOSTNAME = """<xacro:include filename="/etc/hostname"/>"""
FIND_ETC = """<xacro:include filename="$(find etc)/hostname"/>"""
OUTSIDE_YAML = """<link name="${{xacro.load_yaml('../outside/secret.yaml')['token']}}"/>"""

ATTACKS = {
    "python.vars and python.type": (VARS_TYPE, "'vars' is not allowed"),
    "a generator's frame": (GENERATOR, "attribute 'append' of a list is not allowed"),
    "gi_frame, f_back, f_globals": (FRAME, "attribute 'gi_frame' of a list is not allowed"),
    "a format string's attribute walk": (FORMAT, "attribute 'format' of a str is not allowed"),
    "format_map's attribute walk": (FORMAT_MAP, "attribute 'format_map' of a str"),
    "$(env) of a linkview variable": (
        ENV,
        "environment variable LINKVIEW_CTRLX_PASSWORD is not set (name it in the robot's "
        "kinematics.xacro_env)",
    ),
    "an include of /etc/hostname": (HOSTNAME, "reading of /etc/hostname refused: it is outside"),
    "an include through $(find etc)": (FIND_ETC, "reading of /etc/hostname refused"),
    "xacro.load_yaml outside the folder": (OUTSIDE_YAML, "xacro.load_yaml of"),
}


@pytest.mark.parametrize("name", list(ATTACKS))
def test_an_attack_is_refused_and_gets_nothing(name: str, tmp_path: Path) -> None:
    attack, refusal = ATTACKS[name]
    marker = tmp_path / "MARKER"
    env = secret_env()
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.yaml").write_text(f"token: {env['LINKVIEW_VIEWER_TOKEN']}\n")
    cell = hostile_cell(tmp_path / "cell", attack.format(marker=marker))
    result = check(cell, env)
    said = result.stdout + result.stderr
    assert result.returncode == 1 and "Traceback" not in said, said
    assert refusal in result.stderr, result.stderr
    assert result.stderr.startswith(f'{cell}: robot[0] "arm".kinematics.file: '), result.stderr
    assert not marker.exists()
    for value in env.values():
        assert value not in said
    if os.path.exists("/etc/hostname"):
        hostname = Path("/etc/hostname").read_text().strip()
        assert not hostname or hostname not in said.replace(str(tmp_path), "")


def plain_xacro(path: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    """The ``xacro`` command (the package's own entry point) on ``path``, ``env`` added."""
    xacro = [sys.executable, "-c", "import sys, xacro; sys.argv[0] = 'xacro'; xacro.main()"]
    return subprocess.run(
        [*xacro, str(path)], capture_output=True, text=True, timeout=60, env={**os.environ, **env}
    )


@pytest.mark.parametrize("payload", [VARS_TYPE, GENERATOR, FORMAT, ENV])
def test_the_payloads_get_through_plain_xacro(payload: str, tmp_path: Path) -> None:
    # What the attacks above would do without the sandbox: the xacro command runs them.
    marker = tmp_path / "MARKER"
    env = secret_env()
    cell = hostile_cell(tmp_path / "cell", payload.format(marker=marker))
    result = plain_xacro(cell.parent / "arm.urdf.xacro", env)
    assert marker.exists() or env["LINKVIEW_CTRLX_PASSWORD"] in result.stdout


def test_a_symbolic_link_out_of_the_folder_is_refused(tmp_path: Path) -> None:
    env = secret_env()
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.yaml").write_text(f"token: {env['LINKVIEW_VIEWER_TOKEN']}\n")
    attack = """<link name="${xacro.load_yaml('config.yaml')['token']}"/>"""
    cell = hostile_cell(tmp_path / "cell", attack)
    (cell.parent / "config.yaml").symlink_to(outside / "secret.yaml")
    result = check(cell, env)
    assert result.returncode == 1 and "xacro.load_yaml of" in result.stderr
    assert env["LINKVIEW_VIEWER_TOKEN"] not in result.stdout + result.stderr


def test_named_variables_are_seen_and_no_other(tmp_path: Path) -> None:
    env = {**secret_env(), "ROBOT_PREFIX": "left_"}
    names = ["$(env ROBOT_PREFIX)flange", "tok_$(optenv LINKVIEW_VIEWER_TOKEN none)"]
    names.append("home_$(optenv HOME none)")
    attack = "\n".join(
        f'<link name="{name}"/><joint name="fix{k}" type="fixed"><parent link="tool"/>'
        f'<child link="{name}"/></joint>'
        for k, name in enumerate(names)
    )
    cell = hostile_cell(tmp_path / "cell", attack, extra=', xacro_env = ["ROBOT_PREFIX"]')
    links = load_cell(cell, env=env, cache_dir=tmp_path / "cache").robots[0].link_names
    assert set(links) == {"base", "tool", "left_flange", "tok_none", "home_none"}


def test_a_cell_cannot_hand_a_secret_to_its_description(tmp_path: Path) -> None:
    env = secret_env()
    cell = hostile_cell(tmp_path / "a", "", extra=', xacro_env = ["LINKVIEW_CTRLX_PASSWORD"]')
    result = check(cell, env)
    assert result.returncode == 1
    assert "LINKVIEW_CTRLX_PASSWORD is linkview's own setting, never a description's" in (
        result.stderr
    )
    cell = hostile_cell(tmp_path / "b", "", extra=', xacro_env = ["LINE1_PASSWORD"]')
    cell.write_text(
        cell.read_text().replace(
            'name = "mock"\n',
            'name = "mock"\nurl = "https://192.0.2.1"\npassword_env = "LINE1_PASSWORD"\n',
        )
    )
    result = check(cell, {**env, "LINE1_PASSWORD": "line1-secret"})
    assert result.returncode == 1
    assert "LINE1_PASSWORD holds a source's password: a description never sees it" in (
        result.stderr
    )
    assert "line1-secret" not in result.stdout + result.stderr
