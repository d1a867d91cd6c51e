"""A built wheel, installed in a fresh venv away from the checkout, serves the page and meshes."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import time
import urllib.request
from pathlib import Path

from tests.conftest import free_port

ROOT = Path(__file__).resolve().parent.parent


def lend_dependencies(venv: Path) -> None:
    """Let ``venv`` import the packages of the environment running the tests, after its own.

    ``--system-site-packages`` would lend the base interpreter's packages, which
    are not ours when pytest runs in a venv. The path is added after the wheel is
    installed, so pip never sees this environment's (editable) linkview. Only
    directories are added, never the checkout: an editable install's finder is
    a ``.pth`` hook of the lending environment, which a plain path does not run.
    """
    lent = dict.fromkeys([sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]])
    (site_packages,) = venv.glob("lib/python*/site-packages")
    (site_packages / "_lent_dependencies.pth").write_text("".join(f"{p}\n" for p in lent))


SOURCES = ("pyproject.toml", "setup.py", "README.md", "server", "static", "assets", "cells")
"""What the build reads; copied, so that its build/ and egg-info land beside the copy."""


def source_copy(folder: Path) -> Path:
    """The checkout's build inputs in ``folder`` (tests write only in temporary folders)."""
    folder.mkdir()
    skip = shutil.ignore_patterns("__pycache__", "*.pyc", "node_modules")
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, folder / name, ignore=skip)
        else:
            shutil.copy2(ROOT / name, folder / name)
    return folder


def test_wheel_serves_the_page_and_a_mesh(tmp_path: Path) -> None:
    dist = tmp_path / "dist"
    subprocess.run(
        [sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(dist)],
        cwd=source_copy(tmp_path / "src"),
        check=True,
        capture_output=True,
        timeout=300,
    )
    (wheel,) = dist.glob("linkview-*.whl")
    venv = tmp_path / "venv"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # no checkout on the path
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    python = str(venv / "bin" / "python")
    pip = [python, "-m", "pip", "install", "-q", "--no-deps", str(wheel)]
    subprocess.run(pip, env=env, check=True, capture_output=True, timeout=300)
    lend_dependencies(venv)
    where = subprocess.run(
        [python, "-c", "import server, uvicorn; print(server.__file__)"],
        cwd=tmp_path,
        env=env,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    assert str(venv) in where, f"server imported from {where}, not the wheel"

    port = free_port()
    log = (tmp_path / "server.log").open("wb")
    proc = subprocess.Popen(
        [python, "-m", "server", "--port", str(port)],
        cwd=tmp_path,
        env=env,
        stdout=log,
        stderr=log,
    )
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 30
        while True:
            try:
                with urllib.request.urlopen(f"{base}/", timeout=2) as resp:
                    page = resp.read().decode()
                    break
            except OSError:
                assert proc.poll() is None, (tmp_path / "server.log").read_text()
                assert time.monotonic() < deadline, "the installed server did not answer"
                time.sleep(0.2)
        assert resp.status == 200 and '<script type="module"' in page
        with urllib.request.urlopen(f"{base}/static/js/main.js", timeout=5) as resp:
            assert resp.status == 200
        with urllib.request.urlopen(f"{base}/api/robots", timeout=5) as resp:
            robots = json.load(resp)
        mesh = robots[0]["links"][0]["mesh"]
        with urllib.request.urlopen(base + mesh, timeout=5) as resp:
            assert resp.status == 200 and resp.read(4) == b"glTF"
    finally:
        proc.terminate()
        proc.wait(10)
        log.close()
