"""The README works when pasted: two commands that make their own venv, a cell that loads."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

from server.cell import load_cell
from server.mock_ctrlx import make_certificate

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()
VENV = "python3 -m venv .venv && . .venv/bin/activate && "


def blocks(language: str) -> list[str]:
    """The README's fenced code blocks in ``language``, in order."""
    return re.findall(rf"^```{language}\n(.*?)^```$", README, re.M | re.S)


def test_exactly_two_commands_each_making_and_using_a_venv() -> None:
    run, test = (block.strip() for block in blocks("sh"))
    assert "\n" not in run and "\n" not in test, "each command is one line to paste"
    # pip on a stock Debian or Ubuntu Python refuses to install outside a venv (PEP 668).
    assert run.startswith(VENV) and run.endswith("python -m server")
    apt, rest = test.split(" && python3 -m venv", 1)
    assert {"chromium", "redis-server", "python3-venv"} <= set(apt.split())
    assert f"python3 -m venv{rest}".startswith(VENV)
    assert rest.index("pip install") < rest.index("python -m pytest")


def test_ci_runs_the_readme_test_command_verbatim() -> None:
    (_, test) = (block.strip() for block in blocks("sh"))
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert ci[-1] == test


def test_the_cell_snippet_loads_as_pasted(tmp_path: Path) -> None:
    (snippet,) = blocks("toml")
    cell_file = tmp_path / "mycell.toml"
    cell_file.write_text(snippet)
    description = ROOT / "cells" / "examples" / "arm6" / "arm6_description"
    shutil.copytree(description, tmp_path / "arm6_description")
    shutil.copy(make_certificate(tmp_path / "tls").ca_file, tmp_path / "line1.pem")
    cell = load_cell(cell_file, env={"LINE1_PASSWORD": "pw"}, cache_dir=tmp_path / "cache")
    (robot,) = cell.robots
    assert robot.name == "arm" and len(robot.joints) == 6
    (source,) = cell.sources
    assert source.url == "https://192.168.1.1" and source.password == "pw"


def test_the_default_controller_login_is_stated() -> None:
    # People must know what linkview tries when they give no user or password.
    assert re.search(r"user and password\s+both default to `boschrexroth`", README)
    assert re.search(r"password comes\s+only ever from the environment", README)
