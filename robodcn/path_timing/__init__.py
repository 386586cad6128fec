"""Time-optimal, jerk-limited timing of a fixed geometric joint path (TOPP-RA + jerk pass).

Public interface: :func:`time_optimal` → :class:`PathTiming` (``duration``, ``sample``,
``at``, ``stretch``); :class:`Samples`. numpy only.
"""

from __future__ import annotations

from robodcn.path_timing.law import PathTiming, Samples
from robodcn.path_timing.optimal import path_derivatives, time_optimal

__all__ = ["PathTiming", "Samples", "path_derivatives", "time_optimal"]
