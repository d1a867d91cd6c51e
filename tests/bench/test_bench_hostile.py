"""bench/hostile.py starts with --help and runs each part quick (no docs written).

The clients' and the cell files' attacks are also the tests of tests/e2e/test_limits.py and
tests/e2e/test_hostile_cells.py; discover against the mock with 2 000 more axes, 2 % of its
requests failing, is the benchmark's alone, and its figures are checked here.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.test_bench import help_text, run_quick

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "bench" / "hostile.py"


def test_help_names_the_attacks_and_the_parts() -> None:
    text = help_text(BENCH)
    assert "nested brackets" in text and "{clients,cells,discover,network}" in text


def test_quick_discover_finds_every_axis_a_few_requests_at_a_time(tmp_path: Path) -> None:
    out = run_quick(BENCH, tmp_path, "--part", "discover")
    rows = [line.split("|")[1:-1] for line in out.splitlines() if line.startswith("| 2,")]
    (row,) = rows
    served, found, dropped, _, in_flight = (cell.strip() for cell in row[:5])
    assert (served, found, dropped) == ("2,000 + 11", "2011", "0")
    assert int(in_flight) <= 4  # a handful, as docs/cell.md promises


@pytest.mark.parametrize("part", ["clients", "cells", "network"])
def test_each_other_part_runs_quick(part: str, tmp_path: Path) -> None:
    run_quick(BENCH, tmp_path, "--part", part)
