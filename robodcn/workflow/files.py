"""Files ``robodcn run`` plays: a waypoints TOML, a Trajectory JSON, a JointTrajectory JSON.

- **Waypoints TOML** (``robodcn teach`` writes one): ``[[waypoints]]`` tables with ``x``,
  ``y`` (metres) and ``theta_deg`` (or ``theta``, radians), optionally ``method`` / ``turn``
  / ``beta`` (KenLERP β) for the segment that leads to that waypoint; a ``[plan]`` table
  with ``method``, ``beta``, ``turn`` (the defaults of segments whose waypoint gives none),
  ``duration`` (seconds or "auto"), ``profile``, ``rate_hz``, ``blend``; an optional ``arm``
  name (informational). :func:`load_waypoints` → :class:`WaypointsPlan`,
  whose :meth:`~WaypointsPlan.plan_fields` are :class:`robodcn.planner.PlanRequest` fields.
- **Trajectory JSON** (``robodcn plan --format json``): :meth:`robodcn.planner.Trajectory.from_json`
  with the arm, then checked against this arm's limits and calibration.
- **JointTrajectory JSON**, the shape of ROS ``trajectory_msgs/JointTrajectory``:
  ``joint_names``, ``points`` each with ``positions`` (rad), optional ``velocities`` (rad/s)
  and ``accelerations`` (rad/s²), ``time_from_start {sec, nanosec}``. Joint names must be
  the arm's (any order). Time is shifted so the first point is at t = 0 (the arm approaches
  it first). Resampled at the stream rate by piecewise Hermite interpolation: quintic when
  accelerations are given, cubic with the given velocities, and without velocities cubic with
  the three-point estimate v_k = (p_{k+1} − p_{k−1}) / (t_{k+1} − t_{k−1}) (zero at the first
  and last point: the arm starts and ends at rest). A straight-line interpolation, as a ROS
  controller does with positions only, would step the velocity at every point.

Every parsing problem is an InputError naming the file, the point index and the field; the
resampled motion is checked like a plan (joint and tick limits, velocity and acceleration by
finite differences with the arm at rest before and after) and a violation is the matching
PlanError naming the file, the point the motion is heading to, the time and the joint.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn import contract, kinematics, servo_units
from robodcn.config import Arm
from robodcn.errors import (
    AccelerationLimitError,
    InputError,
    JointLimitError,
    TickLimitError,
    VelocityLimitError,
)
from robodcn.planner import MAX_SAMPLES, Trajectory

#: Slack on limits for float rounding only (as the planner's).
_SLACK = 1e-9
PLAN_KEYS = ("method", "beta", "turn", "duration", "profile", "rate_hz", "blend")


def _fail(path: str, where: str, message: str, value: Any = None) -> InputError:
    return InputError(f"{path}: {where}: {message}", field=where, value=value)


def _read(path: str | Path) -> str:
    try:
        return Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"FILE: cannot read {str(path)!r}: {exc}", field="file",
                         value=str(path)) from exc


# -- waypoints TOML ------------------------------------------------------------------------------

@dataclass(frozen=True)
class WaypointsPlan:
    """A waypoints file: poses (m, 3) in metres and radians, plan options given in the file."""

    source: str
    waypoints: NDArray[np.float64]
    options: dict[str, Any]

    def plan_fields(self, **overrides: Any) -> dict[str, Any]:
        """PlanRequest keyword fields: the file's options, then ``overrides`` not None."""
        fields = dict(self.options)
        fields.update({k: v for k, v in overrides.items() if v is not None})
        fields["waypoints"] = self.waypoints
        return fields


@contextmanager
def _in_file(source: str, where: str) -> Iterator[None]:
    """An InputError of :mod:`robodcn.contract`'s field checks inside, restated naming the
    file and the key (``poses.toml: plan.beta: must be within 0..10, got 12``)."""
    try:
        yield
    except InputError as exc:
        reason = getattr(exc, "reason", None) or exc.message
        raise _fail(source, where, reason, exc.value) from None


def _number(source: str, where: str, value: Any, schema: Mapping[str, Any] | None = None,
            unit: str | None = None) -> float:
    with _in_file(source, where):
        return contract.check_number(where, value, schema or {}, unit)


