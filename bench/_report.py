"""Write one benchmark's table into docs/benchmarks.md, leaving other benchmarks' sections alone."""

from __future__ import annotations

import datetime as dt
import os
import platform
import re
from pathlib import Path

DOC = Path(__file__).resolve().parent.parent / "docs" / "benchmarks.md"
HEADER = "# Benchmarks\n\nEach section is rewritten by the script that names it.\n"


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``), or what the platform says."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> str:
    """One line naming the machine the figures come from."""
    cpu = cpu_model()
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, {platform.system()}"


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    """A GitHub markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def publish(script: str, title: str, body: str, *, quick: bool = False) -> None:
    """Print ``body`` and write it as ``script``'s section of docs/benchmarks.md.

    A ``quick`` run (``--quick``: the smallest run that still measures, which
    tests/test_bench.py starts) only prints: its figures are too rough to publish.
    """
    print()
    print(body)
    if not quick:
        write_section(script, title, body)


def write_section(script: str, title: str, body: str) -> None:
    """Replace (or append) the section written by ``script`` in docs/benchmarks.md."""
    stamp = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    start, end = f"<!-- {script}:start -->", f"<!-- {script}:end -->"
    section = f"{start}\n## {title}\n\n`python {script}`, {stamp}, on {machine()}.\n\n{body}\n{end}"
    text = DOC.read_text() if DOC.exists() else HEADER
    pattern = re.compile(re.escape(start) + ".*?" + re.escape(end), re.S)
    text = (
        pattern.sub(lambda _: section, text)
        if pattern.search(text)
        else text + "\n" + section + "\n"
    )
    DOC.parent.mkdir(parents=True, exist_ok=True)
    DOC.write_text(text)
