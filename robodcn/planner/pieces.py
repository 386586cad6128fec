"""The optimal law's pieces: the path cut at its stops, each with its dense joint path q(s).

The path is cut at every via where it stops (``blend=False``): ṡ = 0 there, so the
time-optimal law of the whole path is the concatenation of the pieces' own rest-to-rest laws
(the stops decouple them exactly); each piece is timed on ``DENSE`` IK samples a segment of
its joint path q(s) (``DENSE_JERK`` when a joint sets a jerk limit; above ``DENSE_RATE_HZ``
a law whose samples fail is timed again on more, :func:`dense_per_segment`). With ``blend=True``
the whole path is one piece that passes every via. A
joint-space approach from ``start_joints`` (or a moving start's brake) is a piece of its own
(a straight joint line). With a start state the path runs from FK(q0) first
(:func:`segments_from_start`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from robodcn.config import Arm
from robodcn.contract.request import PlanRequest
from robodcn.interpolate import turn_angle
from robodcn.path_timing import PathTiming
from robodcn.path_timing.arclength import Smooth
from robodcn.planner import arm_arrays
from robodcn.planner.path import (
    Path,
    Segment,
    angle_column,
    blended_path,
    joints_of,
    plan_waypoints,
    pose_of,
    same_pose,
    segments_of,
    to_user,
    within_limits,
)

#: IK samples per path segment the law is timed on (the whole path at most DENSE_MAX). A
#: jerk-free law reads q′ and q″ alone: on DENSE samples their second-order differences, and
#: the C² interpolant the plan's joints are sampled from, keep the path within ~1e-8 m (3 nm
#: seen on the test paths). The jerk pass also reads q‴, whose third differences need the
#: finer DENSE_JERK (on DENSE it reads their error as curvature and slows the law).
DENSE = 100
DENSE_JERK = 400
DENSE_MAX = 4000
#: Above this rate a jerk-free law is timed on proportionally more dense samples (up to
#: DENSE_JERK: ``build_pieces(fine=True)``) — an auto law from rest at once, any other when
#: its samples fail validation, before it is slowed: the plan's samples then resolve the
#: interpolant's q″ between the dense samples, which the grid's stages did not see, and a
#: slow stretches the whole piece (at 1 kHz on DENSE up to 2.5 % longer than on
#: DENSE_JERK; at 100–250 Hz within a period).
DENSE_RATE_HZ = 250.0


def dense_per_segment(req: PlanRequest, segments: int, fine: bool = False) -> int:
    """IK samples per segment the optimal law of ``req`` is timed on, on a path of
    ``segments`` segments (the constants above)."""
    # JointLimits.jerk_limited, read off the arm's arrays built once (planner.arm_arrays)
    if arm_arrays.arrays_of(req.arm).jerk_limited:
        dense = DENSE_JERK
    elif fine:
        dense = min(DENSE_JERK, math.ceil(DENSE * max(1.0, req.rate_hz / DENSE_RATE_HZ)))
    else:
        dense = DENSE
    return max(16, min(dense, DENSE_MAX // max(1, segments)))


@dataclass
class DensePiece:
    """A stretch of the plan with its own law: path pieces map s → poses, the approach
    s → joints (s ∈ [0, 1])."""

    path: Path | None
    segment0: int  # index of the first waypoint segment (−1 on the approach)
    q_from: NDArray | None = None
    q_to: NDArray | None = None
    s: NDArray | None = None
    q: NDArray | None = None
    law: PathTiming | None = None
    count: int = 0
    _smooth: tuple[NDArray, NDArray, Smooth] | None = field(default=None, repr=False,
                                                              compare=False)

    def poses(self, s: NDArray, arm: Arm) -> NDArray:
        if self.path is None:
            return pose_of(arm, self.joints_line(s))
        return self.path(np.clip(s, 0.0, 1.0))

    def joints_line(self, s: NDArray) -> NDArray:
        return self.q_from + np.outer(np.clip(s, 0.0, 1.0), self.q_to - self.q_from)

    def interpolant(self) -> Smooth:
        """The C² interpolant q(s) of the dense samples (:class:`~robodcn.path_timing.
        arclength.Smooth`), built once per (s, q): a slowed law is sampled again on it."""
        cached = self._smooth
        if cached is None or cached[0] is not self.s or cached[1] is not self.q:
            assert self.s is not None and self.q is not None
            cached = self._smooth = (self.s, self.q, Smooth(self.s, self.q))
        return cached[2]


#: The uniform grids of :func:`_dense_s`'s one-segment paths by sample count (read-only)
_UNIFORM: dict[int, NDArray] = {}


def _dense_s(path: Path, count: int) -> NDArray:
    """Path parameters for the dense samples: uniform per segment, every knot included (one
    segment: numpy.linspace(0, 1, count + 1), the same values, kept read-only per count)."""
    knots = path.knots
    if knots.shape[0] == 2 and knots[0] == 0.0 and knots[1] == 1.0:
        grid = _UNIFORM.get(count)
        if grid is None:
            grid = _UNIFORM[count] = np.linspace(0.0, 1.0, count + 1)
            grid.setflags(write=False)
        return grid
    parts = [np.linspace(knots[i], knots[i + 1], count + 1)[:-1] for i in range(len(knots) - 1)]
    return np.concatenate([*parts, [1.0]])


def _moves(q: NDArray) -> bool:
    """Whether a joint moves along the samples q (n, k): its range above 1e-12 rad (numpy.ptp
    as max − min, without its wrapper). The range is at least |q_end − q_start| (both are
    in it), so a piece whose ends differ by more moves: told from its two rows in plain
    floats, the reductions only for a piece that returns to where it started."""
    first, last = q[0].tolist(), q[-1].tolist()
    if max(abs(b - a) for a, b in zip(first, last, strict=True)) > 1e-12:
        return True
    return float((np.maximum.reduce(q, axis=0) - np.minimum.reduce(q, axis=0)).max()) > 1e-12


def _pieces(req: PlanRequest, segments: list[Segment]) -> list[DensePiece]:
    if req.blend:
        start = None if req.start_state is None else req.start_state.arrays()[0]
        return [DensePiece(blended_path(req, segments, start), 0)]
    return [DensePiece(Path([seg], np.array([0.0, 1.0]), None), j)
            for j, seg in enumerate(segments)]


def segments_from_start(req: PlanRequest) -> list[Segment]:
    """The request's segments; with a start state, from FK(q0) first (request docstring):
    the prepended segment takes segment 0's method, turn and β, θ (a yawed arm's pitch)
    chained on from the arm's."""
    if req.start_state is None:
        return segments_of(req)
    arm = req.arm
    q0 = req.start_state.arrays()[0]
    pose = pose_of(arm, q0[None, :])[0]
    wp = plan_waypoints(req)
    if req.position_only:
        pose[2] = 0.0
    close = same_pose(req, *to_user(arm, np.vstack([pose, wp[0]])))
    methods = [req.segment_method(j) for j in range(req.segments)]
    turns = [req.segment_turn(j) for j in range(req.segments)]
    betas = [req.segment_beta(j) for j in range(req.segments)]
    if close:
        wp = wp[1:]
    else:
        methods, turns, betas = ([methods[0], *methods], [turns[0], *turns],
                                 [betas[0], *betas])
    k = angle_column(arm)
    out = []
    start = pose.copy()
    for j in range(wp.shape[0]):
        end = wp[j].copy()
        end[k] = start[k] + turn_angle(start[k], wp[j, k], turns[j])
        out.append(Segment(start, end, methods[j], turns[j], betas[j]))
        start = end
    return out


