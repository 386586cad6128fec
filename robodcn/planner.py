"""Waypoints → interpolated poses → branch-continuous joint angles → servo ticks, validated.

``plan(arm, waypoints, ...)`` builds a :class:`PlanRequest` (immutable, validated) and
returns a :class:`Trajectory` sampled exactly every 1/rate_hz seconds from t = 0
(design.md §1, §4). Nothing leaves the planner unvalidated and nothing is clamped: the first
failing sample (reach, joint limits, tick limits, finite-difference velocity and acceleration)
raises a :mod:`robodcn.errors` PlanError naming its index, time, pose and joint.

Structure of a plan
-------------------
* **Segments.** Waypoint j → j + 1 follows ``robodcn.interpolate.interpolate`` with that
  segment's method and turn; θ is chained so it stays continuous across waypoints.
* **Stops (blend=False).** Each segment has its own time law s(τ) and stops at its end
  waypoint (quintic and trapezoid are rest-to-rest; "linear" has velocity steps).
* **Blend (blend=True).** One time law over a global path parameter u ∈ [0, 1] whose knots
  are spaced by each segment's joint-space travel time; each segment's pose curve gets a
  cubic Hermite correction h₁(s)·Δ₀ + h₂(s)·Δ₁ (h₁ = s(1 − s)², h₂ = s²(s − 1): zero at both
  ends, unit slope at one end) so that at every via point the tangent dP/du equals the
  knot-weighted (Bessel) average of the two neighbouring segments' tangents. The path still
  passes exactly through every waypoint, and the velocity is continuous there; between
  waypoints the curve departs from the pure ScLERP/KenLERP/... path by that correction.
* **Approach.** With ``start_joints`` farther than half a servo tick from the IK of the first
  waypoint (the branch and 2π turn nearest start_joints, unless that turn is outside the
  joint limits and another is inside), a joint-space quintic from start_joints is
  prepended. It is always timed "auto" and comes on top of a numeric ``duration``.
* **Duration.** A number: the path's time, rounded up to whole sample periods and split over
  stop segments in proportion to their own shortest durations. "auto": per piece, the
  smallest number of sample periods N for which the finite-difference checks pass. The
  estimate N = ⌈T_fd(N)·rate⌉ from :func:`robodcn.timing.fd_min_duration` (the closed form of
  uniform time scaling) is iterated, then confirmed: N passes and N − 1 fails (or N = 1).
  Each piece is minimal on its own; if a join between stop segments still fails (only the
  linear profile, whose velocity steps at the joins), all path pieces are slowed by the
  failing ratio and re-checked, a few times at most. A path that leaves the workspace
  cannot be timed: its UnreachableError names the first sample out of reach in the plan
  timed by the estimate, ignoring the speeds before it (which that timing did not set).

Validation is by finite differences at the sample rate: velocity (q_i − q_{i−1})·rate is
charged to sample i, acceleration (q_{i+1} − 2q_i + q_{i−1})·rate² to sample i + 1 (the
first sample that cannot be reached in time). The arm is at rest before t = 0 and after the
end (the streamer starts from a standing arm and holds the last goal), so q_{−1} = q_0 and
q_{n} = q_{n−1}: a velocity step at either end, as the linear profile has, is an acceleration
like any other (the end one is charged to the last sample).
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks, kinematics, servo_units, timing
from robodcn.config import RATE_RANGE, Arm, arm_from_dict
from robodcn.dcn import TURNS
from robodcn.errors import (
    AccelerationLimitError,
    InputError,
    JointLimitError,
    PlanError,
    TickLimitError,
    TooLargeError,
    UnreachableError,
    VelocityLimitError,
)
from robodcn.interpolate import METHODS, interpolate, turn_angle

PROFILES = timing.PROFILES
#: Largest plan (samples) the planner produces.
MAX_SAMPLES = 1_000_000
#: Relative slack on velocity/acceleration limits in validation, for float rounding only
#: (auto timing itself uses the exact limits, so auto plans never rely on it).
LIMIT_SLACK = 1e-9
#: Slack on joint position limits (rad), float rounding only.
ANGLE_SLACK = 1e-9
_MAX_SEARCH_STEPS = 40
_COARSE = 128


# -- request ----------------------------------------------------------------------------------

def _is_number(value: Any) -> bool:
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(value,
                                                                                         bool)


def _per_segment(name: str, value: Any, allowed: tuple[str, ...], segments: int
                 ) -> str | tuple[str, ...]:
    if isinstance(value, str):
        if value not in allowed:
            raise InputError(f"{name} must be one of {', '.join(map(repr, allowed))}, got "
                             f"{value!r}", field=name, value=value)
        return value
    if isinstance(value, list | tuple):
        if len(value) != segments:
            raise InputError(f"{name} as a list needs one entry per segment ({segments}), got "
                             f"{len(value)}", field=name, value=value)
        for i, item in enumerate(value):
            if item not in allowed:
                raise InputError(f"{name}[{i}] must be one of {', '.join(map(repr, allowed))}, "
                                 f"got {item!r}", field=f"{name}[{i}]", value=item)
        return tuple(value)
    raise InputError(f"{name} must be a string or a list of strings, got {value!r}",
                     field=name, value=value)


@dataclass(frozen=True)
class PlanRequest:
    """Everything a plan depends on; validated on construction (Ruckig-style input data).

    Attributes
    ----------
    arm : Arm
    waypoints : tuple of m ≥ 2 poses (x, y, θ), metres and radians
    method : "sclerp" | "kenlerp" | "seplerp" | "dlb", or one per segment
    beta : KenLERP bias
    turn : "shortest" | "ccw" | "cw", or one per segment
    duration : total seconds (> 0) or "auto"
    profile : "linear" | "quintic" | "trapezoid"
    rate_hz : sample rate, 1..1000 Hz
    blend : pass through via points with continuous velocity instead of stopping
    start_joints : the arm's present joints (k,) or None (then the plan starts at the IK of
        waypoints[0] on the arm's preferred elbow branch)

    Lists given for method, turn, waypoints and start_joints are stored as tuples.
    """

    arm: Arm
    waypoints: Any
    method: Any = "sclerp"
    beta: float = 1.0
    turn: Any = "shortest"
    duration: Any = "auto"
    profile: str = "quintic"
    rate_hz: float = 100.0
    blend: bool = False
    start_joints: Any = None

    def __post_init__(self) -> None:
        put = object.__setattr__
        if not isinstance(self.arm, Arm):
            raise InputError(f"arm must be an Arm (robodcn.load_arm), got {type(self.arm)!r}",
                             field="arm", value=self.arm)
        wp = _checks.finite("waypoints", self.waypoints)
        if wp.ndim != 2 or wp.shape[1] != 3 or wp.shape[0] < 2:
            raise InputError(f"waypoints must be at least 2 poses (x, y, θ), shape (m, 3), got "
                             f"shape {wp.shape}", field="waypoints", value=self.waypoints)
        put(self, "waypoints", tuple(tuple(float(v) for v in row) for row in wp))
        segments = wp.shape[0] - 1
        put(self, "method", _per_segment("method", self.method, METHODS, segments))
        put(self, "turn", _per_segment("turn", self.turn, TURNS, segments))
        if not _is_number(self.beta) or not math.isfinite(self.beta):
            raise InputError(f"beta must be a finite number, got {self.beta!r}", field="beta",
                             value=self.beta)
        put(self, "beta", float(self.beta))
        if not isinstance(self.profile, str) or self.profile not in PROFILES:
            raise InputError(f"profile must be one of {', '.join(map(repr, PROFILES))}, got "
                             f"{self.profile!r}", field="profile", value=self.profile)
        if not _is_number(self.rate_hz) or not (RATE_RANGE[0] <= self.rate_hz <= RATE_RANGE[1]):
            raise InputError(f"rate_hz must be a number within {RATE_RANGE[0]:g}..{RATE_RANGE[1]:g}"
                             f" Hz, got {self.rate_hz!r}", field="rate_hz", value=self.rate_hz)
        put(self, "rate_hz", float(self.rate_hz))
        if self.duration != "auto":
            if not _is_number(self.duration) or not math.isfinite(self.duration) \
                    or self.duration <= 0.0:
                raise InputError(f"duration must be a positive number of seconds or 'auto', "
                                 f"got {self.duration!r}", field="duration", value=self.duration)
            put(self, "duration", float(self.duration))
            n = _intervals(self.duration, self.rate_hz)
            if n + 1 > MAX_SAMPLES:
                raise TooLargeError(f"duration {self.duration:g} s at {self.rate_hz:g} Hz needs "
                                 f"{n + 1} samples, more than {MAX_SAMPLES}: shorten the "
                                 "duration or lower rate_hz", field="duration",
                                 value=self.duration)
            if n < segments:
                raise InputError(f"duration {self.duration:g} s at {self.rate_hz:g} Hz gives "
                                 f"{n} sample periods for {segments} segments: each needs at "
                                 "least one", field="duration", value=self.duration)
        if not isinstance(self.blend, bool | np.bool_):
            raise InputError(f"blend must be true or false, got {self.blend!r}", field="blend",
                             value=self.blend)
        put(self, "blend", bool(self.blend))
        if self.start_joints is not None:
            q = _checks.finite("start_joints", self.start_joints)
            if q.shape != (self.arm.dof,):
                raise InputError(f"start_joints must have shape ({self.arm.dof},) for arm "
                                 f"{self.arm.name!r}, got {q.shape}", field="start_joints",
                                 value=self.start_joints)
            put(self, "start_joints", tuple(float(v) for v in q))

    @property
    def waypoints_array(self) -> NDArray[np.float64]:
        """Waypoints as an (m, 3) array."""
        return np.array(self.waypoints, dtype=np.float64)

    @property
    def segments(self) -> int:
        return len(self.waypoints) - 1

    def segment_method(self, j: int) -> str:
        return self.method if isinstance(self.method, str) else self.method[j]

    def segment_turn(self, j: int) -> str:
        return self.turn if isinstance(self.turn, str) else self.turn[j]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (the arm embedded in SI keys, see Arm.to_dict)."""
        return {"arm": self.arm.to_dict(), "arm_source": self.arm.source,
                "waypoints": [list(w) for w in self.waypoints],
                "method": self.method if isinstance(self.method, str) else list(self.method),
                "beta": self.beta,
                "turn": self.turn if isinstance(self.turn, str) else list(self.turn),
                "duration": self.duration, "profile": self.profile, "rate_hz": self.rate_hz,
                "blend": self.blend,
                "start_joints": None if self.start_joints is None else list(self.start_joints)}

    @classmethod
    def from_dict(cls, data: dict[str, Any], arm: Arm | None = None) -> PlanRequest:
        """Inverse of :meth:`to_dict`; ``arm`` overrides the embedded arm."""
        if not isinstance(data, dict):
            raise InputError("request must be an object", field="request", value=data)
        data = dict(data)
        embedded = data.pop("arm", None)
        source = data.pop("arm_source", "<json>")
        if arm is None:
            if embedded is None:
                raise InputError("request has no arm: pass arm=", field="request.arm",
                                 value=None)
            arm = arm_from_dict(embedded, source=str(source))
        allowed = {"waypoints", "method", "beta", "turn", "duration", "profile", "rate_hz",
                   "blend", "start_joints"}
        unknown = set(data) - allowed
        if unknown:
            name = sorted(unknown)[0]
            raise InputError(f"unknown request field {name!r}", field=f"request.{name}",
                             value=data[name])
        return cls(arm=arm, **data)


