"""The geometric path of a plan: segments, blending, pieces with their time laws, IK."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from robodcn import kinematics, timing
from robodcn.config import Arm
from robodcn.contract.request import PlanRequest
from robodcn.interpolate import interpolate, turn_angle
from robodcn.path_timing.limits import JointLimits

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
        """The segment's interpolation at path parameters ``s`` (robodcn.interpolate)."""
        return interpolate(self.start, self.end, s, method=self.method, beta=self.beta,
                           turn=self.turn)


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


class Piece:
    """A part of the plan with its own time law: a pose path or a joint-space approach."""

    def __init__(self, *, path: Path | None = None, profile: str = "quintic",
                 q_from: NDArray | None = None, q_to: NDArray | None = None,
                 elbow: str = "up") -> None:
        self.path = path
        self.elbow = elbow
        self.profile = profile
        self.accel_fraction = timing.DEFAULT_ACCEL_FRACTION
        self.q_from = q_from
        self.q_to = q_to

    def sample(self, n: int, arm: Arm, reference: NDArray | None
               ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, int | None]:
        """Poses and joints (n + 1 rows) at τ_i = i/n, and None; or poses, None and the
        local index of the first pose out of reach."""
        tau = np.arange(n + 1) / n
        if self.path is None:
            q = self.q_from + np.outer(timing.quintic(tau), self.q_to - self.q_from)
            return kinematics.fk(arm.links, q), q, None
        poses = self.path(timing.profile(self.profile, tau, self.accel_fraction))
        q, bad = joints_of(arm, poses, reference, self.elbow)
        if q is not None and arm.dof == 2:
            poses[:, 2] = q[:, 0] + q[:, 1]  # θ plays no part: report the arm's own (FK)
        return poses, q, bad


def joints_of(arm: Arm, poses: NDArray[np.float64], reference: NDArray | None, elbow: str
              ) -> tuple[NDArray[np.float64] | None, int | None]:
    """Branch-continuous IK of ``poses`` (kinematics.try_ik_path): the first sample on
    ``elbow`` (or nearest ``reference``), each later one on the branch nearest the previous
    sample; or (None, first pose out of reach)."""
    limits = [(j.min_angle, j.max_angle) for j in arm.joints]
    return kinematics.try_ik_path(arm.links, poses, reference=reference, elbow=elbow,
                                  limits=limits)


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
    q, _ = kinematics.try_ik_path(arm.links, piece.path(s), reference=reference,
                                  elbow=piece.elbow)
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


def segments_of(req: PlanRequest) -> list[Segment]:
    """(start, end, method, turn, β) per segment with θ chained continuously across waypoints.

    On a position-only (2-joint) arm θ plays no part: every θ is 0, so each segment is the
    straight-line position interpolation whatever the method (no rotation to screw about).
    """
    wp = req.waypoints_array
    if req.position_only:
        wp[:, 2] = 0.0
    out = []
    start = wp[0].copy()
    for j in range(req.segments):
        turn = req.segment_turn(j)
        end = wp[j + 1].copy()
        end[2] = start[2] + turn_angle(start[2], wp[j + 1, 2], turn)
        out.append(Segment(start, end, req.segment_method(j), turn, req.segment_beta(j)))
        start = end
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
        q, _ = kinematics.try_ik_path(arm.links, poses, reference=ref, elbow=req.branch)
        if q is not None:
            weights.append(float(np.max(np.abs(np.diff(q, axis=0)).sum(axis=0) / v)))
            ref = q[-1]
        else:
            weights.append(float(np.linalg.norm(np.diff(poses[:, :2], axis=0), axis=1).sum()))
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


