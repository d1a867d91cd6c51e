"""bench/sources.py starts with --help and runs its quick mode (no docs written)."""

from __future__ import annotations

from pathlib import Path

from tests.test_bench import help_text, run_quick

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "bench" / "sources.py"


def test_help_names_the_kinds_it_measures() -> None:
    text = help_text(BENCH)
    assert "ctrlX, RTDE" in text and "OPC UA" in text


def test_quick_mode_measures_every_kind_and_leaves_the_docs_alone(tmp_path: Path) -> None:
    out = run_quick(BENCH, tmp_path)
    rows = [line for line in out.splitlines() if line.startswith("| ")]
    assert [row.split("|")[1].strip() for row in rows[1:]] == ["ctrlx", "rtde", "mqtt", "opcua"]
    # Every kind's sources connected and made frames.
    assert all(row.split("|")[-2].strip() == "2 of 2" for row in rows[1:])
