"""A one-screen summary of a planned trajectory: duration, samples, and per joint the peak
velocity and acceleration as a fraction of its limit (for ``plan`` before its table).

Velocity and acceleration are the planner's finite differences at the sample rate with the
arm at rest before and after ((q_i − q_{i−1})·rate, (q_{i+1} − 2q_i + q_{i−1})·rate²), so a
fraction of 1.0 is exactly what the planner's validation allows.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from robodcn.config import Arm


def trajectory_summary(traj, arm: Arm) -> dict[str, Any]:
    """{"duration_s", "samples", "rate_hz", "method", "joints": [{name, peak_velocity,
    velocity_fraction, peak_acceleration, acceleration_fraction}]} in SI."""
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
            "method": traj.method, "joints": joints}


def trajectory_summary_text(traj, arm: Arm) -> str:
    """:func:`trajectory_summary` in degrees for a terminal, a few lines."""
    s = trajectory_summary(traj, arm)
    method = s["method"] if isinstance(s["method"], str) else ",".join(s["method"])
    lines = [f"# {s['duration_s']:.3f} s, {s['samples']} samples at {s['rate_hz']:g} Hz, "
             f"method {method}"]
    for j in s["joints"]:
        lines.append(f"#   {j['name']:<10} peak {math.degrees(j['peak_velocity']):7.1f}°/s "
                     f"({100 * j['velocity_fraction']:5.1f}% of limit), "
                     f"{math.degrees(j['peak_acceleration']):8.1f}°/s² "
                     f"({100 * j['acceleration_fraction']:5.1f}%)")
    return "\n".join(lines)
