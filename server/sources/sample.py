"""A sample of the followed nodes: what every kind of source hands to the acquisition."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(slots=True)  # not frozen: made per sample; a frozen init costs 1.5 µs more
class Sample:
    """Values of the followed nodes at one instant, in the nodes' own units.

    Keys are the node keys the cell's joints name (a data-layer path, an OPC UA
    NodeId, an RTDE field, ...). A node that could not be read holds the
    exception saying why, so one bad node spoils only the robot that uses it.
    """

    t_source: float
    """Unix time (s) the device sampled the values (our receive time where it says none)."""
    values: dict[str, float | Exception]
    received: int = 1
    """The device's samples this one stands for: a reader that falls behind keeps the newest
    values of several (latest wins) rather than queueing them."""