def _plan_value(source: str, where: str, key: str, value: Any) -> Any:
    """A value of the file's ``[plan]`` (or a waypoint's method, turn or beta), checked as
    the request field ``key`` is (:mod:`robodcn.contract`): one value, not a list."""
    f = contract.field(key)
    with _in_file(source, where):
        if key in ("method", "turn"):
            return contract.check_choice(where, value, f.choices)
        if key == "beta" or (key == "duration" and not isinstance(value, str)):
            return contract.check_number(where, value, f.schema["oneOf"][0], f.unit)
        if key == "duration":
            return contract.check_choice(where, value, ("auto",))
        return contract.check_field(key, value)     # profile, rate_hz, blend


#: What a segment takes when neither its waypoint nor ``[plan]`` says (the contract's).
SEGMENT_DEFAULTS = {key: contract.field(key).default for key in ("method", "turn", "beta")}


def load_waypoints(path: str | Path) -> WaypointsPlan:
    """Read a waypoints TOML (module docstring); InputError naming file and key otherwise."""
    source = str(path)
    try:
        data = tomllib.loads(_read(path))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{source}: invalid TOML: {exc}", field="file", value=source) from exc
    unknown = set(data) - {"arm", "plan", "waypoints"}
    if unknown:
        key = sorted(unknown)[0]
        raise _fail(source, key, "unknown key (allowed: arm, plan, waypoints)", data[key])
    plan = data.get("plan", {})
    if not isinstance(plan, dict):
        raise _fail(source, "plan", "must be a table", plan)
    options: dict[str, Any] = {}
    for key, value in plan.items():
        if key not in PLAN_KEYS:
            raise _fail(source, f"plan.{key}", f"unknown key (allowed: {', '.join(PLAN_KEYS)})",
                        value)
        options[key] = _plan_value(source, f"plan.{key}", key, value)
    rows = data.get("waypoints")
    if not isinstance(rows, list) or len(rows) < 2:
        raise _fail(source, "waypoints", "needs at least two [[waypoints]] tables, got "
                    f"{0 if not isinstance(rows, list) else len(rows)}", None)
    poses = np.empty((len(rows), 3))
    per_segment: dict[str, list[Any]] = {"method": [], "turn": [], "beta": []}
    for i, row in enumerate(rows):
        where = f"waypoints[{i}]"
        if not isinstance(row, dict):
            raise _fail(source, where, "must be a table", row)
        extra = set(row) - {"x", "y", "theta", "theta_deg", *per_segment}
        if extra:
            key = sorted(extra)[0]
            raise _fail(source, f"{where}.{key}", "unknown key (allowed: x, y, theta_deg or "
                        "theta, method, turn, beta)", row[key])
        for key in ("x", "y"):
            if key not in row:
                raise _fail(source, f"{where}.{key}", "missing", None)
        if "theta" in row and "theta_deg" in row:
            raise _fail(source, f"{where}.theta_deg", "give theta_deg or theta, not both",
                        row["theta_deg"])
        x_item, y_item, theta_item = contract.field("waypoints").schema["items"]["prefixItems"]
        theta = (math.radians(_number(source, f"{where}.theta_deg", row["theta_deg"]))
                 if "theta_deg" in row else _number(source, f"{where}.theta",
                                                    row.get("theta", 0.0), theta_item, "rad"))
        poses[i] = (_number(source, f"{where}.x", row["x"], x_item, "m"),
                    _number(source, f"{where}.y", row["y"], y_item, "m"), theta)
        for key in per_segment:
            if key in row and i == 0:
                raise _fail(source, f"{where}.{key}", "the first waypoint starts no segment: "
                            f"give {key} on the waypoint the segment leads to", row[key])
            if i > 0:
                per_segment[key].append(None if key not in row else
                                        _plan_value(source, f"{where}.{key}", key, row[key]))
    for key, values in per_segment.items():
        if any(v is not None for v in values):
            default = options.get(key, SEGMENT_DEFAULTS[key])
            options[key] = tuple(v if v is not None else default for v in values)
    return WaypointsPlan(source, poses, options)


# -- validation of sampled joint motion -----------------------------------------------------------

