"""Where a plan's path passes its marks: the end of the joint-space approach and the
samples nearest each waypoint (x, y; and z on an arm with a base yaw)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def approach_end(traj) -> int:
    """Index of the first sample on the planned path (after a joint-space approach), 0 when
    the trajectory has no approach: the planner's record (``approach_samples``), else (an
    older trajectory) the first sample at the first waypoint."""
    recorded = int(getattr(traj, "approach_samples", 0) or 0)
    if recorded:
        return recorded
    request = getattr(traj, "request", None)
    if request is None or request.start_joints is None:
        return 0
    width = 3 if np.asarray(traj.poses).shape[1] == 4 else 2   # x, y (and z)
    target = np.asarray(request.waypoints[0][:width])
    close = np.flatnonzero(np.linalg.norm(traj.poses[:, :width] - target, axis=1) < 1e-6)
    return int(close[0]) if close.size else 0


def waypoint_samples(traj, waypoints: NDArray[np.float64] | None) -> list[int]:
    """Sample indices nearest to each waypoint (in order along the path)."""
    if waypoints is None or len(waypoints) == 0:
        return [0, len(traj.t) - 1]
    out, start = [], approach_end(traj)
    width = 3 if np.asarray(traj.poses).shape[1] == 4 else 2   # x, y (and z)
    for w in waypoints:
        d = np.linalg.norm(traj.poses[start:, :width] - np.asarray(w)[:width], axis=1)
        i = start + int(np.argmin(d))
        out.append(i)
        start = i
    return out
