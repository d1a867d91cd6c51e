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
OTHER_MODES = {"hostile": [["--quick", "--network"]]}
"""Modes that run code the plain ``--quick`` does not (``--network``: issue 34's attacks)."""
RUNS = [(p, ["--quick"]) for p in BENCHMARKS] + [
    (p, mode) for p in BENCHMARKS for mode in OTHER_MODES.get(p.stem, [])
]


def test_every_benchmark_is_found() -> None:
    names = {p.stem for p in BENCHMARKS}
    assert {"kinematics", "page_fps", "page_trace", "cluster", "viewers"} <= names, names
    assert {"sources", "opcua_client", "hostile"} <= names, names
    assert set(OTHER_MODES) <= names, "a mode of a benchmark that is gone"


@pytest.mark.parametrize(
    ("script", "mode"), RUNS, ids=[" ".join([p.stem, *m[1:]]) for p, m in RUNS]
)
def test_benchmark_runs_its_quick_mode(script: Path, mode: list[str], tmp_path: Path) -> None:
    doc_before = DOC.read_bytes()
    done = subprocess.run(
        [sys.executable, str(script), *mode],
        cwd=tmp_path,  # whatever a benchmark writes beside itself lands here, not in the checkout
        env={**os.environ, "LINKVIEW_CACHE_DIR": str(tmp_path / "cache")},  # servers' meshes
        capture_output=True,
        text=True,
        timeout=QUICK_LIMIT_S,
    )
    assert done.returncode == 0, f"{script.name} {' '.join(mode)} failed:\n{done.stderr[-4000:]}"
    assert TABLE_RULE.search(done.stdout), f"{script.name} printed no table:\n{done.stdout[-2000:]}"
    assert DOC.read_bytes() == doc_before, f"{script.name} {' '.join(mode)} rewrote {DOC.name}"
