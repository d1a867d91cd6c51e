"""Cells past the bounds the server runs are refused, each problem naming its limit, and the
biggest of them before any robot is built."""

from __future__ import annotations

import time
import tomllib
import tracemalloc
from pathlib import Path

import pytest

from server.cell import CellError, load_cell
from server.cell.limits import (
    MAX_DEPTH,
    MAX_FILE_BYTES,
    MAX_NODES,
    MAX_NODES_PER_SOURCE,
    MAX_ROBOTS,
)

JOINTS = 16
"""A 16-axis DH chain (the schema's longest), each axis with its setpoint: 32 nodes a robot."""


def dh_robot(name: str, source: str) -> str:
    zeros = ", ".join(["0.0"] * JOINTS)
    joints = ", ".join(
        f'{{ node = "motion/axs/{name}_{j}/state/values/actual/pos", '
        f'setpoint = "motion/axs/{name}_{j}/state/values/ipo/pos" }}'
        for j in range(JOINTS)
    )
    return (
        f'[[robot]]\nname = "{name}"\nsource = "{source}"\n'
        f'kinematics = {{ type = "dh", d = [{zeros}], a = [{zeros}], alpha_deg = [{zeros}] }}\n'
        f"joints = [{joints}]\n"
    )


def cell_of(path: Path, robots: int, sources: int) -> Path:
    text = "".join(f'[[source]]\nname = "s{s}"\n' for s in range(sources))
    text += "".join(dh_robot(f"r{i}", f"s{i % sources}") for i in range(robots))
    path.write_text(text)
    return path


def problems(path: Path) -> list[tuple[str, str]]:
    with pytest.raises(CellError) as caught:
        load_cell(path, env={}, cache_dir=path.parent)
    return caught.value.problems


def test_a_source_reading_too_many_nodes_names_the_limit(tmp_path: Path) -> None:
    robots = MAX_NODES_PER_SOURCE // (2 * JOINTS) + 1  # one robot too many for one source
    found = problems(cell_of(tmp_path / "cell.toml", robots, sources=1))
    count = robots * 2 * JOINTS
    assert found == [
        ('source[0] "s0"', f"reads {count} nodes; a source may read at most {MAX_NODES_PER_SOURCE}")
    ]


def test_a_cell_reading_too_many_nodes_names_the_limit(tmp_path: Path) -> None:
    sources = -(-MAX_NODES // MAX_NODES_PER_SOURCE) + 1  # each source within its own bound
    robots = MAX_NODES // (2 * JOINTS) + sources
    found = problems(cell_of(tmp_path / "cell.toml", robots, sources))
    assert found == [
        ("(cell)", f"reads {robots * 2 * JOINTS} nodes; a cell may read at most {MAX_NODES}")
    ]


def test_nesting_past_the_bound_is_refused_before_the_schema(tmp_path: Path) -> None:
    path = tmp_path / "cell.toml"
    path.write_text("x = " + "[" * (MAX_DEPTH + 4) + "]" * (MAX_DEPTH + 4) + "\n")
    assert tomllib.loads(path.read_text())  # tomllib reads it: the bound is ours
    assert problems(path) == [("(file)", f"nests tables or arrays more than {MAX_DEPTH} deep")]


def test_too_many_robots_are_refused_before_the_schema_runs(tmp_path: Path) -> None:
    path = cell_of(tmp_path / "cell.toml", MAX_ROBOTS + 1, sources=2)
    start = time.perf_counter()
    tomllib.loads(path.read_text())
    parsing_s = time.perf_counter() - start  # the reference, from the same run
    start = time.perf_counter()
    found = problems(path)
    refusing_s = time.perf_counter() - start
    assert found == [("robot", f"{MAX_ROBOTS + 1} robots; a cell may have at most {MAX_ROBOTS}")]
    # Nothing but the parse: validating and building 1 001 robots takes many times longer.
    assert refusing_s < 3 * parsing_s + 0.05


def test_a_file_past_the_bound_is_not_read_whole(tmp_path: Path) -> None:
    path = tmp_path / "cell.toml"
    with path.open("w") as out:
        out.write('[[source]]\nname = "s"\n')
        out.truncate(3 * MAX_FILE_BYTES)  # a sparse file: 12 MiB, nearly all of it zeros
    tracemalloc.start()
    try:
        found = problems(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert found == [("(file)", "is 12.0 MiB; a cell file may be at most 4.0 MiB")]
    assert peak < MAX_FILE_BYTES + (1 << 20)
