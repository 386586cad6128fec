"""The geometric path of a plan: segments, blending, pieces with their time laws, IK.

Path poses are a planar arm's (x, y, θ) and a yawed arm's plane poses (yaw, r, z, pitch)
(:mod:`~robodcn.planner.yawed`); the functions here that touch poses or IK dispatch on the
arm (:func:`pose_of`, :func:`joints_of`, :func:`to_user`), so the timing laws never ask
which kind of arm they time.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from robodcn import kinematics, timing
from robodcn.config import Arm
from robodcn.contract.request import PlanRequest
from robodcn.interpolate import interpolate_unchecked, turn_angle
from robodcn.path_timing.limits import JointLimits
from robodcn.planner import arm_arrays, yawed

#: Samples of the coarse uniform grid used for estimates and path shaping.
COARSE = 128


class Segment(NamedTuple):
    """One segment of a path: its end poses (θ chained), method, turn and KenLERP β."""

    start: NDArray[np.float64]
    end: NDArray[np.float64]
    method: str
    turn: str
    beta: float

    def poses(self, s: NDArray[np.float64]) -> NDArray[np.float64]:
        """The segment's interpolation at path parameters ``s`` (robodcn.interpolate; a
        yawed arm's in its plane, :func:`robodcn.planner.yawed.interpolate_plane`)."""
        if self.start.shape[0] == 4:
            return yawed.interpolate_plane(self.start, self.end, s, self.method, self.beta,
                                           self.turn)
        return interpolate_unchecked(self.start, self.end, s, self.method, self.beta,
                                     self.turn)


