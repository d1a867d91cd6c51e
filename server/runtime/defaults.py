"""What every source of a cell takes from the server's settings unless the cell says otherwise."""

from __future__ import annotations

from dataclasses import dataclass

from ..ctrlx import Mode
from ..mock_ctrlx import HOLD_S


@dataclass(frozen=True)
class SourceDefaults:
    """What a cell's source takes from the server's settings unless it says otherwise."""

    period_s: float = 0.02
    mode: Mode = "subscribe"
    """How a ctrlX source reads (``--mode``)."""
    keepalive_s: float = 1.0
    timeout_s: float = 5.0
    allow_commands: bool = False
    history_s: float = 600.0
    """Seconds of samples every source keeps (see server.history)."""
    mock_hold_s: float = HOLD_S
    """How long an embedded mock holds a commanded pose before its demo cycle resumes."""
    sample_cost_s: float = 0.0
    """CPU seconds wasted per sample (a test knob, see Settings.sample_cost_s)."""
