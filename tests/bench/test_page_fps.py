"""bench/page_fps.py --quick: every case runs and lands in its table; the docs stay as they are."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))
from _report import cpu_model  # noqa: E402


def test_the_quick_run_measures_every_case_and_names_the_cpu() -> None:
    doc = ROOT / "docs" / "benchmarks.md"
    before = doc.read_bytes()
    done = subprocess.run(
        [sys.executable, "bench/page_fps.py", "--quick"],
        cwd=ROOT,
        capture_output=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr.decode()[-3000:]
    out = done.stdout.decode()
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
    assert doc.read_bytes() == before  # a quick run publishes nothing