def check_joint_samples(arm: Arm, joints: NDArray[np.float64], rate_hz: float, *,
                        source: str, point_of_sample: NDArray[np.int64]) -> NDArray[np.int64]:
    """Ticks (n, k) of joint samples at ``rate_hz`` after checking them against ``arm``.

    Checks joint limits, tick limits, velocity (q_i − q_{i−1})·rate and acceleration
    (q_{i+1} − 2q_i + q_{i−1})·rate² with the arm at rest before the first and after the
    last sample (robodcn.planner's rules). The first failing sample raises the matching
    PlanError naming ``source``, ``points[point_of_sample[i]]``, the time and the joint,
    in degrees.
    """
    n = joints.shape[0]
    lo = np.array([j.min_angle for j in arm.joints]) - _SLACK
    hi = np.array([j.max_angle for j in arm.joints]) + _SLACK
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
        (vel > vmax * (1 + _SLACK), VelocityLimitError, "velocity"),
        (acc > amax * (1 + _SLACK), AccelerationLimitError, "acceleration"),
    ]
    first = None
    for bad, cls, what in checks:
        rows = bad.any(axis=1)
        if rows.any():
            i = int(np.argmax(rows))
            if first is None or i < first[0]:
                first = (i, int(np.argmax(bad[i])), cls, what)
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


def _trajectory(arm: Arm, joints: NDArray[np.float64], rate_hz: float, ticks: NDArray,
                method: str) -> Trajectory:
    t = np.arange(joints.shape[0]) / rate_hz
    return Trajectory(t, kinematics.fk(arm.links, joints), joints, ticks, arm.joint_names,
                      arm.servo_ids, rate_hz, method)


# -- Trajectory JSON ------------------------------------------------------------------------------

def load_trajectory(path: str | Path, arm: Arm, *, text: str | None = None) -> Trajectory:
    """A saved Trajectory JSON for ``arm``: same joints and servos, ticks as this arm's
    calibration gives them, every sample inside the arm's limits."""
    source = str(path)
    text = _read(path) if text is None else text
    try:
        traj = Trajectory.from_json(text, arm)
    except InputError as exc:
        raise InputError(f"{source}: {exc.message}", field=exc.field, value=exc.value) from exc
    if tuple(traj.joint_names) != arm.joint_names:
        raise _fail(source, "joint_names", f"{list(traj.joint_names)} do not match arm "
                    f"{arm.name!r} {list(arm.joint_names)}", list(traj.joint_names))
    expected = servo_units.radians_to_ticks(traj.joints, arm.servos)
    if not np.array_equal(expected, traj.ticks):
        i, j = (int(v) for v in np.argwhere(expected != traj.ticks)[0])
        raise _fail(source, f"ticks[{i}][{j}]", f"is {int(traj.ticks[i, j])}, but joint "
                    f"{arm.joint_names[j]!r} at {math.degrees(traj.joints[i, j]):.3f}° is tick "
                    f"{int(expected[i, j])} with this arm's calibration: plan it again for "
                    "this arm", int(traj.ticks[i, j]))
    check_joint_samples(arm, traj.joints, traj.rate_hz, source=source,
                        point_of_sample=np.arange(len(traj.t)))
    return traj


# -- JointTrajectory JSON -------------------------------------------------------------------------

