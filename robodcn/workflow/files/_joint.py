"""A JointTrajectory JSON (ROS ``trajectory_msgs/JointTrajectory``), resampled at the
stream rate by piecewise Hermite interpolation (the package docstring says how)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn.config import Arm
from robodcn.errors import InputError, JointLimitError
from robodcn.planner import MAX_SAMPLES, Trajectory
from robodcn.workflow.files._common import SLACK, fail, read
from robodcn.workflow.files._samples import check_joint_samples, joint_samples_trajectory


def _seconds(source: str, where: str, stamp: Any) -> float:
    if not isinstance(stamp, dict) or set(stamp) - {"sec", "nanosec"} or "sec" not in stamp:
        raise fail(source, where, f"must be {{\"sec\": int, \"nanosec\": int}}, got {stamp!r}",
                    stamp)
    sec, nanosec = stamp["sec"], stamp.get("nanosec", 0)
    for key, value in (("sec", sec), ("nanosec", nanosec)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise fail(source, f"{where}.{key}", f"must be an integer ≥ 0, got {value!r}",
                        value)
    if nanosec >= 1_000_000_000:
        raise fail(source, f"{where}.nanosec", f"must be below 1000000000, got {nanosec}",
                    nanosec)
    return sec + nanosec * 1e-9


def _vector(source: str, where: str, value: Any, k: int) -> NDArray[np.float64]:
    ok = isinstance(value, list) and len(value) == k and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
        for v in value)
    if not ok:
        raise fail(source, where, f"must be {k} finite numbers (one per joint name), got "
                    f"{value!r}", value)
    return np.asarray(value, dtype=np.float64)


def hermite(t_points: NDArray, p: NDArray, v: NDArray, a: NDArray | None, t: NDArray
            ) -> NDArray[np.float64]:
    """Piecewise Hermite interpolation at times ``t`` (n,) of points (m, k).

    Cubic (p, v at both ends of each interval) or quintic (p, v, a) in the normalised
    time s = (t − t_k)/h, h = t_{k+1} − t_k; e.g. cubic p(s) = (2s³ − 3s² + 1)p_k +
    (s³ − 2s² + s)h·v_k + (−2s³ + 3s²)p_{k+1} + (s³ − s²)h·v_{k+1}.
    """
    k = np.clip(np.searchsorted(t_points, t, side="right") - 1, 0, len(t_points) - 2)
    h = (t_points[k + 1] - t_points[k])[:, None]
    s = ((t - t_points[k])[:, None] / h)
    s2, s3 = s * s, s * s * s
    if a is None:
        return ((2 * s3 - 3 * s2 + 1) * p[k] + (s3 - 2 * s2 + s) * h * v[k]
                + (-2 * s3 + 3 * s2) * p[k + 1] + (s3 - s2) * h * v[k + 1])
    s4, s5 = s3 * s, s3 * s2
    return ((1 - 10 * s3 + 15 * s4 - 6 * s5) * p[k]
            + (s - 6 * s3 + 8 * s4 - 3 * s5) * h * v[k]
            + (0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5) * h * h * a[k]
            + (0.5 * s3 - s4 + 0.5 * s5) * h * h * a[k + 1]
            + (-4 * s3 + 7 * s4 - 3 * s5) * h * v[k + 1]
            + (10 * s3 - 15 * s4 + 6 * s5) * p[k + 1])


def estimate_velocities(t: NDArray, p: NDArray) -> NDArray[np.float64]:
    """Three-point velocities (p_{k+1} − p_{k−1})/(t_{k+1} − t_{k−1}); zero at both ends."""
    v = np.zeros_like(p)
    if len(t) > 2:
        v[1:-1] = (p[2:] - p[:-2]) / (t[2:] - t[:-2])[:, None]
    return v


def joint_trajectory(data: Any, arm: Arm, rate_hz: float, *, source: str = "<json>"
                     ) -> Trajectory:
    """A JointTrajectory dict (module docstring) resampled at ``rate_hz`` and checked."""
    if not isinstance(data, dict):
        raise fail(source, "json", "must be an object", None)
    names = data.get("joint_names")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise fail(source, "joint_names", f"must be a list of joint names, got {names!r}",
                    names)
    if sorted(names) != sorted(arm.joint_names) or len(set(names)) != len(names):
        raise fail(source, "joint_names", f"{names} must be the joints of arm {arm.name!r}: "
                    f"{list(arm.joint_names)}", names)
    order = [names.index(n) for n in arm.joint_names]    # file column of each arm joint
    points = data.get("points")
    if not isinstance(points, list) or len(points) < 2:
        raise fail(source, "points", "needs at least two points", None)
    k = len(names)
    t = np.empty(len(points))
    p = np.empty((len(points), k))
    v = np.empty_like(p)
    a = np.empty_like(p)
    has = {"velocities": [], "accelerations": []}
    for i, point in enumerate(points):
        where = f"points[{i}]"
        if not isinstance(point, dict):
            raise fail(source, where, "must be an object", point)
        extra = set(point) - {"positions", "velocities", "accelerations", "effort",
                              "time_from_start"}
        if extra:
            key = sorted(extra)[0]
            raise fail(source, f"{where}.{key}", "unknown field", point[key])
        if "positions" not in point:
            raise fail(source, f"{where}.positions", "missing", None)
        if "time_from_start" not in point:
            raise fail(source, f"{where}.time_from_start", "missing", None)
        p[i] = _vector(source, f"{where}.positions", point["positions"], k)[order]
        for key, array in (("velocities", v), ("accelerations", a)):
            given = bool(point.get(key))
            has[key].append(given)
            if given:
                array[i] = _vector(source, f"{where}.{key}", point[key], k)[order]
        t[i] = _seconds(source, f"{where}.time_from_start", point["time_from_start"])
        if i and t[i] <= t[i - 1]:
            raise fail(source, f"{where}.time_from_start", f"{t[i]:.9g} s must be later than "
                        f"points[{i - 1}]'s {t[i - 1]:.9g} s", t[i])
    for key in ("velocities", "accelerations"):
        if any(has[key]) and not all(has[key]):
            i = has[key].index(False)
            raise fail(source, f"points[{i}].{key}", f"missing: give {key} on every point or "
                        "on none", None)
    if all(has["accelerations"]) and not all(has["velocities"]):
        raise fail(source, "points[0].velocities", "accelerations need velocities too", None)
    for i in range(len(points)):
        for j, spec in enumerate(arm.joints):
            if not spec.min_angle - SLACK <= p[i, j] <= spec.max_angle + SLACK:
                raise JointLimitError(
                    f"{source}: points[{i}].positions[{names.index(spec.name)}]: joint "
                    f"{spec.name!r} at {math.degrees(p[i, j]):.1f}° is outside its limits "
                    f"{math.degrees(spec.min_angle):.1f}..{math.degrees(spec.max_angle):.1f}°",
                    field=f"points[{i}].positions", value=float(p[i, j]), joint=spec.name)
    t = t - t[0]
    n = math.ceil(t[-1] * rate_hz - 1e-9) + 1
    if n > MAX_SAMPLES:
        raise fail(source, "points", f"{t[-1]:.1f} s at {rate_hz:g} Hz is {n} samples, more "
                    f"than {MAX_SAMPLES}", n)
    ts = np.minimum(np.arange(n) / rate_hz, t[-1])
    if not all(has["velocities"]):
        v = estimate_velocities(t, p)
    joints = hermite(t, p, v, a if all(has["accelerations"]) else None, ts)
    joints[-1] = p[-1]
    # The point each sample is heading to (sample 0 heads to point 1).
    heading = np.clip(np.searchsorted(t, ts, side="left"), 1, len(t) - 1)
    ticks = check_joint_samples(arm, joints, rate_hz, source=source, point_of_sample=heading)
    return joint_samples_trajectory(arm, joints, rate_hz, ticks, "joint_trajectory")


def load_joint_trajectory(path: str | Path, arm: Arm, rate_hz: float,
                          text: str | None = None) -> Trajectory:
    """:func:`joint_trajectory` of a JSON file."""
    source = str(path)
    text = read(path) if text is None else text
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{source}: invalid JSON: {exc}", field="file", value=source) from exc
    return joint_trajectory(data, arm, rate_hz, source=source)
