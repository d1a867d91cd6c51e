"""Every benchmark still starts: each ``bench/*.py`` runs its quickest mode (``--quick``).

Nothing else runs the benchmarks, so an import that moves (``free_port`` left
``tests.web._browser`` once, and two benchmarks failed at import for weeks)
must break the build, not the next measurement. A quick run measures
something small for real (a browser page, a Redis cluster, a mock
controller) and prints its table; it never writes docs/benchmarks.md.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BENCHMARKS = sorted(p for p in (ROOT / "bench").glob("*.py") if not p.name.startswith("_"))
DOC = ROOT / "docs" / "benchmarks.md"
QUICK_LIMIT_S = 300.0
"""A bound, not a figure: the quick runs take 5 to 60 s here; this stops a hung one."""
TABLE_RULE = re.compile(r"^\|(---\|)+$", re.M)
DEDICATED = {
    "hostile": "tests/bench/test_bench_hostile.py",
    "opcua_client": "tests/bench/test_bench_opcua_client.py",
    "page_fps": "tests/bench/test_page_fps.py",
    "sources": "tests/bench/test_bench_sources.py",
}
"""Benchmarks whose quick runs are tests of their own, which read the figures too (and run
each part of bench/hostile.py apart): not run twice."""
RUNS = [p for p in BENCHMARKS if p.stem not in DEDICATED]


def help_text(script: Path) -> str:
    """What ``script --help`` prints (it must succeed: every import of the benchmark works)."""
    done = subprocess.run(
        [sys.executable, str(script), "--help"], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "--quick" in done.stdout  # the mode CI starts it in
    return done.stdout


def run_quick(script: Path, tmp_path: Path, *mode: str) -> str:
    """Run ``script`` (``--quick`` and ``mode``) in ``tmp_path``; its output, once it has
    succeeded, printed a table and left docs/benchmarks.md as it was."""
    doc_before = DOC.read_bytes()
    args = ["--quick", *mode]
    done = subprocess.run(
        [sys.executable, str(script), *args],
        cwd=tmp_path,  # whatever a benchmark writes beside itself lands here, not in the checkout
        env={**os.environ, "LINKVIEW_CACHE_DIR": str(tmp_path / "cache")},  # servers' meshes
        capture_output=True,
        text=True,
        timeout=QUICK_LIMIT_S,
    )
    named = f"{script.name} {' '.join(args)}"
    assert done.returncode == 0, f"{named} failed:\n{done.stderr[-4000:]}"
    assert TABLE_RULE.search(done.stdout), f"{named} printed no table:\n{done.stdout[-2000:]}"
    assert DOC.read_bytes() == doc_before, f"{named} rewrote {DOC.name}"
    return done.stdout


def test_every_benchmark_is_found() -> None:
    names = {p.stem for p in BENCHMARKS}
    assert {"kinematics", "page_fps", "page_trace", "cluster", "viewers"} <= names, names
    assert set(DEDICATED) <= names, "a benchmark that is gone"
    for name, test in DEDICATED.items():  # their own test runs them quick
        assert f'"{name}.py"' in (ROOT / test).read_text(), (name, test)


@pytest.mark.parametrize("script", RUNS, ids=lambda p: p.stem)
def test_benchmark_runs_its_quick_mode(script: Path, tmp_path: Path) -> None:
    run_quick(script, tmp_path)
