"""bench/opcua_client.py starts with --help and runs its quick mode (no docs written)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.test_bench import help_text, run_quick

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "bench" / "opcua_client.py"


def test_help_says_what_it_measures() -> None:
    text = help_text(BENCH)
    assert "OPC UA sample's CPU" in text


def test_quick_mode_splits_the_opc_ua_clients_cost_and_leaves_the_docs_alone(
    tmp_path: Path,
) -> None:
    out = run_quick(BENCH, tmp_path)
    rows = {
        line.split("|")[1].strip(): float(line.split("|")[2])
        for line in out.splitlines()
        if line.startswith("| ") and not line.startswith("| part")
    }
    parts = [cost for name, cost in rows.items() if name.startswith("OPC UA: ")]
    # The parts add up to the whole (the rest is what the clocks did not cover).
    assert sum(parts) == pytest.approx(rows["OPC UA client, all of it"], abs=0.003)  # 3 decimals
    assert all(cost > 0.0 for cost in parts[:-1])