def _seconds(source: str, where: str, stamp: Any) -> float:
    if not isinstance(stamp, dict) or set(stamp) - {"sec", "nanosec"} or "sec" not in stamp:
        raise _fail(source, where, f"must be {{\"sec\": int, \"nanosec\": int}}, got {stamp!r}",
                    stamp)
    sec, nanosec = stamp["sec"], stamp.get("nanosec", 0)
    for key, value in (("sec", sec), ("nanosec", nanosec)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise _fail(source, f"{where}.{key}", f"must be an integer ≥ 0, got {value!r}",
                        value)
    if nanosec >= 1_000_000_000:
        raise _fail(source, f"{where}.nanosec", f"must be below 1000000000, got {nanosec}",
                    nanosec)
    return sec + nanosec * 1e-9


def _vector(source: str, where: str, value: Any, k: int) -> NDArray[np.float64]:
    ok = isinstance(value, list) and len(value) == k and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
        for v in value)
    if not ok:
        raise _fail(source, where, f"must be {k} finite numbers (one per joint name), got "
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
        raise _fail(source, "json", "must be an object", None)
    names = data.get("joint_names")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise _fail(source, "joint_names", f"must be a list of joint names, got {names!r}",
                    names)
    if sorted(names) != sorted(arm.joint_names) or len(set(names)) != len(names):
        raise _fail(source, "joint_names", f"{names} must be the joints of arm {arm.name!r}: "
                    f"{list(arm.joint_names)}", names)
    order = [names.index(n) for n in arm.joint_names]    # file column of each arm joint
    points = data.get("points")
    if not isinstance(points, list) or len(points) < 2:
        raise _fail(source, "points", "needs at least two points", None)
    k = len(names)
    t = np.empty(len(points))
    p = np.empty((len(points), k))
    v = np.empty_like(p)
    a = np.empty_like(p)
    has = {"velocities": [], "accelerations": []}
    for i, point in enumerate(points):
        where = f"points[{i}]"
        if not isinstance(point, dict):
            raise _fail(source, where, "must be an object", point)
        extra = set(point) - {"positions", "velocities", "accelerations", "effort",
                              "time_from_start"}
        if extra:
            key = sorted(extra)[0]
            raise _fail(source, f"{where}.{key}", "unknown field", point[key])
        if "positions" not in point:
            raise _fail(source, f"{where}.positions", "missing", None)
        if "time_from_start" not in point:
            raise _fail(source, f"{where}.time_from_start", "missing", None)
        p[i] = _vector(source, f"{where}.positions", point["positions"], k)[order]
        for key, array in (("velocities", v), ("accelerations", a)):
            given = bool(point.get(key))
            has[key].append(given)
            if given:
                array[i] = _vector(source, f"{where}.{key}", point[key], k)[order]
        t[i] = _seconds(source, f"{where}.time_from_start", point["time_from_start"])
        if i and t[i] <= t[i - 1]:
            raise _fail(source, f"{where}.time_from_start", f"{t[i]:.9g} s must be later than "
                        f"points[{i - 1}]'s {t[i - 1]:.9g} s", t[i])
    for key in ("velocities", "accelerations"):
        if any(has[key]) and not all(has[key]):
            i = has[key].index(False)
            raise _fail(source, f"points[{i}].{key}", f"missing: give {key} on every point or "
                        "on none", None)
    if all(has["accelerations"]) and not all(has["velocities"]):
        raise _fail(source, "points[0].velocities", "accelerations need velocities too", None)
    for i in range(len(points)):
        for j, spec in enumerate(arm.joints):
            if not spec.min_angle - _SLACK <= p[i, j] <= spec.max_angle + _SLACK:
                raise JointLimitError(
                    f"{source}: points[{i}].positions[{names.index(spec.name)}]: joint "
                    f"{spec.name!r} at {math.degrees(p[i, j]):.1f}° is outside its limits "
                    f"{math.degrees(spec.min_angle):.1f}..{math.degrees(spec.max_angle):.1f}°",
                    field=f"points[{i}].positions", value=float(p[i, j]), joint=spec.name)
    t = t - t[0]
    n = math.ceil(t[-1] * rate_hz - 1e-9) + 1
    if n > MAX_SAMPLES:
        raise _fail(source, "points", f"{t[-1]:.1f} s at {rate_hz:g} Hz is {n} samples, more "
                    f"than {MAX_SAMPLES}", n)
    ts = np.minimum(np.arange(n) / rate_hz, t[-1])
    if not all(has["velocities"]):
        v = estimate_velocities(t, p)
    joints = hermite(t, p, v, a if all(has["accelerations"]) else None, ts)
    joints[-1] = p[-1]
    # The point each sample is heading to (sample 0 heads to point 1).
    heading = np.clip(np.searchsorted(t, ts, side="left"), 1, len(t) - 1)
    ticks = check_joint_samples(arm, joints, rate_hz, source=source, point_of_sample=heading)
    return _trajectory(arm, joints, rate_hz, ticks, "joint_trajectory")


def load_joint_trajectory(path: str | Path, arm: Arm, rate_hz: float,
                          text: str | None = None) -> Trajectory:
    """:func:`joint_trajectory` of a JSON file."""
    source = str(path)
    text = _read(path) if text is None else text
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{source}: invalid JSON: {exc}", field="file", value=source) from exc
    return joint_trajectory(data, arm, rate_hz, source=source)


# -- which kind of file -------------------------------------------------------------------------

def file_kind(path: str | Path) -> tuple[str, str | None]:
    """("waypoints" | "trajectory" | "joint_trajectory", the JSON text or None)."""
    source = str(path)
    if Path(path).suffix.lower() == ".toml":
        return "waypoints", None
    text = _read(path)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{source}: neither a waypoints .toml nor valid JSON: {exc}",
                         field="file", value=source) from exc
    if isinstance(data, dict) and "points" in data and "joint_names" in data:
        return "joint_trajectory", text
    if isinstance(data, dict) and "ticks" in data and "t" in data:
        return "trajectory", text
    raise InputError(f"{source}: JSON is neither a Trajectory (t, poses, joints, ticks ...) "
                     "nor a JointTrajectory (joint_names, points)", field="file", value=source)


