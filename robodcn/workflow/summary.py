"""A one-screen summary of a planned trajectory: duration, samples, and per joint the peak
velocity and acceleration as a fraction of its limit (as data, SI; ``plan`` prints it with
:func:`robodcn.cli.report_text.plan_summary`).

Velocity and acceleration are the planner's finite differences at the sample rate with the
arm at rest before and after ((q_i − q_{i−1})·rate, (q_{i+1} − 2q_i + q_{i−1})·rate²), so a
fraction of 1.0 is exactly what the planner's validation allows. The tool point's peak speed
and where a tool limit binds: :func:`robodcn.planner.tool_peak.tool_peak`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from robodcn.config import Arm
from robodcn.planner.tool_peak import tool_peak


def trajectory_summary(traj, arm: Arm) -> dict[str, Any]:
    """{"duration_s", "samples", "rate_hz", "method", "joints": [{name, peak_velocity,
    velocity_fraction, peak_acceleration, acceleration_fraction}], "tool": {peak_speed, t,
    sample, pose, peak_acceleration, speed_limit, acceleration_limit, binds_from, binds_to,
    binding_share}} in SI."""
    q = traj.joints
    padded = np.concatenate([q[:1], q, q[-1:]])
    vel = np.abs(np.diff(padded, axis=0)[: len(q)]).max(axis=0) * traj.rate_hz
    acc = np.abs(padded[2:] - 2.0 * padded[1:-1] + padded[:-2]).max(axis=0) * traj.rate_hz ** 2
    joints = [{"name": spec.name, "peak_velocity": float(v),
               "velocity_fraction": float(v / spec.max_velocity),
               "peak_acceleration": float(a),
               "acceleration_fraction": float(a / spec.max_acceleration)}
              for spec, v, a in zip(arm.joints, vel, acc, strict=True)]
    return {"duration_s": traj.duration, "samples": len(traj.t), "rate_hz": traj.rate_hz,
            "method": traj.method, "joints": joints, "tool": tool_peak(traj).to_dict()}
