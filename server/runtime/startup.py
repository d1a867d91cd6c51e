"""From settings to a cell and source defaults: what ``python -m server`` and the app start with."""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

from ..cell import Cell, CellError, load_cell
from ..cell.load import unreadable
from ..cell.schema import CtrlxSource
from ..config import Settings
from ..history import History
from ..history.store import MAX_BYTES
from ..paths import DEMO_CELL
from ..recording import replay_cell
from .source import SourceDefaults, nodes_of

log = logging.getLogger(__name__)


def configured_cell(settings: Settings, path: Path | None = None, text: str | None = None) -> Cell:
    """The cell file ``path`` (default: the settings', else the demo cell), ``--ctrlx`` applied.

    ``--ctrlx URL`` (with ``LINKVIEW_CTRLX_*``) points a one-source cell at a
    controller, which is how the demo cell meets real hardware without a file.
    With ``--replay FILE`` every source plays that recording instead. ``text``:
    the file as edited on the page, not yet saved (``server.commissioning``).
    """
    try:
        if settings.replay is not None:
            cell = replay_cell(settings.replay, path or settings.cell)
        else:
            target = path or settings.cell or DEMO_CELL
            loaded = load_cell(target, text=text, stand_ins=settings.allow_edits or None)
            cell = with_controller(loaded, settings)
    except CellError:
        raise
    except Exception as exc:  # one line at start-up and on reload, as check shows it
        log.debug("reading the cell failed", exc_info=exc)
        raise unreadable(path or settings.cell or settings.replay or DEMO_CELL, exc) from exc
    problems = history_problems(cell, source_defaults(settings))
    if problems:
        raise CellError(cell.path or Path("(cell)"), problems)
    for robot in cell.robots:
        for warning in robot.warnings:
            log.warning("robot %s: %s", robot.name, warning)
    return cell


def history_problems(cell: Cell, defaults: SourceDefaults) -> list[tuple[str, str]]:
    """Why ``cell``'s histories, full, would take more than ``history.store.MAX_BYTES``.

    A replayed source's history is its recording, bounded where it is read.
    """
    history = History(defaults.history_s)
    total, nodes = 0, 0
    for source in cell.sources:
        if source.replay is None:
            count = len(set(nodes_of(cell.robots_of(source.name))))
            total += history.bytes_at_most(count, source.period_s or defaults.period_s)
            nodes += count
    if total <= MAX_BYTES:
        return []
    mib = 1 << 20
    return [
        (
            "(cell)",
            f"its history ({defaults.history_s:g} s of {nodes} nodes) would take up to "
            f"{total / mib:.0f} MiB; at most {MAX_BYTES / mib:.0f} MiB: shorten --history "
            "(LINKVIEW_HISTORY_S) or lengthen the sources' period_ms",
        )
    ]


def with_controller(cell: Cell, settings: Settings) -> Cell:
    """``cell`` with its one source pointed at ``--ctrlx`` (unchanged without it)."""
    if settings.ctrlx_url is None:
        return cell
    if len(cell.sources) != 1:
        raise CellError(
            cell.path or Path("(cell)"),
            [("source", "--ctrlx needs a cell with one source; give each source its url")],
        )
    first = cell.sources[0]
    source = dataclasses.replace(
        first,
        url=settings.ctrlx_url,
        type="ctrlx",
        options=CtrlxSource(
            name=first.name,
            url=settings.ctrlx_url,
            api=settings.ctrlx_api,
            mode=settings.ctrlx_mode,
        ),
        user=settings.ctrlx_user,
        password=settings.ctrlx_password.get_secret_value(),
        ca=settings.ctrlx_ca,
        insecure=settings.insecure,
    )
    return dataclasses.replace(cell, sources=(source,))


def source_defaults(settings: Settings) -> SourceDefaults:
    """What every source of the cell inherits from the settings."""
    return SourceDefaults(
        period_s=settings.poll_interval_s,
        mode=settings.ctrlx_mode,
        keepalive_s=settings.keepalive_s,
        timeout_s=settings.request_timeout_s,
        allow_commands=settings.allow_commands,
        history_s=settings.history_s,
        mock_hold_s=settings.mock_hold_s,
        sample_cost_s=settings.sample_cost_s,
    )