def build_pieces(req: PlanRequest, fine: bool = False
                 ) -> tuple[list[DensePiece] | None, NDArray | None]:
    """The pieces with their dense joint paths (None, first bad pose if the path leaves the
    workspace); ``fine``: on the rate's finer density (:func:`dense_per_segment`)."""
    arm = req.arm
    segments = segments_from_start(req)
    pieces = _pieces(req, segments)
    state = req.start_state
    ref = None if state is None else state.arrays()[0]
    if req.start_joints is not None:
        ref = np.asarray(req.start_joints)
    # dense geometry, branch-continuous across pieces
    per = dense_per_segment(req, len(segments), fine)
    first_q = None
    for piece in pieces:
        s = _dense_s(piece.path, per)
        poses = piece.path(s)
        q, bad = joints_of(arm, poses, ref, req.branch)
        if q is None:
            return None, poses[bad]
        if first_q is None:
            first_q = q[0]
        piece.s, piece.q = s, q
        ref = q[-1]
    # a piece along which no joint moves (coincident waypoints) takes no time: drop it
    moving_pieces = [p for p in pieces if _moves(p.q)]
    pieces = moving_pieces or pieces[:1]
    if req.start_joints is not None:
        start = np.asarray(req.start_joints)
        target = within_limits(first_q, [(jt.min_angle, jt.max_angle) for jt in arm.joints])
        tolerance = min(math.pi / jt.servo.ticks_per_turn for jt in arm.joints)
        if np.max(np.abs(target - start)) > tolerance:
            if np.max(np.abs(target - first_q)) > 0:  # the path's turn follows the approach
                shift = target - first_q
                for piece in pieces:
                    piece.q = piece.q + shift
            approach = DensePiece(None, -1, q_from=start, q_to=target)
            approach.s = np.linspace(0.0, 1.0, 3)
            approach.q = approach.joints_line(approach.s)
            pieces.insert(0, approach)
    return pieces, None
