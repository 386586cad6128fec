"""robodcn: smooth planar rigid-motion trajectories with dual complex numbers, streamed to
Dynamixel servos.

The maths and the planner load eagerly; the servo side (``execute``, ``ServoBus``, ``scan``,
which import dynamixel-sdk) loads on first use, so planning never needs a serial stack.
"""

from __future__ import annotations

import importlib
from typing import Any

from robodcn import dcn, dualquat, errors
from robodcn.config import Arm, load_arm
from robodcn.interpolate import blend, interpolate
from robodcn.planner import PlanRequest, StartState, Trajectory, plan, plan_request

__version__ = "0.1.0"

_LAZY = {
    "execute": "robodcn.stream",
    "ExecutionReport": "robodcn.stream",
    "StopSignal": "robodcn.stream",
    "ServoBus": "robodcn.bus",
    "scan": "robodcn.bus",
}

__all__ = ["Arm", "ExecutionReport", "PlanRequest", "ServoBus", "StartState", "StopSignal",
           "Trajectory",
           "blend", "dcn", "dualquat", "errors", "execute", "interpolate", "load_arm", "plan",
           "plan_request", "scan"]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'robodcn' has no attribute {name!r}")