class Path:
    """A pose curve P(u), u ∈ [0, 1], over one or more segments with knots U; each segment
    is interpolated with its own method, turn and β (:class:`Segment`)."""

    def __init__(self, segments: list[Segment], knots: NDArray[np.float64],
                 corrections: list[tuple[NDArray, NDArray]] | None):
        self.segments = segments
        self.knots = knots
        self.corrections = corrections

    def segment_poses(self, j: int, s: NDArray[np.float64]) -> NDArray[np.float64]:
        poses = self.segments[j].poses(s)
        if self.corrections is not None:
            d0, d1, g0, g1 = self.corrections[j]
            # quintic Hermite basis, zero at both ends: unit slope at 0 / at 1, unit second
            # derivative at 0 / at 1 (every other end value and derivative zero)
            s2, r = s * s, 1.0 - s
            poses += ((s - 6.0 * s * s2 + 8.0 * s2 * s2 - 3.0 * s2 * s2 * s)[:, None] * d0
                      + (s2 * s * (-4.0 + 7.0 * s - 3.0 * s2))[:, None] * d1
                      + (0.5 * s2 * r ** 3)[:, None] * g0
                      + (0.5 * s2 * s * r * r)[:, None] * g1)
        return poses

    def __call__(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        if len(self.segments) == 1:
            return self.segment_poses(0, u)
        out = np.empty((u.shape[0], self.segments[0].start.shape[0]))
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


class Piece:
    """A part of the plan with its own time law: a pose path or a joint-space approach."""

    def __init__(self, *, path: Path | None = None, profile: str = "quintic",
                 q_from: NDArray | None = None, q_to: NDArray | None = None,
                 elbow: str = "up") -> None:
        self.path = path
        self.elbow = elbow
        self.profile = profile
        self.accel_fraction = timing.DEFAULT_ACCEL_FRACTION
        #: (v_s, a_s): the path speed and acceleration limits over s ∈ [0, 1] of a
        #: trapezoid piece (:func:`shape_trapezoid`), for :func:`fit_trapezoid`
        self.path_limits: tuple[float, float] | None = None
        self.q_from = q_from
        self.q_to = q_to

    def sample_many(self, counts: Sequence[int], arm: Arm, reference: NDArray | None
                    ) -> list[tuple[NDArray[np.float64], NDArray[np.float64] | None,
                                    int | None]]:
        """:meth:`sample` at each of ``counts``, each exactly as alone; a one-segment pose
        path of a planar arm is interpolated and solved for all of them in one pass
        (kinematics.ik_paths_unchecked)."""
        if self.path is None or len(self.path.segments) != 1 or arm.yawed or min(counts) < 1:
            return [self.sample(n, arm, reference) for n in counts]
        tau = np.concatenate([np.arange(n + 1) / n for n in counts])
        # one segment: its poses are the interpolation at each parameter, in any order
        poses = self.path(timing.profile_unchecked(self.profile, tau, self.accel_fraction))
        consts = arm_arrays.arrays_of(arm)
        ref = None if reference is None else np.asarray(reference, dtype=np.float64)
        rows = [n + 1 for n in counts]
        solved = kinematics.ik_paths_unchecked(consts.links, poses, rows, ref, self.elbow,
                                               consts.angle_limits)
        out = []
        ends = list(itertools.accumulate(rows))  # plain ints: numpy's cumsum of a list is slow
        for (q, bad), a, b in zip(solved, [0, *ends[:-1]], ends, strict=True):
            p = poses[a:b]
            if q is not None and arm.dof == 2:
                p[:, 2] = q[:, 0] + q[:, 1]  # θ plays no part: report the arm's own (FK)
            out.append((p, q, bad))
        return out

    def sample(self, n: int, arm: Arm, reference: NDArray | None
               ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, int | None]:
        """Poses and joints (n + 1 rows) at τ_i = i/n, and None; or poses, None and the
        local index of the first pose out of reach."""
        if self.path is None:
            q = self.q_from + np.outer(_law_grid("quintic", n, timing.DEFAULT_ACCEL_FRACTION),
                                       self.q_to - self.q_from)
            return pose_of(arm, q), q, None
        poses = self.path(_law_grid(self.profile, n, self.accel_fraction))
        q, bad = joints_of(arm, poses, reference, self.elbow)
        if q is not None and arm.dof == 2:
            poses[:, 2] = q[:, 0] + q[:, 1]  # θ plays no part: report the arm's own (FK)
        return poses, q, bad


@functools.lru_cache(maxsize=64)
def _law_grid(profile: str, n: int, accel_fraction: float) -> NDArray[np.float64]:
    """The uniform law's path parameters u_i = profile(i/n), i = 0..n (timing.
    profile_unchecked), read-only: the auto search's estimate samples every piece at
    COARSE periods, each plan anew."""
    u = timing.profile_unchecked(profile, np.arange(n + 1) / n, accel_fraction)
    u.setflags(write=False)
    return u


def pose_width(arm: Arm) -> int:
    """Numbers in a path pose: 3 (x, y, θ) or, for a yawed arm, 4 (yaw, r, z, pitch)."""
    return 4 if arm.yawed else 3


def angle_column(arm: Arm) -> int:
    """The path pose's column of the in-plane rotation: θ, or a yawed arm's pitch."""
    return 3 if arm.yawed else 2


def pose_of(arm: Arm, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Path poses (n, 3|4) of joints q (n, k): planar FK, or a yawed arm's plane poses."""
    if arm.yawed:
        return yawed.plane_pose_of(arm, q)
    # the planner's joints are its own (finite, (n, k)): fk's argument checks skipped
    return kinematics.fk_unchecked(arm_arrays.arrays_of(arm).links,
                                   np.asarray(q, dtype=np.float64))


def to_user(arm: Arm, poses: NDArray[np.float64]) -> NDArray[np.float64]:
    """Path poses → the user's poses: the same array for a planar arm, (x, y, z, pitch) in
    the base frame for a yawed one."""
    return yawed.to_user(poses) if arm.yawed else poses


def user_pose(arm: Arm, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """The user's poses (n, 3|4) of joints q (n, k): (x, y, θ), or (x, y, z, pitch)."""
    return to_user(arm, pose_of(arm, q))


def same_pose(req: PlanRequest, a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    """Whether two of the user's poses are one: positions within 0.1 mm, θ (pitch) within
    0.01° modulo 2π (θ ignored on a position-only arm)."""
    k = len(req.arm.pose_keys) - 1
    gap = abs((b[k] - a[k] + math.pi) % (2 * math.pi) - math.pi)
    return bool(np.abs(a[:k] - b[:k]).max() <= 1e-4 and (req.position_only or gap <= 1.75e-4))


def _ik(arm: Arm, poses: NDArray[np.float64], reference: NDArray | None, elbow: str,
        limits: Sequence[tuple[float, float]] | None = None
        ) -> tuple[NDArray[np.float64] | None, int | None]:
    if arm.yawed:
        return yawed.plane_joints(arm, poses, reference, elbow, limits)
    # the request is validated: the links, the path's poses and the reference are checked
    ref = None if reference is None else np.asarray(reference, dtype=np.float64)
    return kinematics.ik_path_unchecked(arm_arrays.arrays_of(arm).links, poses, ref, elbow,
                                        limits)


def joints_of(arm: Arm, poses: NDArray[np.float64], reference: NDArray | None, elbow: str
              ) -> tuple[NDArray[np.float64] | None, int | None]:
    """Branch-continuous IK of path ``poses`` (kinematics.try_ik_path; a yawed arm's
    :func:`robodcn.planner.yawed.plane_joints`): the first sample on ``elbow`` (or nearest
    ``reference``), each later one on the branch nearest the previous sample; or (None,
    first pose out of reach)."""
    return _ik(arm, poses, reference, elbow, arm_arrays.arrays_of(arm).angle_limits)


def first_joints(arm: Arm, pose: NDArray[np.float64], reference: NDArray | None, elbow: str
                 ) -> NDArray[np.float64]:
    """The joints (k,) of one path pose that a checked waypoint is (:func:`joints_of`)."""
    q, _ = joints_of(arm, np.asarray(pose, dtype=np.float64)[None, :], reference, elbow)
    assert q is not None, "waypoints are checked reachable before any path is built"
    return q[0]


def start_of(req: PlanRequest) -> NDArray[np.float64] | None:
    """The joints the plan starts from: start_joints, a start state's joints, or None."""
    if req.start_joints is not None:
        return np.asarray(req.start_joints, dtype=np.float64)
    if req.start_state is not None:
        return req.start_state.arrays()[0]
    return None


def plan_waypoints(req: PlanRequest) -> NDArray[np.float64]:
    """The path poses the plan runs through: the waypoints (θ = 0 on a position-only arm; a
    yawed arm's in its plane, yaws unwrapped from the start), and before a lone waypoint
    the pose of the start (a one-waypoint request starts there: the contract's rule)."""
    arm = req.arm
    wp = req.waypoints_array
    start = start_of(req)
    if arm.yawed:
        wp = yawed.plane_waypoints(arm, wp, start)
    elif req.position_only:
        wp[:, 2] = 0.0
    if wp.shape[0] == 1:
        assert start is not None, "the contract needs a start for a lone waypoint"
        first = pose_of(arm, start[None, :])
        if req.position_only:
            first[:, 2] = 0.0
        wp = np.vstack([first, wp])
    return wp


def rate_limits(arm: Arm) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The arm's per-joint velocity and acceleration limits (JointLimits.of)."""
    lim = JointLimits.of(arm)
    return lim.v, lim.a


def shape_trapezoid(piece: Piece, arm: Arm, reference: NDArray | None) -> None:
    """Pick the trapezoid's acceleration fraction from path-space limits (timing module).

    Path speed ṡ makes joint speeds |q'(s)|·ṡ and (neglecting the q''(s)·ṡ² term)
    accelerations |q'(s)|·s̈, so the path limits are v_s = min v_j/max|q_j'|, a_s =
    min a_j/max|q_j'| and the time-optimal trapezoid over s ∈ [0, 1] has ρ from
    trapezoid_min_time(1, v_s, a_s); ρ is kept in [0.05, 0.5].
    """
    if piece.profile != "trapezoid" or piece.path is None:
        return
    s = np.linspace(0.0, 1.0, COARSE + 1)
    q, _ = _ik(arm, piece.path(s), reference, piece.elbow)
    if q is None:
        return  # validation reports it with the real sample index
    slope = np.abs(np.diff(q, axis=0)).max(axis=0) * COARSE
    if not np.any(slope > 0.0):
        return
    v, a = rate_limits(arm)
    with np.errstate(divide="ignore"):
        v_s = float(np.min(v / slope))
        a_s = float(np.min(a / slope))
    _, rho = timing.trapezoid_min_time(1.0, v_s, a_s)
    piece.accel_fraction = min(0.5, max(0.05, rho))
    piece.path_limits = (v_s, a_s)


def fit_trapezoid(piece: Piece, arm: Arm, duration_s: float) -> bool:
    """The trapezoid's acceleration fraction for a piece given ``duration_s`` (a fixed
    duration); True if ρ changed.

    :func:`shape_trapezoid` gives the minimum-time ρ* over s ∈ [0, 1] in T* (timing.
    trapezoid_min_time): a triangle (ρ* = ½) whenever the velocity limit does not bind, so a
    fixed duration with time to spare had no cruise at all. Given T, ρ moves from ρ* (T ≤
    1.3 T*, so that a duration near the minimum, such as ``auto``'s own, times the same law)
    linearly to the default ρ = ¼ (T ≥ 2 T*: accelerate a quarter of the time, cruise half,
    decelerate a quarter); a ρ* ≤ ¼ already cruises and is kept. Both ends are within the
    path limits there (the path acceleration 1/(ρ(1 − ρ)T²) and speed 1/((1 − ρ)T) fall
    with T faster than ρ(1 − ρ) and 1 − ρ do). Under a jerk limit ρ* is kept: the trapezoid
    steps its acceleration, so its sampled jerk ≈ A·rate, which a smaller ρ raises.
    """
    limits = piece.path_limits
    if piece.profile != "trapezoid" or limits is None or not duration_s > 0.0 \
            or any(j.max_jerk is not None for j in arm.joints):
        return False
    fastest, rho_star = timing.trapezoid_min_time(1.0, *limits)
    rho_star = min(0.5, max(0.05, rho_star))
    target = timing.DEFAULT_ACCEL_FRACTION
    if rho_star <= target:
        rho = rho_star
    else:
        spare = min(1.0, max(0.0, (duration_s / fastest - 1.3) / 0.7))
        rho = rho_star + (target - rho_star) * spare
    changed = rho != piece.accel_fraction
    piece.accel_fraction = rho
    return changed


def segments_of(req: PlanRequest) -> list[Segment]:
    """(start, end, method, turn, β) per segment with θ chained continuously across waypoints
    (:func:`plan_waypoints`; a yawed arm's pitch likewise, its yaw as unwrapped there).

    On a position-only (2-joint) arm θ plays no part: every θ is 0, so each segment is the
    straight-line position interpolation whatever the method (no rotation to screw about).
    """
    # the chaining in plain floats (the same sums; numpy scalars cost more on a few poses),
    # one array per waypoint, each segment's end the next one's start
    rows = plan_waypoints(req).tolist()
    k = angle_column(req.arm)
    out = []
    start = rows[0]
    start_array = np.array(start)
    for j in range(req.segments):
        turn = req.segment_turn(j)
        end = rows[j + 1]
        end[k] = start[k] + turn_angle(start[k], end[k], turn)
        end_array = np.array(end)
        out.append(Segment(start_array, end_array, req.segment_method(j), turn,
                           req.segment_beta(j)))
        start, start_array = end, end_array
    return out


def blended_path(req: PlanRequest, segments: list[Segment], reference: NDArray | None
                 ) -> Path:
    """One path through all waypoints with Bessel tangents at the via points (module doc).

    C²: each segment's pose curve L(s) gets the quintic Hermite correction that sets, at both
    of its ends, dP/du to the knot-weighted (Bessel) average of the two neighbouring
    segments' tangents and d²P/du² to the same average of their second derivatives; the
    path's ends keep the segment's own. So the joint path q(u) = IK(P(u)) is C² through the
    vias (finite jerk at any speed), where the cubic correction left a step of q''.
    """
    arm = req.arm
    v, _ = rate_limits(arm)
    weights = []
    ref = reference
    for seg in segments:
        single = Path([seg], np.array([0.0, 1.0]), None)
        s = np.linspace(0.0, 1.0, 33)
        poses = single(s)
        q, _ = _ik(arm, poses, ref, req.branch)
        if q is not None:
            weights.append(float(np.max(np.abs(np.diff(q, axis=0)).sum(axis=0) / v)))
            ref = q[-1]
        else:
            k = angle_column(arm)  # the position columns come just before the angle
            weights.append(float(np.linalg.norm(np.diff(poses[:, k - 2:k], axis=0),
                                                axis=1).sum()))
    w = np.asarray(weights)
    w = np.maximum(w, 1e-3 * w.max() if w.max() > 0 else 1.0)
    knots = np.concatenate([[0.0], np.cumsum(w) / w.sum()])
    knots[-1] = 1.0
    span = np.diff(knots)
    h, h2 = 1e-6, 1e-4
    ends = []  # (dL/ds, d²L/ds²) at s = 0 and at s = 1 per segment, central differences
    for seg in segments:
        p = seg.poses(np.array([-h, h, 1.0 - h, 1.0 + h]))
        c = seg.poses(np.array([-h2, 0.0, h2, 1.0 - h2, 1.0, 1.0 + h2]))
        ends.append(((p[1] - p[0]) / (2 * h), (p[3] - p[2]) / (2 * h),
                     (c[0] - 2 * c[1] + c[2]) / h2 ** 2, (c[3] - 2 * c[4] + c[5]) / h2 ** 2))
    m = len(segments)
    tangents = [ends[0][0] / span[0]]  # dP/du at each knot
    curvatures = [ends[0][2] / span[0] ** 2]  # d²P/du² at each knot
    for j in range(1, m):
        w_in, w_out = span[j] / (span[j - 1] + span[j]), span[j - 1] / (span[j - 1] + span[j])
        tangents.append(w_in * ends[j - 1][1] / span[j - 1] + w_out * ends[j][0] / span[j])
        curvatures.append(w_in * ends[j - 1][3] / span[j - 1] ** 2
                          + w_out * ends[j][2] / span[j] ** 2)
    tangents.append(ends[-1][1] / span[-1])
    curvatures.append(ends[-1][3] / span[-1] ** 2)
    corrections = [(span[j] * tangents[j] - ends[j][0], span[j] * tangents[j + 1] - ends[j][1],
                    span[j] ** 2 * curvatures[j] - ends[j][2],
                    span[j] ** 2 * curvatures[j + 1] - ends[j][3]) for j in range(m)]
    return Path(segments, knots, corrections)


def within_limits(q: NDArray[np.float64], limits: Sequence[tuple[float, float]]
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


