"""History: every source's samples of the last minutes, poses recomputed on demand."""

from .encode import decode_binary, encode_binary, encode_json
from .reader import HistoryReader, NewRows
from .ring import Rows, SampleRing
from .store import History, Mark, Marks, SourceHistory
from .window import Poses, RobotWindow, robot_window, source_window

__all__ = [
    "History",
    "HistoryReader",
    "NewRows",
    "Mark",
    "Marks",
    "Poses",
    "RobotWindow",
    "Rows",
    "SampleRing",
    "SourceHistory",
    "decode_binary",
    "encode_binary",
    "encode_json",
    "robot_window",
    "source_window",
]
