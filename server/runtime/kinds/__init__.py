"""The kinds of source a cell can name, each opened into a connector (and its embedded mock).

A kind is one opener, in a module of its own: from the cell's source and its
robots to a ``Connector`` the shared acquisition follows, the address health
shows, and, for a source without ``url``, the embedded mock it started. Adding
a protocol is adding an opener here (and its keys to ``server.cell.schema``);
nothing downstream changes.
"""

from .ctrlx import open_ctrlx
from .mqtt import open_mqtt
from .opcua import open_opcua
from .opened import Opened, Opener
from .rtde import open_rtde

OPENERS: dict[str, Opener] = {
    "ctrlx": open_ctrlx,
    "rtde": open_rtde,
    "mqtt": open_mqtt,
    "opcua": open_opcua,
}
"""The opener of each ``type`` a cell's source may have (``server.cell.schema.SOURCE_TYPES``)."""

__all__ = ["OPENERS", "Opened", "Opener", "open_ctrlx", "open_mqtt", "open_opcua", "open_rtde"]