def _intervals(duration: float, rate: float) -> int:
    """Whole sample periods covering ``duration`` (rounded up; 1e-9 absorbs float noise)."""
    return max(1, math.ceil(duration * rate - 1e-9))


# -- trajectory -------------------------------------------------------------------------------

@dataclass(eq=False)
class Trajectory:
    """A validated plan: samples every 1/rate_hz s from t = 0.

    Attributes
    ----------
    t : (n,) seconds; poses : (n, 3) (x, y, θ) with θ continuous (for a 2-joint arm θ is the
    requested one on the path, FK's q1 + q2 on an approach); joints : (n, k) radians,
    unwrapped; ticks : (n, k) int64 goal positions; joint_names, servo_ids : k each;
    rate_hz; method (the request's, a string or a list per segment); request.
    """

    t: NDArray[np.float64]
    poses: NDArray[np.float64]
    joints: NDArray[np.float64]
    ticks: NDArray[np.int64]
    joint_names: tuple[str, ...]
    servo_ids: tuple[int, ...]
    rate_hz: float
    method: str | list[str]
    request: PlanRequest | None = field(default=None)

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=np.float64)
        self.poses = np.asarray(self.poses, dtype=np.float64)
        self.joints = np.asarray(self.joints, dtype=np.float64)
        ticks = np.asarray(self.ticks)
        if ticks.size and not np.issubdtype(ticks.dtype, np.integer):
            if not np.array_equal(ticks, np.round(ticks)):
                raise InputError("ticks must be integers", field="ticks", value=None)
        self.ticks = ticks.astype(np.int64)
        self.joint_names = tuple(self.joint_names)
        self.servo_ids = tuple(int(i) for i in self.servo_ids)
        n = self.t.shape[0] if self.t.ndim == 1 else -1
        k = len(self.joint_names)
        for name, array, shape in (("t", self.t, (n,)), ("poses", self.poses, (n, 3)),
                                   ("joints", self.joints, (n, k)),
                                   ("ticks", self.ticks, (n, k))):
            if n < 1 or array.shape != shape:
                raise InputError(f"trajectory {name} must have shape {shape} (n ≥ 1 samples, "
                                 f"k = {k} joints), got {array.shape}", field=name,
                                 value=array.shape)
        if len(self.servo_ids) != k:
            raise InputError(f"servo_ids must name {k} servos, got {len(self.servo_ids)}",
                             field="servo_ids", value=self.servo_ids)
        if not _is_number(self.rate_hz) or not RATE_RANGE[0] <= self.rate_hz <= RATE_RANGE[1]:
            raise InputError(f"rate_hz must be within {RATE_RANGE[0]:g}..{RATE_RANGE[1]:g} Hz, "
                             f"got {self.rate_hz!r}", field="rate_hz", value=self.rate_hz)
        self.rate_hz = float(self.rate_hz)
        expected = np.arange(n) / self.rate_hz
        if np.abs(self.t - expected).max() > 1e-9:
            raise InputError("t must start at 0 and step by exactly 1/rate_hz", field="t",
                             value=None)
        for name, array in (("poses", self.poses), ("joints", self.joints)):
            if not np.isfinite(array).all():
                raise InputError(f"trajectory {name} must be finite", field=name, value=None)

    @property
    def duration(self) -> float:
        """t[-1], seconds."""
        return float(self.t[-1])

    def to_dict(self) -> dict[str, Any]:
        return {"t": self.t.tolist(), "poses": self.poses.tolist(),
                "joints": self.joints.tolist(), "ticks": self.ticks.tolist(),
                "joint_names": list(self.joint_names), "servo_ids": list(self.servo_ids),
                "rate_hz": self.rate_hz, "method": self.method,
                "request": None if self.request is None else self.request.to_dict()}

    def to_json(self) -> str:
        """JSON with keys t, poses, joints, ticks, joint_names, servo_ids, rate_hz, method,
        request (floats written with repr precision: the round trip is exact)."""
        return json.dumps(self.to_dict())

    @classmethod
    def from_json(cls, text: str, arm: Arm | None = None) -> Trajectory:
        """Parse :meth:`to_json` output, checking every shape (InputError naming the key).

        The request is rebuilt with ``arm`` when given, else with the arm embedded in it.
        """
        try:
            data = json.loads(text)
        except (json.JSONDecodeError, TypeError) as exc:
            raise InputError(f"trajectory JSON is invalid: {exc}", field="json",
                             value=None) from exc
        if not isinstance(data, dict):
            raise InputError("trajectory JSON must be an object", field="json", value=None)
        keys = ("t", "poses", "joints", "ticks", "joint_names", "servo_ids", "rate_hz",
                "method")
        for key in keys:
            if key not in data:
                raise InputError(f"trajectory JSON lacks key {key!r}", field=key, value=None)
        if arm is not None and tuple(data["servo_ids"]) != arm.servo_ids:
            raise InputError(f"trajectory servo_ids {data['servo_ids']} do not match arm "
                             f"{arm.name!r} {list(arm.servo_ids)}", field="servo_ids",
                             value=data["servo_ids"])
        request = None
        if data.get("request") is not None:
            request = PlanRequest.from_dict(data["request"], arm)
        arrays = {}
        for key in ("t", "poses", "joints", "ticks"):
            arrays[key] = _checks.finite(key, data[key])
        names = data["joint_names"]
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise InputError("joint_names must be a list of strings", field="joint_names",
                             value=names)
        return cls(arrays["t"], arrays["poses"], arrays["joints"], arrays["ticks"], names,
                   data["servo_ids"], data["rate_hz"], data["method"], request)

    def to_csv(self) -> str:
        """CSV: t, x, y, theta, one column per joint (rad), one per servo (ticks)."""
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(["t", "x", "y", "theta", *(f"q_{n}" for n in self.joint_names),
                         *(f"tick_{i}" for i in self.servo_ids)])
        floats = np.column_stack([self.t, self.poses, self.joints])
        for row, ticks in zip(floats.tolist(), self.ticks.tolist(), strict=True):
            writer.writerow([repr(v) for v in row] + ticks)
        return out.getvalue()


