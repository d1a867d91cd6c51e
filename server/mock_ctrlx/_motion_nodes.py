"""The motion app's configuration nodes for the mock's axes and kinematics (``motion/...``).

A ctrlX CORE's motion app describes each axis and kinematics in the data
layer; the mock serves the part a client needs to map joints, with the
field names of Bosch Rexroth's motion flatbuffers (``motion.core.fbtypes``:
AxsCfgProperties, AxsCfgLimits, KinCfg, KinCfgAxs, KinCfgJntTrafoSet):

* ``motion/state/axs-list`` and ``motion/state/kin-list``: every axis and
  kinematics name (arstring);
* ``motion/axs/<axis>/cfg/properties``: ``{axsType: ROTATIONAL | LINEAR,
  modulo, moduloValue, moduloValueUnit}``;
* ``motion/axs/<axis>/cfg/lim``: position, velocity and acceleration limits
  with their units (a limit the axis does not have is left out);
* ``motion/kin/<kin>/cfg``: the kinematics' axes (``axsCfg``: name, direction,
  ACS index) and its joint transformation (``mcs.axsTrafoSets``: the
  transformation's name, its axis assignment and its parameters with units).

Values are static: the mock's configuration never changes while it runs.
"""

from __future__ import annotations

import math
from typing import Any

from .machine import AxisGroup, SimAxis

AXES = "motion/axs"
KINEMATICS = "motion/kin"
AXIS_LIST = "motion/state/axs-list"
KIN_LIST = "motion/state/kin-list"
ACTUAL_POS = "state/values/actual/pos"
IPO = "state/values/ipo"
IPO_POS = "state/values/ipo/pos"


def axis_type(axis: SimAxis) -> str:
    """``LINEAR`` or ``ROTATIONAL``, as ``cfg/properties`` says it."""
    return "LINEAR" if axis.unit in ("mm", "m") else "ROTATIONAL"


def axis_config(axis: SimAxis) -> dict[str, dict[str, Any]]:
    """The ``cfg/properties`` and ``cfg/lim`` nodes of an axis, as Data bodies."""
    base = f"{AXES}/{axis.name}/cfg"
    unit = axis.unit
    limits: dict[str, Any] = {}
    if math.isfinite(axis.lo):
        limits.update(posMin=axis.lo, posMinUnit=unit)
    if math.isfinite(axis.hi):
        limits.update(posMax=axis.hi, posMaxUnit=unit)
    limits.update(
        velPos=axis.v_max,
        velNeg=axis.v_max,
        velPosUnit=f"{unit}/s",
        velNegUnit=f"{unit}/s",
        acc=axis.a_max,
        dec=axis.a_max,
        accUnit=f"{unit}/s^2",
        decUnit=f"{unit}/s^2",
    )
    properties = {
        "axsType": axis_type(axis),
        "modulo": False,
        "moduloValue": 0.0,
        "moduloValueUnit": unit,
    }
    return {
        f"{base}/properties": {"type": "object", "value": properties},
        f"{base}/lim": {"type": "object", "value": limits},
    }


def kinematics_config(group: AxisGroup) -> dict[str, Any]:
    """The ``motion/kin/<kin>/cfg`` Data of a group that forms a kinematics."""
    trafo = group.kinematics
    assert trafo is not None, f"group {group.name} is no kinematics"
    axes = [
        {"axsName": axis.name, "axsMeaning": "", "axsDir": "+", "acsIndex": i}
        for i, axis in enumerate(group.axes)
    ]
    assignment = [{"axisName": name, "indexAcs": i} for i, name in enumerate(trafo.axes)]
    params = [
        {"name": name, "valueDouble": value, "unit": unit} for name, value, unit in trafo.params
    ]
    trafo_set = {
        "name": "Default",
        "jntTrafo": trafo.name,
        "param": {
            "axisAssignment": {"assignment": assignment},
            "groups": [{"name": "Geometry", "param": params}],
        },
    }
    value = {"objectType": "Kinematics", "axsCfg": axes, "mcs": {"axsTrafoSets": [trafo_set]}}
    return {"type": "object", "value": value}


def motion_config(axes: list[SimAxis], groups: list[AxisGroup]) -> dict[str, dict[str, Any]]:
    """Every configuration node for ``axes`` (served at ``motion/axs``) and their groups."""
    if not axes:
        return {}
    names = {a.name for a in axes}
    kinematics = [
        g for g in groups if g.kinematics is not None and all(a.name in names for a in g.axes)
    ]
    nodes: dict[str, dict[str, Any]] = {
        AXIS_LIST: {"type": "arstring", "value": [a.name for a in axes]},
        KIN_LIST: {"type": "arstring", "value": [g.name for g in kinematics]},
    }
    for axis in axes:
        nodes.update(axis_config(axis))
    for group in kinematics:
        nodes[f"{KINEMATICS}/{group.name}/cfg"] = kinematics_config(group)
    return nodes
