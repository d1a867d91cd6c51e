"""Many processes and hosts sharing one Redis server: acquisition workers and web replicas.

Workers (``python -m server acquire``) follow the sources they hold leases
for and publish what their acquisitions encode; replicas (``python -m
server --broker URL``) fan it out to viewers. Without a broker, none of
this runs: one process does everything.
"""

from .broker import BrokerSettings, broker_settings
from .replica import Replica
from .worker import Worker, run_worker

__all__ = ["BrokerSettings", "Replica", "Worker", "broker_settings", "run_worker"]