# -- pieces of a plan -------------------------------------------------------------------------

class _Path:
    """A pose curve P(u), u ∈ [0, 1], over one or more segments with knots U."""

    def __init__(self, segments: list[tuple[NDArray, NDArray, str, str]], beta: float,
                 knots: NDArray[np.float64], corrections: list[tuple[NDArray, NDArray]] | None):
        self.segments = segments
        self.beta = beta
        self.knots = knots
        self.corrections = corrections

    def segment_poses(self, j: int, s: NDArray[np.float64]) -> NDArray[np.float64]:
        start, end, method, turn = self.segments[j]
        poses = interpolate(start, end, s, method=method, beta=self.beta, turn=turn)
        if self.corrections is not None:
            d0, d1 = self.corrections[j]
            poses += (s * (1.0 - s) ** 2)[:, None] * d0 + (s * s * (s - 1.0))[:, None] * d1
        return poses

    def __call__(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        if len(self.segments) == 1:
            return self.segment_poses(0, u)
        out = np.empty((u.shape[0], 3))
        # u is non-decreasing, so each segment owns one contiguous slice.
        bounds = np.searchsorted(u, self.knots[1:-1], side="left")
        edges = [0, *bounds.tolist(), u.shape[0]]
        for j in range(len(self.segments)):
            lo, hi = edges[j], edges[j + 1]
            if hi > lo:
                span = self.knots[j + 1] - self.knots[j]
                s = np.clip((u[lo:hi] - self.knots[j]) / span, 0.0, 1.0)
                out[lo:hi] = self.segment_poses(j, s)
        return out


class _Piece:
    """A part of the plan with its own time law: a pose path or a joint-space approach."""

    def __init__(self, *, path: _Path | None = None, profile: str = "quintic",
                 q_from: NDArray | None = None, q_to: NDArray | None = None) -> None:
        self.path = path
        self.profile = profile
        self.accel_fraction = timing.DEFAULT_ACCEL_FRACTION
        self.q_from = q_from
        self.q_to = q_to

    def sample(self, n: int, arm: Arm, reference: NDArray | None
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Poses and joints (n + 1 rows) at τ_i = i/n; raises UnreachableError (local index)."""
        tau = np.arange(n + 1) / n
        if self.path is None:
            q = self.q_from + np.outer(timing.quintic(tau), self.q_to - self.q_from)
            return kinematics.fk(arm.links, q), q
        poses = self.path(timing.profile(self.profile, tau, self.accel_fraction))
        return poses, _joints(arm, poses, reference)


def _joints(arm: Arm, poses: NDArray[np.float64], reference: NDArray | None
            ) -> NDArray[np.float64]:
    limits = [(j.min_angle, j.max_angle) for j in arm.joints]
    return kinematics.ik_path(arm.links, poses, reference=reference, elbow=arm.elbow,
                              limits=limits)


def _limits(arm: Arm) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    return (np.array([j.max_velocity for j in arm.joints]),
            np.array([j.max_acceleration for j in arm.joints]))


def _fd_need(q: NDArray[np.float64], arm: Arm) -> float:
    v, a = _limits(arm)
    return timing.fd_min_duration(q, v, a)


def _shape_trapezoid(piece: _Piece, arm: Arm, reference: NDArray | None) -> None:
    """Pick the trapezoid's acceleration fraction from path-space limits (timing module).

    Path speed ṡ makes joint speeds |q'(s)|·ṡ and (neglecting the q''(s)·ṡ² term)
    accelerations |q'(s)|·s̈, so the path limits are v_s = min v_j/max|q_j'|, a_s =
    min a_j/max|q_j'| and the time-optimal trapezoid over s ∈ [0, 1] has ρ from
    trapezoid_min_time(1, v_s, a_s); ρ is kept in [0.05, 0.5].
    """
    if piece.profile != "trapezoid" or piece.path is None:
        return
    s = np.linspace(0.0, 1.0, _COARSE + 1)
    try:
        q = kinematics.ik_path(arm.links, piece.path(s), reference=reference, elbow=arm.elbow)
    except UnreachableError:
        return  # validation reports it with the real sample index
    slope = np.abs(np.diff(q, axis=0)).max(axis=0) * _COARSE
    if not np.any(slope > 0.0):
        return
    v, a = _limits(arm)
    with np.errstate(divide="ignore"):
        v_s = float(np.min(v / slope))
        a_s = float(np.min(a / slope))
    _, rho = timing.trapezoid_min_time(1.0, v_s, a_s)
    piece.accel_fraction = min(0.5, max(0.05, rho))


def _estimate(piece: _Piece, arm: Arm, reference: NDArray | None
              ) -> tuple[float, NDArray | None]:
    """Shortest duration on a uniform grid of _COARSE periods (≈ the closed form), seconds,
    and the piece's last joints; (1 s, None) if the path leaves the workspace (validation
    then names the sample)."""
    try:
        _, q = piece.sample(_COARSE, arm, reference)
    except UnreachableError:
        return 1.0, None
    return _fd_need(q, arm), q[-1]


def _search(piece: _Piece, arm: Arm, reference: NDArray | None, rate: float) -> int:
    """Smallest N (sample periods) whose samples pass the velocity/acceleration checks.

    Bracket, then bisect: from the estimate, grow N (to the finite-difference closed form's
    ⌈T_fd(N)·rate⌉, at least doubling) until it passes; then try the closed form's guess just
    below and bisect between the largest failing and the smallest passing N until they are
    neighbours. The result passes and N − 1 fails (or N = 1). Typically 2–3 evaluations.
    """

    def need(n: int) -> float | None:
        try:
            return _fd_need(piece.sample(n, arm, reference)[1], arm)
        except UnreachableError:
            return None  # validation reports it with the real sample index

    n = _intervals(max(_estimate(piece, arm, reference)[0], 1e-12), rate)
    fail, ok = 0, None  # largest N known to fail (0: none), smallest known to pass
    stepped_down = False
    for _ in range(_MAX_SEARCH_STEPS):
        if ok is not None and ok - fail <= 1:
            return ok
        if n + 1 > MAX_SAMPLES:
            raise TooLargeError(f"the 'auto' duration needs more than {MAX_SAMPLES} samples at "
                             f"{rate:g} Hz: lower rate_hz or raise the joint limits",
                             field="duration", value="auto")
        t_need = need(n)
        if t_need is None:
            return ok or n
        guess = max(1, math.ceil(t_need * rate - 1e-9))
        if t_need <= n / rate:
            ok = n
            if fail < guess < ok:
                n = guess
            elif not stepped_down:
                n, stepped_down = ok - 1, True  # usually the estimate was exact: confirm
            else:
                n = (fail + ok) // 2
        else:
            fail = n
            if ok is None:
                n = max(guess, 2 * n)
            else:
                n = guess if fail < guess < ok else (fail + ok) // 2
    return ok if ok is not None else n


def _split(total: int, weights: Sequence[float]) -> list[int]:
    """Split ``total`` periods over segments ∝ weights (largest remainder, each ≥ 1)."""
    w = np.maximum(np.asarray(weights, dtype=np.float64), 0.0)
    m = len(w)
    if w.sum() <= 0.0:
        w = np.ones(m)
    share = (total - m) * w / w.sum()
    base = np.floor(share).astype(int)
    rest = (total - m) - base.sum()
    order = np.argsort(-(share - base), kind="stable")
    base[order[:rest]] += 1
    return (base + 1).tolist()


# -- planning ---------------------------------------------------------------------------------

def _fmt_pose(pose: Sequence[float]) -> str:
    return f"x={pose[0]:.4f} m, y={pose[1]:.4f} m, θ={math.degrees(pose[2]):.1f}°"


def _check_waypoints(arm: Arm, wp: NDArray[np.float64]) -> None:
    ok = kinematics.reachable(arm.links, wp)
    if ok.all():
        return
    j = int(np.argmin(ok))
    inner, outer = kinematics.workspace(arm.links)
    r = float(kinematics.wrist_radius(arm.links, wp[j:j + 1])[0])
    raise UnreachableError(f"waypoints[{j}] ({_fmt_pose(wp[j])}) is out of reach: the wrist "
                           f"point is {r:.4f} m from the base, the arm reaches "
                           f"{inner:.4f}..{outer:.4f} m", field=f"waypoints[{j}]",
                           value=wp[j].tolist(), pose=wp[j].tolist())


def _segments(req: PlanRequest) -> list[tuple[NDArray, NDArray, str, str]]:
    """(start, end, method, turn) per segment with θ chained continuously across waypoints."""
    wp = req.waypoints_array
    out = []
    start = wp[0].copy()
    for j in range(req.segments):
        turn = req.segment_turn(j)
        end = wp[j + 1].copy()
        end[2] = start[2] + turn_angle(start[2], wp[j + 1, 2], turn)
        out.append((start, end, req.segment_method(j), turn))
        start = end
    return out


def _blended_path(req: PlanRequest, segments: list, reference: NDArray | None) -> _Path:
    """One path through all waypoints with Bessel tangents at the via points (module doc)."""
    arm = req.arm
    v, _ = _limits(arm)
    weights = []
    ref = reference
    for seg in segments:
        single = _Path([seg], req.beta, np.array([0.0, 1.0]), None)
        s = np.linspace(0.0, 1.0, 33)
        poses = single(s)
        try:
            q = kinematics.ik_path(arm.links, poses, reference=ref, elbow=arm.elbow)
            weights.append(float(np.max(np.abs(np.diff(q, axis=0)).sum(axis=0) / v)))
            ref = q[-1]
        except UnreachableError:
            weights.append(float(np.linalg.norm(np.diff(poses[:, :2], axis=0), axis=1).sum()))
    w = np.asarray(weights)
    w = np.maximum(w, 1e-3 * w.max() if w.max() > 0 else 1.0)
    knots = np.concatenate([[0.0], np.cumsum(w) / w.sum()])
    knots[-1] = 1.0
    span = np.diff(knots)
    h = 1e-6
    ends = []  # (dL/ds at 0, dL/ds at 1) per segment, central differences
    for seg in segments:
        start, end, method, turn = seg
        p = interpolate(start, end, np.array([-h, h, 1.0 - h, 1.0 + h]), method=method,
                        beta=req.beta, turn=turn)
        ends.append(((p[1] - p[0]) / (2 * h), (p[3] - p[2]) / (2 * h)))
    m = len(segments)
    tangents = [ends[0][0] / span[0]]  # dP/du at each knot
    for j in range(1, m):
        incoming = ends[j - 1][1] / span[j - 1]
        outgoing = ends[j][0] / span[j]
        tangents.append((span[j] * incoming + span[j - 1] * outgoing) / (span[j - 1] + span[j]))
    tangents.append(ends[-1][1] / span[-1])
    corrections = [(span[j] * tangents[j] - ends[j][0], span[j] * tangents[j + 1] - ends[j][1])
                   for j in range(m)]
    return _Path(segments, req.beta, knots, corrections)


def _within_limits(q: NDArray[np.float64], limits: Sequence[tuple[float, float]]
                   ) -> NDArray[np.float64]:
    """q, with any joint outside its limits moved by ±2π when that brings it inside (the
    approach then turns the long way round instead of into a limit)."""
    q = q.copy()
    for j, (lo, hi) in enumerate(limits):
        if not lo <= q[j] <= hi:
            for shifted in (q[j] - 2.0 * math.pi, q[j] + 2.0 * math.pi):
                if lo <= shifted <= hi:
                    q[j] = shifted
                    break
    return q


def plan_request(req: PlanRequest) -> Trajectory:
    """Plan a validated :class:`PlanRequest` (module docstring); see :func:`plan`."""
    arm = req.arm
    rate = req.rate_hz
    wp = req.waypoints_array
    _check_waypoints(arm, wp)
    start = None if req.start_joints is None else np.asarray(req.start_joints)
    limits = [(j.min_angle, j.max_angle) for j in arm.joints]
    segments = _segments(req)
    if req.blend:
        paths = [_blended_path(req, segments, start)]
    else:
        paths = [_Path([seg], req.beta, np.array([0.0, 1.0]), None) for seg in segments]
    pieces = [_Piece(path=p, profile=req.profile) for p in paths]
    first = kinematics.ik_path(arm.links, wp[:1], reference=start, elbow=arm.elbow,
                               limits=limits)[0]
    if start is not None:
        first = _within_limits(first, limits)
    # Half the finest servo step: closer than that the servos cannot tell the difference.
    tolerance = min(math.pi / j.servo.ticks_per_turn for j in arm.joints)
    if start is not None and np.max(np.abs(first - start)) > tolerance:
        pieces.insert(0, _Piece(q_from=start, q_to=first))

    # Sample counts, piece by piece; the joint reference threads through the pieces.
    counts: list[int] = []
    estimates: list[float] = []
    ref = start
    for piece in pieces:
        _shape_trapezoid(piece, arm, ref)
        last = None
        if req.duration == "auto" or piece.path is None:
            counts.append(_search(piece, arm, ref, rate))
        else:
            need, last = _estimate(piece, arm, ref)
            estimates.append(need)
            counts.append(0)
        if last is None:
            try:
                last = piece.sample(counts[-1] or _COARSE, arm, ref)[1][-1]
            except UnreachableError:
                last = ref
        ref = last
    if req.duration != "auto":
        shares = iter(_split(_intervals(req.duration, rate), estimates))
        counts = [c if c else next(shares) for c in counts]
        return _assemble(req, pieces, counts, start)

    # Auto pieces are each minimal; their joins can still fail (a linear profile's velocity
    # step between segments): slow every path piece down by the failing ratio and retry.
    for _ in range(_MAX_SEARCH_STEPS):
        try:
            return _assemble(req, pieces, counts, start)
        except (VelocityLimitError, AccelerationLimitError) as exc:
            joint = arm.joints[arm.joint_names.index(exc.joint)]
            limit = (joint.max_velocity if isinstance(exc, VelocityLimitError)
                     else joint.max_acceleration)
            ratio = max(1.0, float(exc.value) / limit)
            # Uniform time scaling: velocities go as 1/T, accelerations as 1/T².
            factor = (ratio if isinstance(exc, VelocityLimitError) else math.sqrt(ratio))
            factor *= 1.0 + 1e-6
            scaled = [math.ceil(c * factor) if p.path is not None else c
                      for c, p in zip(counts, pieces, strict=True)]
            if scaled == counts:
                raise
            counts = scaled
    return _assemble(req, pieces, counts, start)


def _assemble(req: PlanRequest, pieces: list[_Piece], counts: list[int],
              reference: NDArray | None) -> Trajectory:
    arm = req.arm
    rate = req.rate_hz
    total = 1 + sum(counts)
    if total > MAX_SAMPLES:
        raise TooLargeError(f"the plan needs {total} samples at {rate:g} Hz, more than "
                         f"{MAX_SAMPLES}: lower rate_hz or shorten the motion",
                         field="duration", value=req.duration)
    poses = np.empty((total, 3))
    joints = np.empty((total, arm.dof))
    offset = 0
    ref = reference
    marks: dict[int, int] = {}  # sample index → waypoint index, where a waypoint is sampled
    segment = 0
    for piece, n in zip(pieces, counts, strict=True):
        if piece.path is not None:
            last = segment + len(piece.path.segments)
            marks[offset], marks[offset + n] = segment, last
            segment = last
        try:
            p, q = piece.sample(n, arm, ref)
        except UnreachableError as exc:
            _unreachable(req, piece, n, ref, offset, poses, joints, exc)
        lo = 0 if offset == 0 else 1
        poses[offset + lo: offset + n + 1] = p[lo:]
        joints[offset + lo: offset + n + 1] = q[lo:]
        offset += n
        ref = q[-1]
    t = np.arange(total) / rate
    ticks = _validate(req, t, poses, joints, marks=marks)
    return Trajectory(t, poses, joints, ticks, arm.joint_names, arm.servo_ids, rate,
                      req.method if isinstance(req.method, str) else list(req.method), req)


def _unreachable(req: PlanRequest, piece: _Piece, n: int, ref: NDArray | None, offset: int,
                 poses: NDArray, joints: NDArray, exc: UnreachableError) -> None:
    """Report a sample out of reach, unless an earlier sample already fails another check."""
    # The piece's sample 0 is the plan's sample ``offset`` (shared with the piece before).
    local = exc.sample
    i = offset + local
    if local > 0:
        tau = np.arange(local) / n
        p = piece.path(timing.profile(piece.profile, tau, piece.accel_fraction))
        poses[offset:i] = p
        joints[offset:i] = _joints(req.arm, p, ref)
    if i > 0:
        # With "auto" the search could not time a path that leaves the workspace, so speeds
        # before the gap say nothing: report the gap itself.
        _validate(req, np.arange(i) / req.rate_hz, poses[:i], joints[:i],
                  dynamics=req.duration != "auto")
    detail = exc.message.split("out of reach: ", 1)[-1]
    _raise_at(UnreachableError, req, i, exc.pose, None, f"is out of reach: {detail}", exc.pose)


def _raise_at(cls: type[PlanError], req: PlanRequest, i: int, pose: Sequence[float],
              joint: str | None, what: str, value: Any = None, field: str = "waypoints",
              waypoint: int | None = None) -> None:
    t = i / req.rate_hz
    pose = [float(v) for v in pose]
    who = f"joint {joint!r} " if joint else ""
    where = ""
    if waypoint is not None:
        field = f"waypoints[{waypoint}]"
        where = f"{field}, "
    raise cls(f"sample {i} ({where}t={t:.3f} s, {_fmt_pose(pose)}): {who}{what}", field=field,
              value=value, sample=i, t=t, pose=pose, joint=joint)


def _validate(req: PlanRequest, t: NDArray, poses: NDArray, joints: NDArray,
              dynamics: bool = True, marks: dict[int, int] | None = None
              ) -> NDArray[np.int64]:
    """All checks at once; raises for the earliest failing sample (ties: position limits,
    ticks, velocity, acceleration). ``dynamics=False`` skips velocity and acceleration;
    ``marks`` maps sample indices to the waypoints sampled there, so that a waypoint outside
    the joint or tick limits is named as such."""
    arm = req.arm
    rate = req.rate_hz
    n = joints.shape[0]
    lo = np.array([j.min_angle for j in arm.joints]) - ANGLE_SLACK
    hi = np.array([j.max_angle for j in arm.joints]) + ANGLE_SLACK
    v, a = _limits(arm)
    if not dynamics:
        v = a = np.full(arm.dof, np.inf)
    ticks = servo_units.ticks_unchecked(joints, arm.servos)
    tmin = np.array([j.servo.min_tick for j in arm.joints])
    tmax = np.array([j.servo.max_tick for j in arm.joints])
    slack = 1.0 + LIMIT_SLACK
    # Fast path: per-joint extremes on contiguous columns; per-sample arrays only on failure.
    fine = True
    for j in range(arm.dof):
        q = np.ascontiguousarray(joints[:, j])
        tick = np.ascontiguousarray(ticks[:, j])
        fine = (lo[j] <= q.min() and q.max() <= hi[j] and tmin[j] <= tick.min()
                and tick.max() <= tmax[j])
        if fine and n > 1:
            d = np.diff(q)
            fine = max(d.max(), -d.min()) * rate <= v[j] * slack
            if fine:
                # At rest on both sides: the end velocities are accelerations from/to zero.
                d2 = np.diff(d) if n > 2 else np.empty(0)
                step = max(abs(d[0]), abs(d[-1]), d2.max(initial=0.0), -d2.min(initial=0.0))
                fine = step * (rate * rate) <= a[j] * slack
        if not fine:
            break
    if fine:
        return ticks
    vel = np.zeros_like(joints)
    acc = np.zeros_like(joints)
    if n > 1:
        np.abs(np.diff(joints, axis=0), out=vel[1:])
    if n > 2:
        np.abs(joints[2:] - 2.0 * joints[1:-1] + joints[:-2], out=acc[2:])
    if n > 1:
        # Starting from and ending at rest (module docstring).
        acc[1] = np.maximum(acc[1], vel[1])
        acc[-1] = np.maximum(acc[-1], vel[-1])
    vel *= rate
    acc *= rate * rate
    # excess[i, j] > 0 marks a violation; one array per check, rows aligned with samples.
    pos_excess = np.maximum(lo - joints, joints - hi)
    tick_excess = np.maximum(tmin - ticks, ticks - tmax).astype(np.float64)
    vel_ratio = vel / v
    acc_ratio = acc / a
    checks = [
        (pos_excess > 0.0, pos_excess, JointLimitError),
        (tick_excess > 0.0, tick_excess, TickLimitError),
        (vel_ratio > slack, vel_ratio, VelocityLimitError),
        (acc_ratio > slack, acc_ratio, AccelerationLimitError),
    ]
    first = n
    chosen = None
    for bad, score, cls in checks:
        rows = bad.any(axis=1)
        if rows.any():
            i = int(np.argmax(rows))
            if i < first:
                first, chosen = i, (bad, score, cls)
    if chosen is None:
        return ticks
    bad, score, cls = chosen
    i = first
    j = int(np.argmax(np.where(bad[i], score[i], -np.inf)))
    spec = arm.joints[j]
    name = spec.name
    if cls is JointLimitError:
        what = (f"at {joints[i, j]:.4f} rad ({math.degrees(joints[i, j]):.1f}°) is outside its "
                f"limits {spec.min_angle:.4f}..{spec.max_angle:.4f} rad "
                f"({math.degrees(spec.min_angle):.1f}..{math.degrees(spec.max_angle):.1f}°)")
        _raise_at(cls, req, i, poses[i], name, what, float(joints[i, j]),
                  waypoint=(marks or {}).get(i))
    if cls is TickLimitError:
        what = (f"needs tick {ticks[i, j]} (servo id {spec.servo.id}), outside its tick "
                f"limits {spec.servo.min_tick}..{spec.servo.max_tick}")
        _raise_at(cls, req, i, poses[i], name, what, int(ticks[i, j]),
                  waypoint=(marks or {}).get(i))
    if cls is VelocityLimitError:
        what = (f"needs {vel[i, j]:.4g} rad/s, limit {spec.max_velocity:.4g} rad/s: lengthen "
                "the duration")
        _raise_at(cls, req, i, poses[i], name, what, float(vel[i, j]), field="duration")
    what = (f"needs {acc[i, j]:.4g} rad/s², limit {spec.max_acceleration:.4g} rad/s²: lengthen "
            "the duration")
    _raise_at(cls, req, i, poses[i], name, what, float(acc[i, j]), field="duration")
    raise AssertionError("unreachable")  # pragma: no cover


def plan(arm: Arm, waypoints: ArrayLike, *, method: str | Sequence[str] = "sclerp",
         beta: float = 1.0, turn: str | Sequence[str] = "shortest",
         duration: float | str = "auto", profile: str = "quintic", rate_hz: float = 100,
         blend: bool = False, start_joints: ArrayLike | None = None) -> Trajectory:
    """Plan a validated trajectory through ``waypoints`` for ``arm``.

    Parameters
    ----------
    arm : Arm (robodcn.load_arm)
    waypoints : (m, 3), m ≥ 2 poses (x, y, θ), metres and radians
    method, turn : interpolation method / turn direction, or a list with one per segment
    beta : KenLERP bias
    duration : total seconds (rounded up to whole sample periods) or "auto" (shortest
        feasible; module docstring)
    profile : "linear" | "quintic" | "trapezoid"
    rate_hz : 1..1000 Hz
    blend : pass through via points with continuous velocity
    start_joints : (k,) present joints; a joint-space approach is prepended when they differ
        from the IK of waypoints[0]

    Raises
    ------
    InputError
        Bad arguments (naming the field), too many samples (> 10⁶).
    UnreachableError, JointLimitError, TickLimitError, VelocityLimitError,
    AccelerationLimitError
        The first failing sample's index, time, pose and joint.
    """
    if isinstance(method, list):
        method = tuple(method)
    if isinstance(turn, list):
        turn = tuple(turn)
    req = PlanRequest(arm=arm, waypoints=waypoints, method=method, beta=beta, turn=turn,
                      duration=duration, profile=profile, rate_hz=rate_hz, blend=blend,
                      start_joints=start_joints)
    return plan_request(req)

