"""Validation of sampled plans: reach, joint and tick limits, finite-difference dynamics.

:func:`check` returns the first failing sample as a :class:`~robodcn.errors.Violation`
(data; the auto-timing search reads it); :func:`raise_for` turns one into its PlanError.

Finite differences at the sample rate (planner module docstring): velocity
(q_i − q_{i−1})·rate is charged to sample i, acceleration (q_{i+1} − 2q_i + q_{i−1})·rate² to
sample i + 1 and jerk (q_{i+2} − 3q_{i+1} + 3q_i − q_{i−1})·rate³ to sample i + 2, the first
sample that cannot be reached in time. The arm rests before t = 0 and after the end, so the
sequence is padded with copies of its first and last samples.

Torque (arms with ``max_torque_nm``): the inverse dynamics (robodcn.dynamics: links, payload
at the tool point, gravity, rotor inertia) of each sample q_i with the central differences
q̇ = (q_{i+1} − q_{i−1})·rate/2 and q̈ = (q_{i+1} − 2q_i + q_{i−1})·rate², charged like the
acceleration to sample i + 1; the payload is the request's ``payload_kg`` (default the
arm's).

Tool limits (a request's ``tool_speed``, ``tool_angular_speed``, ``tool_acceleration``):
the tool point p_i of each sample (the plan's own FK, :func:`robodcn.dynamics.tool_point`)
gives the speed |p_i − p_{i−1}|·rate and the orientation rate max|W (q_i − q_{i−1})|·rate
(:func:`robodcn.path_timing.tool.orientation_rates`), charged to sample i like a joint's
velocity, and the acceleration along the path (|p_i − p_{i−1}| − |p_{i−1} − p_{i−2}|)·rate²
(the second difference of the arc length σ), charged to sample i like a joint's
acceleration (:func:`tool_violation`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import NoReturn

import numpy as np
from numpy.typing import NDArray

from robodcn import kinematics, servo_units
from robodcn.config import DEPTH_SLACK, Arm, Intrusion, first_intrusion
from robodcn.contract.request import PlanRequest
from robodcn.dynamics import tool_point
from robodcn.errors import (
    QUANTITY_UNITS,
    VIOLATION_ERRORS,
    KeepOutError,
    UnreachableError,
    Violation,
)
from robodcn.messages import describe_violation
from robodcn.path_timing.tool import ToolLimits
from robodcn.path_timing.torque import SLACK as TORQUE_SLACK
from robodcn.path_timing.torque import TorqueLimits
from robodcn.planner import arm_arrays

#: Relative slack on velocity/acceleration/jerk limits, for float rounding only (auto timing
#: itself uses the exact limits, so auto plans never rely on it); the torque timing's own
#: tolerance (path_timing.torque.SLACK: one line for timing, holding precheck and validation).
LIMIT_SLACK = TORQUE_SLACK
#: Slack on joint position limits (rad), float rounding only.
ANGLE_SLACK = arm_arrays.ANGLE_SLACK
#: The finite-difference order of each dynamic quantity (what a uniform stretch λ divides by
#: λ^order).
ORDER = {"velocity": 1, "acceleration": 2, "jerk": 3, "torque": 2, "tool_speed": 1,
         "tool_angular_speed": 1, "tool_acceleration": 2}


def fmt_pose(pose: Sequence[float]) -> str:
    return f"x={pose[0]:.4f} m, y={pose[1]:.4f} m, θ={math.degrees(pose[2]):.1f}°"


#: Waypoints whose wrist radius lies this far (m) inside the annulus pass on the plain-float
#: test of :func:`check_waypoints`; closer to an edge the arrays decide (libm's cos, sin and
#: hypot may differ from numpy's by an ulp, ~1e-16 m here).
_CLEAR = 1e-12


def _clear_of_edges(links: Sequence[float], waypoints: Sequence[Sequence[float]]) -> bool:
    """Whether every waypoint's wrist radius |p − l3·(cos θ, sin θ)| (|p| for 2 links) lies
    :data:`_CLEAR` inside the annulus [|l1 − l2|, l1 + l2] ± REACH_TOLERANCE, in plain
    floats: a few poses take a few µs of numpy calls each otherwise."""
    if len(links) not in (2, 3) or len(waypoints) > 16:
        return False
    l1, l2 = links[0], links[1]
    lo = abs(l1 - l2) - kinematics.REACH_TOLERANCE + _CLEAR
    hi = l1 + l2 + kinematics.REACH_TOLERANCE - _CLEAR
    l3 = links[2] if len(links) == 3 else 0.0
    for pose in waypoints:
        x, y = pose[0], pose[1]
        if l3:
            x -= l3 * math.cos(pose[2])
            y -= l3 * math.sin(pose[2])
        if not lo < math.hypot(x, y) < hi:
            return False
    return True


def check_waypoints(req: PlanRequest) -> None:
    """Every waypoint within the workspace annulus, else UnreachableError naming it."""
    arm = req.arm
    if _clear_of_edges(arm.links, req.waypoints):
        return
    wp = req.waypoints_array
    ok = kinematics.reachable(arm.links, wp)
    if ok.all():
        return
    j = int(np.argmin(ok))
    inner, outer = kinematics.workspace(arm.links)
    r = float(kinematics.wrist_radius(arm.links, wp[j:j + 1])[0])
    raise UnreachableError(f"waypoints[{j}] ({fmt_pose(wp[j])}) is out of reach: the wrist "
                           f"point is {r:.4f} m from the base, the arm reaches "
                           f"{inner:.4f}..{outer:.4f} m", field=f"waypoints[{j}]",
                           value=wp[j].tolist(), pose=wp[j].tolist(), waypoint=j)


def check_waypoint_zones(req: PlanRequest, fmt: Callable[[Sequence[float]], str]) -> None:
    """Every waypoint's tool point outside the arm's keep-out zones, else KeepOutError
    naming the first such waypoint, the zone and how deep (before any sampling: the tool
    point of a waypoint is the waypoint itself, whatever the branch); the first of two or
    more is where the motion starts, which the samples' check lets leave a zone. ``fmt``
    words a waypoint (reach.fmt_pose)."""
    zones = req.arm.workspace
    if zones.empty:
        return
    wp = req.waypoints_array
    # the first of two or more is where the motion starts: it may lie inside a zone (the
    # arm fell there) and leave it (config.first_intrusion); a lone waypoint is the goal
    first = 1 if wp.shape[0] > 1 else 0
    tool = np.zeros((wp.shape[0], 3))
    width = 3 if req.arm.yawed else 2
    tool[:, :width] = wp[:, :width]
    depth = zones.depths(tool)
    inside = depth > DEPTH_SLACK
    inside[:first] = False
    if not inside.any():
        return
    j = int(np.argmax(inside.any(axis=1)))
    z = int(np.argmax(np.where(inside[j], depth[j], -np.inf)))
    zone, d = zones.zones[z], float(depth[j, z])
    raise KeepOutError(f"waypoints[{j}] ({fmt(wp[j])}) puts the tool point {d * 1e3:.1f} mm "
                       f"inside the arm's keep-out zone {zones.describe(zone)}: choose a pose "
                       "clear of it", field=f"waypoints[{j}]",
                       value=wp[j].tolist(), pose=wp[j].tolist(), waypoint=j, point="tool",
                       zone=zone, depth=d, position=tool[j].tolist())


def dynamic_limits(arm: Arm) -> tuple[NDArray, NDArray, NDArray]:
    """Per-joint velocity, acceleration and jerk limits (inf where no jerk limit is set;
    read-only, built once per arm: planner.arm_arrays)."""
    consts = arm_arrays.arrays_of(arm)
    return consts.v, consts.a, consts.jerk


def reach_violation(req: PlanRequest, sample: int, pose: Sequence[float],
                    segment: tuple[int, int] | None = None) -> Violation:
    """The "reach" Violation of a sample whose pose the arm cannot reach: its wrist radius
    against the workspace annulus (kinematics.workspace)."""
    pose = tuple(float(x) for x in pose)
    inner, outer = kinematics.workspace(req.arm.links)
    r = float(kinematics.wrist_radius(req.arm.links, [pose])[0])
    return Violation(sample=sample, t=sample / req.rate_hz, pose=pose, quantity="reach",
                     value=r, limit=outer if r > outer else inner, unit="m", segment=segment,
                     field="waypoints")


def raise_unreachable_pose(req: PlanRequest, pose: Sequence[float]) -> NoReturn:
    """UnreachableError for a path pose that no sample names (the geometry leaves the
    workspace before any timing)."""
    pose = [float(x) for x in pose]
    inner, outer = kinematics.workspace(req.arm.links)
    r = float(kinematics.wrist_radius(req.arm.links, [pose])[0])
    raise UnreachableError(f"the path leaves the workspace at {fmt_pose(pose)}: the wrist "
                           f"point is {r:.4f} m from the base, the arm reaches "
                           f"{inner:.4f}..{outer:.4f} m", field="waypoints", value=pose,
                           pose=pose)


def differences(joints: NDArray, order: int, history: NDArray | None = None) -> NDArray:
    """|Δ^order q| at rest on both sides (or after the samples ``history`` before t = 0), row
    r charged to sample min(r, n − 1)."""
    pre = np.repeat(joints[:1], order, axis=0) if history is None else history[-order:]
    padded = np.concatenate([pre, joints, np.repeat(joints[-1:], order - 1, axis=0)])
    d = np.abs(np.diff(padded, n=order, axis=0))
    n = joints.shape[0]
    if d.shape[0] > n:  # differences past the end belong to the last sample
        d = np.concatenate([d[:n - 1], d[n - 1:].max(axis=0, keepdims=True)])
    return d


def torque_limits(req: PlanRequest) -> TorqueLimits | None:
    """The request's torque limits: the arm's ``max_torque_nm`` with the request's payload
    (``payload_kg``, default the arm's), None when no joint sets one."""
    if not arm_arrays.arrays_of(req.arm).torque_limited:
        return None
    # TorqueLimits.of builds the arm's rigid-body model (~40 µs): once per arm and payload
    return arm_arrays.limits_of(req.arm, getattr(req, "payload_kg", None)).torque


def sample_torques(torque: TorqueLimits, joints: NDArray, rate: float,
                   history: NDArray | None = None, *, gravity: bool = True
                   ) -> tuple[NDArray, NDArray | None]:
    """(τ, g), each (n, k): the torque of every sample's central differences (module doc),
    row r charged to sample min(r, n − 1) as :func:`differences` charges the acceleration
    (the larger |τ| of the rows past the end), and the gravity torque of the same rows
    (``gravity=False``: None, one inverse-dynamics pass instead of two)."""
    pre = np.repeat(joints[:1], 2, axis=0) if history is None else history[-2:]
    padded = np.concatenate([pre, joints, joints[-1:]])
    mid = padded[1:-1]
    qd = (padded[2:] - padded[:-2]) * (0.5 * rate)
    qdd = (padded[2:] - 2.0 * mid + padded[:-2]) * (rate * rate)
    tau = torque.torques(mid, qd, qdd)
    grav = torque.torques(mid, np.zeros_like(mid), np.zeros_like(mid)) if gravity else None
    n = joints.shape[0]
    if tau.shape[0] > n:  # rows past the end belong to the last sample
        last = np.argmax(np.abs(tau[n - 1:]), axis=0)
        cols = np.arange(tau.shape[1])
        tau = np.concatenate([tau[:n - 1], tau[n - 1:][last, cols][None]])
        if grav is not None:
            grav = np.concatenate([grav[:n - 1], grav[n - 1:][last, cols][None]])
    return tau, grav


def _tick_of(x: float, scale: float, offset: int) -> int:
    """servo_units.ticks_unchecked of one angle in plain floats: offset + round half away
    from zero of x·scale (the same product, floor(|y| + 0.5) and sign)."""
    y = x * scale
    return offset + int(math.copysign(math.floor(abs(y) + 0.5), y))


def _fine(joints: NDArray, ticks: NDArray, lo: NDArray, hi: NDArray, tmin: NDArray,
          tmax: NDArray, limits: tuple[NDArray, NDArray, NDArray] | None, rate: float,
          slack: float, columns: tuple[list[float], list[int]] | None = None) -> bool:
    """Whether every check passes, from per-joint extremes on contiguous columns (the fast
    path: per-sample arrays are built only when something fails); a short plan's whole
    arrays at once (:data:`FINE_BLOCK_ROWS`), the same extremes. ``columns``: the tick
    conversion's (scale, offset) when ``ticks`` are its output: a column's tick extremes
    are then the ticks of its angle extremes (the conversion is monotone, rising with a
    positive scale, falling with a negative one), no pass over the ticks."""
    n = joints.shape[0]
    if n < FINE_BLOCK_ROWS:
        return _fine_block(joints, ticks, lo, hi, tmin, tmax, limits, rate, slack)
    for j in range(joints.shape[1]):
        q = np.ascontiguousarray(joints[:, j])
        q_lo, q_hi = float(q.min()), float(q.max())
        if not (lo[j] <= q_lo and q_hi <= hi[j]):
            return False
        if columns is None:
            tick = np.ascontiguousarray(ticks[:, j])
            t_lo, t_hi = tick.min(), tick.max()
        else:
            scale, offset = columns[0][j], columns[1][j]
            t_lo, t_hi = (_tick_of(q_lo, scale, offset), _tick_of(q_hi, scale, offset))
            if scale < 0.0:
                t_lo, t_hi = t_hi, t_lo
        if not (tmin[j] <= t_lo and t_hi <= tmax[j]):
            return False
        if limits is None or n < 2:
            continue
        v, a, jk = limits
        d = q[1:] - q[:-1]  # np.diff's own subtraction, without its wrapper
        if max(d.max(), -d.min()) * rate > v[j] * slack:
            return False
        # At rest on both sides: the end velocities are accelerations from/to zero.
        d2 = d[1:] - d[:-1] if n > 2 else np.empty(0)
        step = max(abs(d[0]), abs(d[-1]), d2.max(initial=0.0), -d2.min(initial=0.0))
        if step * rate * rate > a[j] * slack:
            return False
        if math.isfinite(jk[j]):
            d3 = differences(q[:, None], 3)
            if d3.max() * rate ** 3 > jk[j] * slack:
                return False
    return True


#: Plans shorter than this are checked on their whole (n, k) arrays at once (fewer numpy
#: calls), longer ones a contiguous joint column at a time (each stays in cache): the same
#: crossover as the tick conversion's, on the same arrays.
FINE_BLOCK_ROWS = servo_units.WHOLE_ROWS


_min, _max = np.minimum.reduce, np.maximum.reduce


def _listed(x: NDArray | list) -> list:
    return x.tolist() if isinstance(x, np.ndarray) else x


def _fine_block(joints: NDArray, ticks: NDArray, lo: NDArray | list, hi: NDArray | list,
                tmin: NDArray | list, tmax: NDArray | list,
                limits: tuple[NDArray | list, NDArray | list, NDArray | list] | None,
                rate: float, slack: float) -> bool:
    """:func:`_fine` on the whole arrays: the same per-joint extremes and comparisons, the
    k comparisons of each in plain floats (the limits may come as lists: check's, built
    once per arm). The differences run on the samples padded with their first and last
    (at rest on both sides): the end velocities' steps from and to zero are then rows of
    the second difference, the same numbers as |q₁ − q₀| and |q_n − q_{n−1}|."""
    n = joints.shape[0]
    k = joints.shape[1]
    # ndarray.min/max as the ufuncs' reduce: the same extremes without numpy's wrappers
    q_lo, q_hi = _min(joints, axis=0).tolist(), _max(joints, axis=0).tolist()
    t_lo, t_hi = _min(ticks, axis=0).tolist(), _max(ticks, axis=0).tolist()
    lo, hi, tmin, tmax = _listed(lo), _listed(hi), _listed(tmin), _listed(tmax)
    for j in range(k):
        if not (lo[j] <= q_lo[j] and q_hi[j] <= hi[j] and tmin[j] <= t_lo[j]
                and t_hi[j] <= tmax[j]):
            return False
    if limits is None or n < 2:
        return True
    v, a, jk = (_listed(x) for x in limits)
    padded = np.concatenate((joints[:1], joints, joints[-1:]))
    d = padded[1:] - padded[:-1]
    vel = _max(np.abs(d), axis=0).tolist()
    for j in range(k):
        if vel[j] * rate > v[j] * slack:
            return False
    step = _max(np.abs(d[1:] - d[:-1]), axis=0).tolist()
    for j in range(k):
        if step[j] * rate * rate > a[j] * slack:
            return False
    limited = [math.isfinite(x) for x in jk]
    if any(limited):
        d3 = differences(joints[:, limited], 3).max(axis=0)
        if (d3 * rate ** 3 > np.asarray(jk)[limited] * slack).any():
            return False
    return True


def start_history(q0: NDArray, v0: NDArray, a0: NDArray, rate: float) -> NDArray:
    """The three samples q_{-3}, q_{-2}, q_{-1} before a moving start (q0, q̇0, q̈0): the
    constant-acceleration past q_{-m} = q0 − m Δt q̇0 + (m Δt)² q̈0 / 2, so the differences
    across t = 0 measure the plan's continuity with that state."""
    m = np.array([3.0, 2.0, 1.0])[:, None] / rate
    return q0[None, :] - m * v0[None, :] + 0.5 * m * m * a0[None, :]


def check(req: PlanRequest, poses: NDArray, joints: NDArray, *, dynamics: bool = True,
          marks: dict[int, int] | None = None, segment_of: NDArray | None = None,
          ticks: NDArray | None = None, history: NDArray | None = None
          ) -> tuple[NDArray[np.int64], Violation | None]:
    """All checks at once: the ticks and the earliest failing sample, or None.

    Ties at one sample go position limits, ticks, velocity, acceleration, jerk.
    ``dynamics=False`` skips the finite differences; ``marks`` maps sample indices to the
    waypoints sampled there (a waypoint outside the limits is named as such);
    ``segment_of`` gives each sample's segment index (−1 on the approach); ``history``
    (3, k) the samples before t = 0 of a moving start (:func:`start_history`; default: at
    rest).
    """
    arm = req.arm
    rate = req.rate_hz
    n = joints.shape[0]
    # the arm's constant arrays, built once per arm (planner.arm_arrays)
    consts = arm_arrays.arrays_of(arm)
    lo, hi, v, a, jk = consts.lo, consts.hi, consts.v, consts.a, consts.jerk
    columns = None
    if ticks is None:
        ticks = servo_units.ticks_unchecked(joints, (), (consts.tick_scale, consts.tick_offset))
        columns = (consts.tick_scale.tolist(), consts.tick_offset.tolist())
    tmin, tmax = consts.tmin, consts.tmax
    slack = 1.0 + LIMIT_SLACK
    torque = torque_limits(req) if dynamics and n > 1 else None
    tau = None
    if torque is not None:
        # the gravity torques only name a torque violation's field (below): not asked here
        tau, _ = sample_torques(torque, joints, rate, history, gravity=False)
    # every point of the arm against its keep-out zones (nothing to do without zones)
    hit = first_intrusion(arm, joints)
    # the fast path compares per-joint extremes in plain floats: the limits as lists
    b_lo, b_hi, b_tmin, b_tmax, b_v, b_a, b_jk = consts.bounds
    if hit is None and (history is None or not dynamics) and _fine(
            joints, ticks, b_lo, b_hi, b_tmin, b_tmax, (b_v, b_a, b_jk) if dynamics else None,
            rate, slack, columns) \
            and (tau is None or (np.abs(tau) <= torque.tau * slack).all()):
        return ticks, _tools(req, poses, joints, history, segment_of, dynamics)
    rates = []
    if dynamics:
        for order, limit, quantity in ((1, v, "velocity"), (2, a, "acceleration"),
                                       (3, jk, "jerk")):
            if order == 3 and not np.isfinite(limit).any():
                continue
            rates.append((quantity, differences(joints, order, history) * rate ** order,
                          limit))
    pos_excess = np.maximum(lo - joints, joints - hi)
    tick_excess = np.maximum(tmin - ticks, ticks - tmax).astype(np.float64)
    checks = [("position", pos_excess > 0.0, pos_excess, joints),
              ("ticks", tick_excess > 0.0, tick_excess, ticks)]
    checks += [(q, d / limit > slack, d / limit, d) for q, d, limit in rates]
    if tau is not None:
        assert torque is not None
        score = np.abs(tau) / torque.tau
        checks.append(("torque", score > slack, score, np.abs(tau)))
    first, chosen = n, None
    for quantity, bad, score, values in checks:
        rows = bad.any(axis=1)
        if rows.any():
            i = int(np.argmax(rows))
            if i < first:
                first, chosen = i, (quantity, bad, score, values)
    if hit is not None and (chosen is None or hit.sample < first or (
            hit.sample == first and chosen[0] not in ("position", "ticks"))):
        return ticks, keepout_violation(req, hit, poses, marks, segment_of)
    if chosen is None:
        return ticks, _tools(req, poses, joints, history, segment_of, dynamics)
    quantity, bad, score, values = chosen
    i = first
    j = int(np.argmax(np.where(bad[i], score[i], -np.inf)))
    spec = arm.joints[j]
    value = float(values[i, j])
    if quantity == "position":
        limit = spec.min_angle if value < spec.min_angle else spec.max_angle
    elif quantity == "ticks":
        limit = float(spec.servo.min_tick if value < spec.servo.min_tick
                      else spec.servo.max_tick)
    elif quantity == "torque":
        assert torque is not None
        limit = float(torque.tau[j])
    else:
        limit = float({"velocity": v, "acceleration": a, "jerk": jk}[quantity][j])
    waypoint = (marks or {}).get(i) if quantity in ("position", "ticks") else None
    segment = None
    if segment_of is not None and segment_of[i] >= 0:
        segment = (int(segment_of[i]), int(segment_of[i]) + 1)
    field = "duration" if quantity in ("velocity", "acceleration", "jerk", "torque") else (
        f"waypoints[{waypoint}]" if waypoint is not None else "waypoints")
    if quantity == "torque":
        assert torque is not None
        _, grav = sample_torques(torque, joints, rate, history)
        assert grav is not None
        if torque.overloaded(grav[i])[j]:
            field = "payload_kg"  # gravity alone overloads the joint there: no duration helps
            waypoint = (marks or {}).get(i)  # at rest on a waypoint: name it
    if segment is None and segment_of is not None and quantity in ("position", "ticks") \
            and req.start_joints is not None:
        field = "start_joints"
    return ticks, Violation(sample=i, t=i / rate, pose=tuple(float(x) for x in poses[i]),
                            quantity=quantity, value=value, limit=limit,
                            unit=QUANTITY_UNITS[quantity], joint=spec.name, joint_index=j,
                            segment=segment, waypoint=waypoint, field=field)


def tool_limits(req: PlanRequest) -> ToolLimits | None:
    """The request's tool limits (:class:`~robodcn.path_timing.tool.ToolLimits`), None when
    it sets none."""
    if not req.tool_limited:
        return None
    return ToolLimits.of(req.arm, req.tool_speed, req.tool_angular_speed,
                         req.tool_acceleration)


def tool_samples(tool: ToolLimits, joints: NDArray, rate: float,
                 history: NDArray | None = None) -> dict[str, NDArray[np.float64]]:
    """Per tool quantity its value at every sample (n,), SI (module doc): ``tool_speed``
    (m/s), ``tool_angular_speed`` (rad/s), ``tool_acceleration`` (m/s², |d²σ/dt²|), at rest
    before t = 0 (or after ``history``) and after the end; only the limited ones."""
    pre = np.repeat(joints[:1], 2, axis=0) if history is None else history[-2:]
    padded = np.concatenate([pre, joints, joints[-1:]])
    n = joints.shape[0]
    out: dict[str, NDArray[np.float64]] = {}
    if math.isfinite(tool.speed) or math.isfinite(tool.acceleration):
        p = tool_point(tool.chain, padded)
        step = np.sqrt(np.einsum("ni,ni->n", np.diff(p, axis=0), np.diff(p, axis=0)))
        if math.isfinite(tool.speed):  # step m + 1 is q_m − q_{m−1}
            out["tool_speed"] = step[1:n + 1] * rate
        if math.isfinite(tool.acceleration):
            acc = np.abs(np.diff(step)) * (rate * rate)  # row r: sample r (the last: max)
            out["tool_acceleration"] = np.concatenate([acc[:n - 1], [acc[n - 1:].max()]])
    if math.isfinite(tool.angular_speed):
        turn = np.abs(np.diff(padded[1:n + 2], axis=0) @ tool.rates.T).max(axis=1)
        out["tool_angular_speed"] = turn[:n] * rate
    return out


def _tool_limit(tool: ToolLimits, quantity: str) -> float:
    return {"tool_speed": tool.speed, "tool_angular_speed": tool.angular_speed,
            "tool_acceleration": tool.acceleration}[quantity]


def tool_ratios(tool: ToolLimits, joints: NDArray, rate: float,
                history: NDArray | None = None) -> dict[str, NDArray[np.float64]]:
    """Per limited tool quantity value / limit at every sample (n,) (:func:`tool_samples`)."""
    return {q: x / _tool_limit(tool, q)
            for q, x in tool_samples(tool, joints, rate, history).items()}


def tool_violation(req: PlanRequest, poses: NDArray, joints: NDArray,
                   history: NDArray | None = None, segment_of: NDArray | None = None
                   ) -> Violation | None:
    """The first sample past a tool limit (module doc) as a Violation naming the tool field
    (``tool_speed`` …), the value it needs and the limit; None when every sample keeps them
    (or the request sets none)."""
    tool = tool_limits(req)
    if tool is None or joints.shape[0] < 2:
        return None
    slack = 1.0 + LIMIT_SLACK
    first, chosen = joints.shape[0], None
    for quantity, ratio in tool_ratios(tool, joints, req.rate_hz, history).items():
        bad = ratio > slack
        if bad.any() and int(np.argmax(bad)) < first:
            first, chosen = int(np.argmax(bad)), (quantity, ratio)
    if chosen is None:
        return None
    quantity, ratio = chosen
    i = first
    limit = _tool_limit(tool, quantity)
    segment = None
    if segment_of is not None and segment_of[i] >= 0:
        segment = (int(segment_of[i]), int(segment_of[i]) + 1)
    return Violation(sample=i, t=i / req.rate_hz, pose=tuple(float(x) for x in poses[i]),
                     quantity=quantity, value=float(ratio[i] * limit),  # type: ignore[arg-type]
                     limit=float(limit), unit=QUANTITY_UNITS[quantity], segment=segment,
                     field=quantity)


def _tools(req: PlanRequest, poses: NDArray, joints: NDArray, history: NDArray | None,
           segment_of: NDArray | None, dynamics: bool) -> Violation | None:
    """:func:`tool_violation` when the dynamic checks run and the request sets a tool limit."""
    if not dynamics or not req.tool_limited:
        return None
    return tool_violation(req, poses, joints, history, segment_of)


def keepout_violation(req: PlanRequest, hit: Intrusion, poses: NDArray,
                      marks: dict[int, int] | None = None,
                      segment_of: NDArray | None = None) -> Violation:
    """The "keepout" Violation of a sample with a point inside a keep-out zone: value the
    depth (m), limit 0 (the zone's surface), the point, zone and the point's position; the
    field a waypoint sampled there (``waypoints[i]``), the approach's ``start_joints``, or
    the path (``waypoints``)."""
    i = hit.sample
    waypoint = (marks or {}).get(i)
    segment = None
    if segment_of is not None and segment_of[i] >= 0:
        segment = (int(segment_of[i]), int(segment_of[i]) + 1)
    field = f"waypoints[{waypoint}]" if waypoint is not None else "waypoints"
    if waypoint is None and segment is None and segment_of is not None \
            and req.start_joints is not None:
        field = "start_joints"
    j = hit.joint
    return Violation(sample=i, t=i / req.rate_hz, pose=tuple(float(x) for x in poses[i]),
                     quantity="keepout", value=hit.depth, limit=0.0, unit="m",
                     joint=None if j is None else req.arm.joints[j].name, joint_index=j,
                     segment=segment, waypoint=waypoint, field=field, point=hit.point,
                     zone=hit.zone, position=hit.position)


def elbow_branches(joints: NDArray) -> tuple[str | None, tuple[int, ...]]:
    """The elbow branch at the first sample and the samples where it changes.

    "up" is wrap(q2) < 0, "down" wrap(q2) > 0 (robodcn.kinematics); samples within
    kinematics.SINGULAR_TOLERANCE of q2 = 0 or ±π (stretched out, folded) belong to neither
    and carry the branch before them, so a switch is counted where the branch after a
    singular stretch differs from the one before it.
    """
    column = joints[:, 1]
    tol = kinematics.SINGULAR_TOLERANCE
    # the common case, one branch throughout clear of both singularities: the per-sample
    # tests below on the two extremes (|q2| and π − |q2| are monotone there, so these are
    # the very comparisons of the samples nearest 0 and ±π): no sample singular, no change.
    # Within ±3 rad wrap is the identity (rint(q/2π) = 0, q − 0 = q): the raw column's
    # extremes are the wrapped ones, the column wrapped only when it leaves that
    low, high = float(np.minimum.reduce(column)), float(np.maximum.reduce(column))
    if -3.0 <= low and high <= 3.0:
        q2 = column
    else:
        q2 = kinematics.wrap(column)
        low, high = float(q2.min()), float(q2.max())
    if high < 0.0 and not abs(high) < tol and not math.pi - abs(low) < tol:
        return "up", ()
    if low > 0.0 and not abs(low) < tol and not math.pi - abs(high) < tol:
        return "down", ()
    singular = (np.abs(q2) < tol) | (math.pi - np.abs(q2) < tol)
    side = np.where(singular, 0, np.where(q2 < 0.0, -1, 1))
    known = np.where(side != 0, np.arange(side.shape[0]), -1)
    np.maximum.accumulate(known, out=known)
    filled = np.where(known >= 0, side[np.maximum(known, 0)], 0)
    changed = (filled[1:] != filled[:-1]) & (filled[:-1] != 0)
    first = {-1: "up", 1: "down", 0: None}[int(side[0])]
    return first, tuple(int(i) + 1 for i in np.flatnonzero(changed))


def raise_for(violation: Violation) -> NoReturn:
    """Raise the PlanError of ``violation`` (message in SI and JSON names)."""
    raise VIOLATION_ERRORS[violation.quantity](describe_violation(violation, "si"),
                                               violation=violation)
