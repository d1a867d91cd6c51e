"""Hostile cell files saved while the server serves: viewers keep their stream, the server its
memory, and the next good save still reloads.

One server process (``test_limits``' set-up: a token, a viewer reading the
protocol-2 stream throughout) serves a cell of two embedded mocks from a file
the tests overwrite, as a person (or a tool) saving it would: a cell whose new
source cannot start, 400 kB of nested brackets, 100 000 robots in 28 MB, 2 000
robots under the file bound. Each must be refused with its reason (and its
limit) on one line, while both sources keep streaming; the good file, saved
again, runs. ``bench/hostile.py`` runs these attacks for its table.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import urllib.request
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from mcap.writer import Writer

from server.cell.limits import MAX_FILE_BYTES, MAX_ROBOTS
from server.recording.messages import joints_topic
from tests.e2e.test_cells import ARM, cell_text
from tests.e2e.test_limits import AUTH, Server, limits_server
from tests.web._browser import ROOT

SOURCES = """
[[source]]
name = "line1"

[[source]]
name = "line2"
"""
GOOD = cell_text(SOURCES, ("a", "line1", 0.0), ("b", "line2", 500.0))
DEEP = "x = " + "[" * 200_000 + "]" * 200_000 + "\n"
"""400 kB of nested brackets: tomllib recursed until RecursionError, which ended the watcher."""
ANSWER_S = 30.0
"""Each save is answered (reloaded or refused) well within this, even on a loaded machine; a
100 000-robot cell once took 2 min 19 s, then failed asking for 55.9 GiB."""


def many_robots(count: int) -> str:
    """A cell of ``count`` two-axis robots over the two sources."""
    return cell_text(SOURCES, *((f"r{i}", f"line{1 + i % 2}", i * 1.0) for i in range(count)))


def health(server: Server) -> dict[str, Any]:
    request = urllib.request.Request(f"{server.url}/api/health", headers=AUTH)
    try:
        with urllib.request.urlopen(request, timeout=10) as response:
            result: dict[str, Any] = json.loads(response.read())
    except urllib.error.HTTPError as exc:  # 503 while no source is live: still a health body
        result = json.loads(exc.read())
    return result


def answered(server: Server, done: Callable[[dict[str, Any]], bool]) -> dict[str, Any]:
    """Health once ``done(health)`` holds (the test fails after ``ANSWER_S``)."""
    deadline = time.monotonic() + ANSWER_S
    while not done(state := health(server)):
        assert time.monotonic() < deadline, f"no answer within {ANSWER_S} s: {state['cell']}"
        time.sleep(0.1)
    return state


def save(server: Server, text: str) -> None:
    """Write the cell file whole, as an editor saves: into a new file renamed over the old."""
    assert server.cell is not None
    written = server.cell.parent.parent / "saving.toml"  # outside the watched folder
    written.write_text(text)
    os.replace(written, server.cell)


def streaming(state: dict[str, Any], urls: dict[str, str]) -> None:
    """Both sources connected at the addresses they had: never stopped, never restarted."""
    assert {s["name"]: (s["state"], s["url"]) for s in state["sources"]} == {
        name: ("connected", url) for name, url in urls.items()
    }


@contextmanager
def cell_server(folder: Path) -> Iterator[Server]:
    """The attacked server, serving ``GOOD`` from ``folder/cell/cell.toml``."""
    path = folder / "cell" / "cell.toml"  # the log apart: the server watches the cell's folder
    path.parent.mkdir(parents=True)
    path.write_text(GOOD)
    with limits_server(folder / "server.log", "--cell", str(path)) as server:
        server.cell = path
        yield server


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    with cell_server(tmp_path_factory.mktemp("cells")) as running:
        yield running


def restored(server: Server, urls: dict[str, str]) -> None:
    """The good file saved again: no error, and the same sources still streaming."""
    save(server, GOOD)
    names = sorted(urls)
    reloaded = answered(
        server,
        lambda h: h["cell"]["error"] is None and sorted(s["name"] for s in h["sources"]) == names,
    )
    streaming(reloaded, urls)


def urls_of(server: Server) -> dict[str, str]:
    return {s["name"]: s["url"] for s in health(server)["sources"]}


def overflowing_recording(path: Path, robot: str) -> None:
    """An MCAP file whose one sample counter is 2^70: past int64 (it raised OverflowError)."""
    with path.open("wb") as out:
        writer = Writer(out)
        writer.start()
        schema = writer.register_schema("joints", "jsonschema", b"{}")
        channel = writer.register_channel(joints_topic(robot), "json", schema)
        body = {"seq": 2**70, "t_source": 1.0, "position": {"a0": 0.0, "a1": 0.0}}
        writer.add_message(channel, 1, json.dumps(body).encode(), 1)
        writer.finish()


def test_a_recording_with_a_counter_past_int64_is_refused_and_the_sources_keep_streaming(
    server: Server,
) -> None:
    assert server.cell is not None
    urls = urls_of(server)
    overflowing_recording(server.cell.parent / "overflow.mcap", "c")
    broken = GOOD + '\n[[source]]\nname = "replayed"\nreplay = "overflow.mcap"\n'
    broken += ARM.format(name="c", source="replayed", x=1000.0)
    with server.attacked():
        save(server, broken)
        # The recording's counter is refused by name (replay checks each message; before, it
        # raised OverflowError while starting); whether that fails the reload or only its own
        # source, the two sources that were running never stopped.
        state = answered(server, lambda h: "seq not an integer within int64" in json.dumps(h))
        running = [s for s in state["sources"] if s["name"] in urls]
        streaming({**state, "sources": running}, urls)
    with server.attacked():
        restored(server, urls)


def test_deep_nesting_is_one_line_and_the_next_save_reloads(server: Server) -> None:
    urls = urls_of(server)
    with server.attacked():
        save(server, DEEP)
        state = answered(server, lambda h: h["cell"]["error"] is not None)
        error = "cell.toml: (file): nests tables or arrays too deeply to read"
        assert state["cell"]["error"] == error
        streaming(state, urls)
    with server.attacked():
        save(server, GOOD.replace("x = 500.0", "x = 750.0"))  # a change: robot b moves
        state = answered(server, lambda h: h["cell"]["error"] is None)
        streaming(state, urls)  # a base moved: no source restarted
    restored(server, urls)


@pytest.mark.parametrize(
    ("robots", "reason"),
    [
        (100_000, "cell.toml: (file): is "),
        (2 * MAX_ROBOTS, f"cell.toml: robot: 2000 robots; a cell may have at most {MAX_ROBOTS}"),
    ],
)
def test_huge_cells_are_refused_quickly_naming_the_limit(
    server: Server, robots: int, reason: str
) -> None:
    urls = urls_of(server)
    text = many_robots(robots)
    with server.attacked() as window:
        save(server, text)
        state = answered(server, lambda h: h["cell"]["error"] is not None)
        streaming(state, urls)
    assert state["cell"]["error"].startswith(reason)
    if len(text) > MAX_FILE_BYTES:
        mib = MAX_FILE_BYTES >> 20
        assert state["cell"]["error"].endswith(f"MiB; a cell file may be at most {mib}.0 MiB")
    assert window.rss_growth < 64, f"the server grew by {window.rss_growth:.0f} MiB"
    restored(server, urls)


def test_check_names_each_mistake_on_one_line_never_a_traceback(tmp_path: Path) -> None:
    files = {"deep.toml": DEEP, "huge.toml": many_robots(100_000), "many.toml": many_robots(2000)}
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    (tmp_path / "long.toml").write_text(many_robots(30))
    history_s = 86_400
    # Full, a day at 50 Hz (+25 % margin) of two sources of 30 nodes, each row with its time
    # and counter, 8 bytes each:
    full = 2 * round(history_s / 0.02 * 1.25) * (30 + 2) * 8 / 2**20
    huge = len(files["huge.toml"].encode()) / 2**20
    done = subprocess.run(
        [sys.executable, "-m", "server", "check", *sorted(files), "long.toml"],
        cwd=tmp_path,
        env={"PATH": "", "PYTHONPATH": str(ROOT), "LINKVIEW_HISTORY_S": str(history_s)},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert done.stderr.splitlines() == [
        "deep.toml: (file): nests tables or arrays too deeply to read",
        f"huge.toml: (file): is {huge:.1f} MiB; a cell file may be at most 4.0 MiB",
        "many.toml: robot: 2000 robots; a cell may have at most 1000",
        f"long.toml: (cell): its history (86400 s of 60 nodes) would take up to {full:.0f} MiB; "
        "at most 2048 MiB: shorten --history (LINKVIEW_HISTORY_S) or lengthen the sources' "
        "period_ms",
    ]