# -- approach ---------------------------------------------------------------------------------

#: Quintic s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ peaks at ds/dτ = 15/8 and |d²s/dτ²| = 10/√3.
_QUINTIC_PEAK_V = 15.0 / 8.0
_QUINTIC_PEAK_A = 10.0 / math.sqrt(3.0)


def with_approach(traj: Trajectory, arm: Arm, present: NDArray[np.float64]) -> Trajectory:
    """``traj`` with a joint-space quintic from the ``present`` joints to its first sample
    prepended (when they differ by more than half a tick), timed within the joint limits.

    T = max_j max(15/8·|Δq_j|/v_j, √(10/√3·|Δq_j|/a_j)), rounded up to whole sample periods
    and lengthened until the finite-difference checks pass.
    """
    present = np.asarray(present, dtype=np.float64)
    delta = traj.joints[0] - present
    tolerance = min(math.pi / j.servo.ticks_per_turn for j in arm.joints)
    if np.abs(delta).max() <= tolerance:
        return traj
    vmax = np.array([j.max_velocity for j in arm.joints])
    amax = np.array([j.max_acceleration for j in arm.joints])
    need = max(float(np.max(_QUINTIC_PEAK_V * np.abs(delta) / vmax)),
               float(np.max(np.sqrt(_QUINTIC_PEAK_A * np.abs(delta) / amax))))
    rate = traj.rate_hz
    intervals = max(2, math.ceil(need * rate))
    while True:
        tau = np.arange(intervals + 1) / intervals
        s = 10 * tau ** 3 - 15 * tau ** 4 + 6 * tau ** 5
        # The approach ends exactly on the first sample (s = 1 up to rounding).
        joints = np.concatenate([present + np.outer(s[:-1], delta), traj.joints])
        marks = np.concatenate([np.zeros(intervals + 1, dtype=np.int64),
                                np.arange(1, len(traj.t))])
        try:
            ticks = check_joint_samples(arm, joints, rate, source="approach",
                                        point_of_sample=marks)
            break
        except (VelocityLimitError, AccelerationLimitError) as exc:
            if exc.sample is not None and exc.sample > intervals + 1:
                raise
            intervals = math.ceil(intervals * 1.1)
    out = _trajectory(arm, joints, rate, ticks, traj.method if isinstance(traj.method, str)
                      else "joint_trajectory")
    out.request = traj.request
    return out


def trajectory_from_data(data: Any, arm: Arm, rate_hz: float, *, source: str = "trajectory"
                         ) -> Trajectory:
    """A parsed JSON value that is a Trajectory (``plan --format json``) or a JointTrajectory,
    checked for ``arm`` — e.g. the ``trajectory`` field of an HTTP move request. ``rate_hz``
    resamples a JointTrajectory; a Trajectory keeps its own rate."""
    if isinstance(data, dict) and "points" in data and "joint_names" in data:
        return joint_trajectory(data, arm, rate_hz, source=source)
    if isinstance(data, dict) and "ticks" in data and "t" in data:
        return load_trajectory(source, arm, text=json.dumps(data))
    raise InputError(f"{source}: must be a Trajectory (t, poses, joints, ticks, ...) or a "
                     "JointTrajectory (joint_names, points)", field=source, value=None)
