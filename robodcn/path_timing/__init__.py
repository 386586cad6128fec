"""Time-optimal, jerk-limited timing of a fixed geometric joint path (TOPP-RA + jerk pass).

Public interface: :func:`time_optimal` → :class:`PathTiming` (or its :class:`ChainTiming`
when jerk-limited with stops; ``duration``, ``sample``,
``at``, ``stretch``); :func:`max_start_speed`; :class:`Samples`; :class:`JointLimits` (the
arm's per-joint limits, derived once, with the torque limits and a request's tool limits:
:class:`~robodcn.path_timing.tool.ToolLimits`, the tool point's speed, orientation rate and
acceleration along the path as constraints of the same pass). numpy only.
"""

from __future__ import annotations

from robodcn.path_timing.law import ChainTiming, PathTiming, Samples
from robodcn.path_timing.limits import JointLimits
from robodcn.path_timing.optimal import max_start_speed, path_derivatives, time_optimal

__all__ = ["ChainTiming", "JointLimits", "PathTiming", "Samples", "max_start_speed",
           "path_derivatives", "time_optimal"]
