"""What every kind of data source shares: samples, errors, and the connector interface.

A source kind (ctrlX's REST data layer, OPC UA, RTDE, MQTT, a recording) is a
``Connector`` that hands ``Sample``s to the acquisition; everything after "a
sample arrived" (kinematics, frames, history, recording, health) is the same
for every kind. Nothing here knows a protocol.
"""

from .connector import Closable, Connector
from .errors import SourceError
from .sample import Sample
from .throttle import Throttle

__all__ = ["Closable", "Connector", "Sample", "SourceError", "Throttle"]
