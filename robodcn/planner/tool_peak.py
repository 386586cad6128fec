"""The tool point's speed along a planned trajectory: its peak, and where a tool limit binds.

Measured as the validation measures it (:mod:`robodcn.planner.validate`): the finite
differences of the trajectory's own poses (the FK of its joints) at its rate, at rest before
and after, speed |p_i − p_{i−1}|·rate and acceleration along the path
(|p_{i+1} − p_i| − |p_i − p_{i−1}|)·rate². A limit *binds* at the samples within
:data:`BINDING` of it. The plan summary, ``--plot`` and ``GET /v1/moves/{id}`` report it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["BINDING", "ToolPeak", "tool_peak", "tool_speeds"]

#: A sample at or above this share of a tool limit counts as where the limit binds.
BINDING = 0.99


def tool_speeds(traj: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(speed (n,), acceleration along the path (n,)) of the tool point, m/s and m/s²: speed
    i between samples i − 1 and i (0 at sample 0), acceleration i of the steps into and out
    of sample i (module doc)."""
    poses = np.asarray(traj.poses, dtype=np.float64)
    p = poses[:, :3] if poses.shape[1] == 4 else poses[:, :2]
    p = np.concatenate([p[:1], p, p[-1:]])
    step = np.sqrt(np.einsum("ni,ni->n", np.diff(p, axis=0), np.diff(p, axis=0)))
    rate = float(traj.rate_hz)
    return step[:-1] * rate, np.abs(np.diff(step)) * rate * rate


@dataclass(frozen=True)
class ToolPeak:
    """The tool point's peak speed and acceleration along a trajectory, SI.

    peak_speed : m/s, at ``t`` (s), ``sample`` and ``pose`` (the user's pose there);
    peak_acceleration : m/s² along the path; speed_limit, acceleration_limit : the request's
    ``tool_speed`` and ``tool_acceleration`` (None: not set); binds_from, binds_to : the first
    and last time (s) the speed is within :data:`BINDING` of its limit (None: nowhere), and
    binding_share the share of the samples that are.
    """

    peak_speed: float
    t: float
    sample: int
    pose: tuple[float, ...]
    peak_acceleration: float
    speed_limit: float | None = None
    acceleration_limit: float | None = None
    binds_from: float | None = None
    binds_to: float | None = None
    binding_share: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        return {"peak_speed": self.peak_speed, "t": self.t, "sample": self.sample,
                "pose": list(self.pose), "peak_acceleration": self.peak_acceleration,
                "speed_limit": self.speed_limit,
                "acceleration_limit": self.acceleration_limit,
                "binds_from": self.binds_from, "binds_to": self.binds_to,
                "binding_share": self.binding_share}


def tool_peak(traj: Any) -> ToolPeak:
    """The :class:`ToolPeak` of ``traj`` (a :class:`~robodcn.planner.Trajectory`; its
    request's tool limits, when it has a request)."""
    speed, accel = tool_speeds(traj)
    i = int(np.argmax(speed))
    request = getattr(traj, "request", None)
    limit = getattr(request, "tool_speed", None)
    a_limit = getattr(request, "tool_acceleration", None)
    start = end = None
    share = 0.0
    if limit is not None:
        binding = np.flatnonzero(speed >= BINDING * limit)
        if binding.size:
            start, end = float(traj.t[binding[0]]), float(traj.t[binding[-1]])
            share = binding.size / speed.shape[0]
    return ToolPeak(float(speed[i]), float(traj.t[i]), i,
                    tuple(float(x) for x in np.asarray(traj.poses)[i]), float(accel.max()),
                    limit, a_limit, start, end, share)
