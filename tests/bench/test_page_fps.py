"""bench/page_fps.py --quick: every case runs and lands in its table; the docs stay as they are."""

from __future__ import annotations

import re
import sys
from pathlib import Path

from tests.test_bench import run_quick

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))
from _report import cpu_model  # noqa: E402


def test_the_quick_run_measures_every_case_and_names_the_cpu(tmp_path: Path) -> None:
    out = run_quick(ROOT / "bench" / "page_fps.py", tmp_path)
    rows = [line for line in out.splitlines() if line.startswith("| ") and "---" not in line]
    cases = [
        "**page, auto** (level",
        "reference: bare cube",
        "page, 2D view (`?view=2d`)",
        "reference: the page's stage",
        "2D view, no WebGL, --disable-gpu",
    ]
    for case in cases:
        (found,) = [row for row in rows if row.startswith(f"| {case}")]
        cells = [cell.strip() for cell in found.strip("|").split("|")]
        assert cells[1] == cpu_model(), found  # the CPU beside each figure
        assert float(cells[2].strip("*")) > 0, found  # it drew
    auto = next(row for row in rows if row.startswith("| **page, auto**"))
    assert re.search(r"\| \d\.\d\d \|", auto), auto  # its ratio to the cube of the same run
