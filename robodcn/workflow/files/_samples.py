"""Sampled joint motion checked like a plan, and a Trajectory of it."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from robodcn import servo_units
from robodcn.config import Arm, first_intrusion
from robodcn.errors import (
    AccelerationLimitError,
    JointLimitError,
    KeepOutError,
    TickLimitError,
    VelocityLimitError,
)
from robodcn.messages import point_name
from robodcn.planner import Trajectory
from robodcn.workflow.files._common import SLACK
from robodcn.workflow.poses import tool_poses


def check_joint_samples(arm: Arm, joints: NDArray[np.float64], rate_hz: float, *,
                        source: str, point_of_sample: NDArray[np.int64]) -> NDArray[np.int64]:
    """Ticks (n, k) of joint samples at ``rate_hz`` after checking them against ``arm``.

    Checks joint limits, tick limits, the arm's keep-out zones (every joint centre, the
    tool point and points along the links: :func:`robodcn.config.first_intrusion`),
    velocity (q_i − q_{i−1})·rate and acceleration (q_{i+1} − 2q_i + q_{i−1})·rate² with
    the arm at rest before the first and after the last sample (robodcn.planner's rules).
    The first failing sample raises the matching PlanError naming ``source``,
    ``points[point_of_sample[i]]``, the time and the joint, in degrees (a keep-out zone:
    the point, the zone and how deep, in mm).
    """
    n = joints.shape[0]
    lo = np.array([j.min_angle for j in arm.joints]) - SLACK
    hi = np.array([j.max_angle for j in arm.joints]) + SLACK
    vmax = np.array([j.max_velocity for j in arm.joints])
    amax = np.array([j.max_acceleration for j in arm.joints])
    ticks = servo_units.radians_to_ticks(joints, arm.servos)
    tmin = np.array([j.servo.min_tick for j in arm.joints])
    tmax = np.array([j.servo.max_tick for j in arm.joints])
    padded = np.concatenate([joints[:1], joints, joints[-1:]])
    vel = np.abs(np.diff(padded, axis=0))[:n] * rate_hz           # charged to sample i
    acc = np.abs(padded[2:] - 2.0 * padded[1:-1] + padded[:-2]) * rate_hz ** 2
    checks = [
        (np.maximum(lo - joints, joints - hi) > 0, JointLimitError, "position"),
        ((ticks < tmin) | (ticks > tmax), TickLimitError, "ticks"),
        (vel > vmax * (1 + SLACK), VelocityLimitError, "velocity"),
        (acc > amax * (1 + SLACK), AccelerationLimitError, "acceleration"),
    ]
    first = None
    for bad, cls, what in checks:
        rows = bad.any(axis=1)
        if rows.any():
            i = int(np.argmax(rows))
            if first is None or i < first[0]:
                first = (i, int(np.argmax(bad[i])), cls, what)
    hit = first_intrusion(arm, joints)
    if hit is not None and (first is None or hit.sample < first[0] or (
            hit.sample == first[0] and first[3] not in ("position", "ticks"))):
        point = int(point_of_sample[hit.sample])
        x, y, z = hit.position
        name = point_name(hit.point, hit.joint is not None)
        raise KeepOutError(
            f"{source}: points[{point}] (sample {hit.sample}, t={hit.sample / rate_hz:.3f} s): "
            f"the {name} at x={x:.4f} m, y={y:.4f} m, z={z:.4f} m is "
            f"{hit.depth * 1e3:.1f} mm inside the arm's keep-out zone "
            f"{arm.workspace.describe(hit.zone)}",
            field=f"points[{point}]", value=hit.depth, sample=hit.sample,
            t=hit.sample / rate_hz, point=hit.point, zone=hit.zone, depth=hit.depth,
            position=list(hit.position),
            joint=None if hit.joint is None else arm.joints[hit.joint].name)
    if first is None:
        return ticks
    i, j, cls, what = first
    spec = arm.joints[j]
    d = math.degrees
    if what == "position":
        detail = (f"at {d(joints[i, j]):.1f}° is outside its limits {d(spec.min_angle):.1f}.."
                  f"{d(spec.max_angle):.1f}°")
        value = float(joints[i, j])
    elif what == "ticks":
        detail = (f"needs tick {int(ticks[i, j])} (servo id {spec.servo.id}), outside its "
                  f"tick limits {spec.servo.min_tick}..{spec.servo.max_tick}")
        value = int(ticks[i, j])
    elif what == "velocity":
        detail = (f"needs {d(vel[i, j]):.1f}°/s, limit {d(spec.max_velocity):.1f}°/s: slow "
                  "the file's timing down")
        value = float(vel[i, j])
    else:
        detail = (f"needs {d(acc[i, j]):.1f}°/s², limit {d(spec.max_acceleration):.1f}°/s²: "
                  "slow the file's timing down")
        value = float(acc[i, j])
    point = int(point_of_sample[i])
    raise cls(f"{source}: points[{point}] (sample {i}, t={i / rate_hz:.3f} s): joint "
              f"{spec.name!r} {detail}", field=f"points[{point}]", value=value, sample=i,
              t=i / rate_hz, joint=spec.name)


def joint_samples_trajectory(arm: Arm, joints: NDArray[np.float64], rate_hz: float, ticks: NDArray,
                method: str) -> Trajectory:
    t = np.arange(joints.shape[0]) / rate_hz
    return Trajectory(t, tool_poses(arm, joints), joints, ticks, arm.joint_names,
                      arm.servo_ids, rate_hz, method)
