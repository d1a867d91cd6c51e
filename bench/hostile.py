"""A viewer's frame rate and the server's memory while hostile clients attack it.

Runs the attacks of tests/e2e/test_limits.py (a 100 MB body, a 1 MB header,
oversized viewer messages, 2000 idle connections, refused upgrades, a ping
flood that never reads, a message flood, 20 concurrent 10 000-row ``/fk``)
one after the other against one ``python -m server`` process. For each it
reports the frame rate of a protocol-2 viewer reading throughout, beside the
rate it got before any attack, and the server's RSS: its peak during the
attack (sampled every 20 ms) and what is left once the attack is over. The
tests assert only a generous share of the quiet rate; the figures, and issue
20's mark (another viewer keeps 45 of 50 frames/s, memory grows by 20 MB at
most), belong here.

Usage: ``python bench/hostile.py [--rounds 3 | --quick]``; writes docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(ROOT))
from _report import markdown_table, publish  # noqa: E402

from tests.e2e import test_limits as limits  # noqa: E402

ATTACKS: list[tuple[str, Callable[[limits.Server], None]]] = [
    ("100 MB body, declared and streamed", limits.test_a_100_mb_body_is_refused_before_it_is_read),
    ("1 MB request header", limits.test_a_1_mb_header_is_refused),
    (
        "1 MiB viewer message",
        lambda s: limits.test_large_viewer_messages_close_that_viewer_with_1009(s, 1),
    ),
    (
        "16 MiB viewer message",
        lambda s: limits.test_large_viewer_messages_close_that_viewer_with_1009(s, 16),
    ),
    (
        "2000 idle and half-sent connections",
        limits.test_2000_idle_and_half_sent_connections_are_closed,
    ),
    (
        "100 refused upgrades (origin, token)",
        limits.test_foreign_origins_and_bad_tokens_are_refused_without_slowing_viewers,
    ),
    (
        "ping flood, never reading",
        limits.test_a_ping_flood_that_never_reads_is_cut_off_and_its_memory_freed,
    ),
    ("5000-message flood", limits.test_a_message_flood_is_closed_with_1008),
    (
        "20 concurrent 10 000-row /fk",
        limits.test_heavy_transformation_requests_are_bounded_and_the_stream_holds,
    ),
]
MARK_FPS = 45 / 50
"""Issue 20: during any one client's attack another viewer keeps 45 of its 50 frames/s..."""
MARK_MIB = 20.0
"""...and the server's memory grows by 20 MB at most."""
SAMPLE_S = 0.02


class PeakRss(threading.Thread):
    """Samples the server's RSS until stopped; ``peak`` is the most it reached (MiB)."""

    def __init__(self, server: limits.Server) -> None:
        super().__init__(daemon=True)
        self.server = server
        self.peak = server.rss_mib()
        self.done = threading.Event()

    def run(self) -> None:
        while not self.done.wait(SAMPLE_S):
            self.peak = max(self.peak, self.server.rss_mib())


def measure(
    server: limits.Server, attack: Callable[[limits.Server], None]
) -> tuple[float, float, float, str]:
    """One attack: (frames/s, peak RSS growth MiB, RSS growth after it MiB, note)."""
    before = server.rss_mib()
    sampler = PeakRss(server)
    sampler.start()
    note = ""
    try:
        attack(server)
    except AssertionError as exc:  # reported, not hidden: the test would fail too
        note = f"test fails: {str(exc).splitlines()[0]}"
    finally:
        sampler.done.set()
        sampler.join()
    fps, _, left = server.windows[-1]
    return fps, sampler.peak - before, left, note


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rounds", type=int, default=3, help="times each attack runs")
    parser.add_argument("--quick", action="store_true", help="one round")
    args = parser.parse_args()
    rounds = 1 if args.quick else args.rounds
    rows = []
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp, limits.limits_server(Path(tmp) / "log") as server:
        quiet = server.quiet_fps
        for name, attack in ATTACKS:
            runs = [measure(server, attack) for _ in range(rounds)]
            rates = [r[0] for r in runs]
            peak = max(r[1] for r in runs)
            left = max(r[2] for r in runs)
            notes = "; ".join(sorted({r[3] for r in runs if r[3]}))
            fps = statistics.median(rates)
            meets = min(rates) >= MARK_FPS * quiet and peak <= MARK_MIB
            rows.append(
                [
                    name,
                    f"{fps:.1f}",
                    f"{min(rates):.1f}",
                    f"{fps / quiet:.2f}",
                    f"{peak:+.1f}",
                    f"{left:+.1f}",
                    "yes" if meets else "no",
                    notes,
                ]
            )
            print(rows[-1], flush=True)
    load = ", ".join(f"{x:.1f}" for x in load_before)
    body = (
        f"A protocol-2 viewer's frames messages per second during each attack (median and worst "
        f"of {rounds}), against {quiet:.1f}/s before any attack (the source's rate is 50/s). "
        "Server RSS in MiB: the most it grew during the attack (sampled every 20 ms) and what "
        "was left once it was over. *Mark*: issue 20's bound, the worst round at 45/50 of the "
        "quiet rate or better and at most 20 MB more memory. The tests require only a third of "
        f"the quiet rate. Load average before the run {load}: the 2 cores are shared with "
        "other work, so a 'no' on frame rate may be the machine's, not the attack's. The viewer "
        "runs in this process, the server in its own; the 20 heavy requests come from a third "
        "process. Chromium is not involved.\n\n"
        + markdown_table(
            [
                "attack",
                "frames/s",
                "worst",
                "share of quiet",
                "RSS peak",
                "RSS after",
                "mark",
                "",
            ],
            rows,
        )
    )
    publish("bench/hostile.py", "Hostile clients: a viewer's frame rate, the server's memory", body)


if __name__ == "__main__":
    main()
