"""The ``profile="optimal"`` timing law: the geometric path timed by robodcn.path_timing.

The geometry is the method's (planner.path: segments, Bessel-tangent blending, branch-
continuous IK); only the time law differs from the uniform profiles. The pipeline
(:mod:`robodcn.planner.build`) samples, validates and retries through :class:`OptimalTiming`.

* **Pieces** (:mod:`~robodcn.planner.pieces`): cut at every stop, each timed by
  :func:`robodcn.path_timing.time_optimal` on its dense joint path, parameterised by its
  joint-space arc length σ (:mod:`~robodcn.planner.arc`: q′(u) is unbounded where a path
  leaves a stretched or folded arm, q′(σ) is not; the dense samples are re-spaced evenly in
  σ there).
* **Sampling.** Each piece's law is sampled from its own t = 0 at the stream rate up to the
  first sample at or after its end (at rest there: a via is a sample at rest); the joints
  are the C² quintic-Hermite interpolant of the dense IK samples the law was timed on (their
  q′, q″ the law's own: :class:`~robodcn.path_timing.arclength.Smooth`) and the poses their
  FK, within interpolation error (~1e-8 m) of the path.
* **Blend** never takes longer than stopping at the vias: :mod:`~robodcn.planner.
  blend_choice` decides, from geometry and limits alone, whether the plan stops there (the
  blended curve departs from the segments and can be longer or more curved than they are).
* **Validation** stays sample by sample (planner.validate, jerk where set). The law is
  timed on a grid, so between grid points a limit can be passed by a little (curvature
  between stages); a piece whose samples fail is slowed by the failing ratio (a uniform
  stretch λ = r^(1/order), a few rounds) and sampled again; a moving first piece is re-timed
  with lower limits instead (a stretch would change its start speed). Nothing is clamped: a
  plan that still fails raises the first failing sample.
* **Fixed duration.** The pieces' optimal laws are stretched uniformly by one factor so that
  their whole periods add up to the duration; a duration shorter than the optimum
  compresses them alike, and validation names the first sample past a limit (as for the
  uniform laws). A fixed duration is never lengthened to pass validation. A moving start
  cannot be stretched (its start velocity would change), so a numeric duration with a
  moving ``start_state`` is refused (InputError on ``duration``).
* **Moving start** (``start_state``): the path runs from FK(q0) (the request's docstring)
  and joins the state by :func:`robodcn.path_timing.moving_start.join` — along the tangent,
  blended out in joint space over its first T_b seconds, or braking along the start
  velocity and going from rest where the brake ends (that module's docstring has the
  maths). A blend that fails validation tries the next (:func:`~robodcn.path_timing.
  moving_start.retry`); without a jerk limit a failing blend brakes instead.
"""

from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np
from numpy.typing import NDArray

from robodcn.contract import MAX_SAMPLES, intervals
from robodcn.contract.request import PlanRequest, StartState
from robodcn.errors import InputError, TooLargeError, Violation
from robodcn.path_timing import JointLimits, moving_start
from robodcn.path_timing.moving_start import JointState, StartSegment
from robodcn.planner import arm_arrays, path, reach, search, validate
from robodcn.planner.arc import by_arc_length
from robodcn.planner.path import joints_of
from robodcn.planner.pieces import DENSE as DENSE  # re-export
from robodcn.planner.pieces import (
    DensePiece,
    build_pieces,
    dense_per_segment,
    segments_from_start,
)
from robodcn.planner.samples import Sampled

log = logging.getLogger(__name__)

#: Rounds of slowing a piece whose samples fail validation (grid effects) before raising.
RETRIES = 6

__all__ = ["DENSE", "RETRIES", "OptimalTiming", "build_pieces", "fit_duration",
           "stretch_factors"]


def _sample(piece: DensePiece, arm, rate: float, ref: NDArray | None, elbow: str
            ) -> tuple[NDArray, NDArray | None, int | None, NDArray]:
    """(poses, joints or None, first sample out of reach, s) of the piece's law."""
    if piece.law is None:  # nothing moves: held for one period
        s = np.zeros(2)
        piece.count = 1
        poses = piece.poses(s, arm)
        q, bad = (piece.joints_line(s), None) if piece.path is None else \
            joints_of(arm, poses, ref, elbow)
        return poses, q, bad, s
    law_s = piece.law.positions(piece.law.sample_times(rate))  # s alone: no ṡ, s̈ needed
    piece.count = law_s.shape[0] - 1
    if piece.path is None:
        q = piece.joints_line(law_s)
        return path.pose_of(arm, q), q, None, law_s
    # the joints between the dense samples the law was timed on: their C² interpolant in
    # the law's own parameter (its q′, q″ at every dense sample), the poses their FK — within
    # interpolation error (~h⁴ q⁗) of the path and its IK, without the IK's √ sensitivity
    # at a stretched end or a second IK pass
    q = piece.interpolant()(law_s)
    return path.pose_of(arm, q), q, None, law_s


def fit_duration(req: PlanRequest, pieces: list[DensePiece]) -> None:
    """Stretch every piece by one factor so the whole periods add up to req.duration."""
    rate = req.rate_hz
    total = intervals(req.duration, rate)
    need = [0.0 if p.law is None else p.law.duration for p in pieces]
    optimum = sum(math.ceil(d * rate - 1e-9) for d in need)
    if total < optimum:
        # shorter than the optimum: the laws compressed uniformly to it, so validation names
        # the first sample past a limit (as for the uniform profiles), nothing is clamped
        lam = total / optimum
        for piece in pieces:
            if piece.law is not None:
                piece.law = piece.law.compressed(lam)
        return
    shares = search.split(total, need)
    # each share covers its piece's optimum (largest remainder may round one down: fix up)
    shares = [max(n, math.ceil(d * rate - 1e-9)) for n, d in zip(shares, need, strict=True)]
    while sum(shares) > total:
        spare = [n - math.ceil(d * rate - 1e-9) for n, d in zip(shares, need, strict=True)]
        shares[int(np.argmax(spare))] -= 1
    for piece, n in zip(pieces, shares, strict=True):
        if piece.law is not None:
            piece.law = piece.law.stretch(max(n / rate, piece.law.duration))


def stretch_factors(req: PlanRequest, joints: NDArray, history: NDArray | None) -> NDArray:
    """Per sample, the uniform stretch λ that brings its finite differences within the limits:
    max(|q̇|/v, √(|q̈|/a), ∛(|q⃛|/j)) over the joints, charged as validation charges them
    (to the last sample of each difference), and spread back over the samples they span."""
    lim = arm_arrays.limits_of(req.arm, torque=False)  # torque: below, with the request's payload
    rate = req.rate_hz
    f = np.ones(joints.shape[0])
    ratios = []
    for order, limit in ((1, lim.v), (2, lim.a), (3, lim.jerk)):
        if not np.isfinite(limit).any():
            continue
        d = validate.differences(joints, order, history) * rate ** order
        ratios.append((order, (d / limit).max(axis=1) ** (1.0 / order)))
    torque = validate.torque_limits(req)
    if torque is not None and joints.shape[0] > 1:
        # τ = (a s̈ + b ṡ²) + g: a stretch λ divides the first part by λ², so λ² =
        # |τ − g| / (τ_max − |g|); where gravity alone overloads a stretch cannot help
        tau, grav = validate.sample_torques(torque, joints, rate, history)
        with np.errstate(divide="ignore", invalid="ignore"):
            room = torque.tau - np.abs(grav)
            need = np.where(np.abs(tau) > torque.tau,
                            np.sqrt(np.abs(tau - grav) / np.where(room > 0, room, np.inf)), 1.0)
        ratios.append((2, np.nan_to_num(need, nan=1.0).max(axis=1)))
    tool = validate.tool_limits(req)
    if tool is not None and joints.shape[0] > 1:
        for quantity, r in validate.tool_ratios(tool, joints, rate, history).items():
            order = validate.ORDER[quantity]
            ratios.append((order, r ** (1.0 / order)))
    for order, r in ratios:
        for back in range(order + 1):  # every sample the difference spans
            f[:f.shape[0] - back] = np.maximum(f[:f.shape[0] - back], r[back:])
    return f


def _slow(piece: DensePiece, factor: float) -> None:
    if piece.law is None or factor <= 1.0:
        return
    factor *= 1.001
    piece.law = piece.law.stretch(piece.law.duration * factor)
    log.debug("optimal: piece slowed by %.4f (its samples passed a limit between the grid's "
              "stages)", factor)


def _brake_then_go(req: PlanRequest, brake: moving_start.Brake, limits: JointLimits,
                   fine: bool) -> list[DensePiece] | None:
    """The brake as a piece, then the request's path planned from rest where it ends (the
    path was to start at the state's pose: it starts where the brake ends instead); None
    when that path leaves the workspace."""
    waypoints = [list(w) for w in req.waypoints]
    here, there = path.user_pose(req.arm, np.vstack([brake.q0, brake.q_stop]))
    if path.same_pose(req, here, np.asarray(waypoints[0])):
        waypoints[0] = [float(x) for x in there]
        if req.position_only:
            waypoints[0][2] = req.waypoints[0][2]
    still = (0.0,) * brake.q0.shape[0]
    rest = dataclasses.replace(req, waypoints=waypoints,
                               start_state=StartState(tuple(brake.q_stop), still, still))
    pieces, _ = build_pieces(rest, fine=fine)
    if pieces is None:
        return None
    for piece in by_arc_length(req, pieces):  # from rest
        piece.law = moving_start.timed(piece.q, piece.s, limits, req.rate_hz)
    if brake.law.duration <= 0.0:  # nothing to brake: from rest where the state is
        return pieces
    first = DensePiece(None, -1, q_from=brake.q0, q_to=brake.q_stop, s=brake.s, q=brake.q,
                       law=brake.law)
    return [first, *pieces]


class OptimalTiming:
    """The optimal law of a request's pieces (module doc), for the pipeline's loop."""

    def __init__(self, req: PlanRequest, pieces: list[DensePiece], fine: bool = False
                 ) -> None:
        self.req = req
        # built once per arm and payload (planner.arm_arrays); the request's tool limits,
        # when it sets any, join them (their derivatives are computed only then)
        self.limits = arm_arrays.limits_of(req.arm, getattr(req, "payload_kg", None))
        tool = validate.tool_limits(req)
        if tool is not None:
            self.limits = dataclasses.replace(self.limits, tool=tool)
        state = req.start_state
        self.start_state = state
        self.state = None if state is None else JointState(*state.arrays())
        self.moving = state is not None and state.moving
        # one round more for refine()
        self.rounds = RETRIES + len(moving_start.BLEND_TRIES) + 1
        self.history = None if self.state is None else validate.start_history(
            self.state.q, self.state.qd, self.state.qdd, req.rate_hz)
        if self.moving and req.duration != "auto":
            raise InputError("duration: a fixed duration cannot be combined with a moving "
                             "start_state (stretching the optimal law would change the start "
                             "velocity): use duration=\"auto\"", field="duration",
                             value=req.duration)
        self.fine = fine  # the pieces are on build_pieces(fine=True)'s density
        self._time(pieces)

    def _time(self, pieces: list[DensePiece]) -> None:
        """Each piece's optimal law (joined to a moving start; stretched to a fixed
        duration). Whether a blend stops at its vias was decided before (planner.
        blend_choice)."""
        req = self.req
        self.pieces = by_arc_length(req, pieces)
        self.path = self.pieces[0]  # the first piece of the path itself (not a brake)
        self.start: StartSegment | None = None
        if self.moving:
            self._join(allow_brake=True)
        else:
            for piece in self.pieces:
                piece.law = moving_start.timed(piece.q, piece.s, self.limits, req.rate_hz)
        if req.duration != "auto":
            fit_duration(req, self.pieces)

    def refine(self) -> bool:
        """Time the path again on the rate's finer dense samples (pieces.DENSE_RATE_HZ)
        instead of slowing it, once; False when they are no finer or leave the workspace."""
        req = self.req
        if self.fine:
            return False
        self.fine = True
        segments = len(segments_from_start(req))  # as build_pieces counts them
        if dense_per_segment(req, segments, fine=True) <= dense_per_segment(req, segments):
            return False
        pieces, _ = build_pieces(req, fine=True)
        if pieces is None:
            return False
        log.debug("optimal: timed again on finer dense samples")
        self._time(pieces)
        return True

    @property
    def braking(self) -> bool:
        return self.start is not None and self.start.kind == "brake"

    def _join(self, allow_brake: bool) -> None:
        """The moving start onto the first piece (path_timing.moving_start.join)."""
        assert self.state is not None
        rate = self.req.rate_hz
        seg = moving_start.join(self.state, self.path.q, self.path.s, self.limits, rate,
                                allow_brake=allow_brake)
        if seg.kind == "brake":
            assert seg.brake is not None
            braked = _brake_then_go(self.req, seg.brake, self.limits, self.fine)
            if braked is None:  # no path from where the brake ends: join without it
                self._join(allow_brake=False)
                return
            self.pieces, self.start = braked, seg
            return
        for piece in self.pieces[1:]:
            piece.law = moving_start.timed(piece.q, piece.s, self.limits, rate)
        self.path.law = seg.law
        self.start = seg

    def sample(self) -> Sampled | Violation:
        """Every piece sampled in turn, the blend-out added, sample 0 the given state
        exactly (IK of FK(q0) rounds); or the first sample out of reach."""
        req = self.req
        arm = req.arm
        rate = req.rate_hz
        ref = None
        if self.state is not None:
            ref = self.state.q
        elif req.start_joints is not None:
            ref = np.asarray(req.start_joints)
        poses_l, joints_l, seg_l = [], [], []
        marks: dict[int, int] = {}
        starts = []
        offset = 0
        for piece in self.pieces:
            p, q, bad, s = _sample(piece, arm, rate, ref, req.branch)
            if q is None:
                assert bad is not None
                return reach.reach_violation(req, offset + bad, p[bad])
            if piece.path is None:
                seg = np.full(s.shape[0], -1, dtype=np.int64)
            else:
                m = len(piece.path.segments)
                if m == 1:  # no inner knot: every sample on the piece's one segment
                    seg = np.empty(s.shape[0], dtype=np.int64)  # np.full, unwrapped
                    seg.fill(piece.segment0)
                else:
                    inner = np.searchsorted(piece.path.knots[1:-1], s, side="right")
                    seg = piece.segment0 + np.minimum(inner, m - 1)
                marks[offset] = piece.segment0
                marks[offset + piece.count] = piece.segment0 + m
            lo = 0 if offset == 0 else 1  # a later piece's first sample is the last one's end
            starts.append(offset)
            poses_l.append(p[lo:])
            joints_l.append(q[lo:])
            seg_l.append(seg[lo:])
            offset += piece.count
            ref = q[-1]
            if offset + 1 > MAX_SAMPLES:
                raise TooLargeError(f"the plan needs more than {MAX_SAMPLES} samples at "
                                    f"{rate:g} Hz: lower rate_hz or shorten the motion",
                                    field="duration", value=req.duration)
        if len(poses_l) == 1:  # one piece: its own arrays
            poses, joints, segment_of = poses_l[0], joints_l[0], seg_l[0]
        else:
            poses, joints = np.concatenate(poses_l), np.concatenate(joints_l)
            segment_of = np.concatenate(seg_l)
        blend = None if self.start is None else self.start.blend
        if blend is not None:
            # the blend-out ends within the first piece (at rest at its end when it stops)
            tb = min(blend.duration, self.pieces[0].count / rate)
            n_b = min(joints.shape[0], math.ceil(tb * rate) + 1)
            blend = dataclasses.replace(blend, duration=tb)
            joints[:n_b] += blend.correction(np.arange(n_b) / rate)
            poses[:n_b] = path.pose_of(arm, joints[:n_b])
        if self.state is not None:
            joints[0] = self.state.q
        approach = self.pieces[0].count if self.pieces[0].path is None else 0
        return Sampled(poses, joints, segment_of, marks, np.asarray(starts, dtype=np.int64),
                       approach, self.history)

    def slow(self, violation: Violation, sampled: Sampled | None) -> bool:
        """Slow what failed: a moving first piece brakes (no jerk limit) or blends out over
        longer with lower limits; any other piece is stretched by its samples' factors."""
        assert sampled is not None
        starts = sampled.starts
        log.debug("optimal: %s %.4g > %.4g at sample %d of %d (piece starts %s)",
                  violation.quantity, violation.value, violation.limit, violation.sample,
                  sampled.joints.shape[0], starts.tolist())
        # the differences of a violation span the samples sample − order .. sample
        lo = violation.sample - validate.ORDER[violation.quantity]
        span = np.searchsorted(starts, [max(lo, 0), violation.sample], side="right") - 1
        which = int(max(0, min(span[0], len(self.pieces) - 1)))
        if self.moving and which == 0:
            return self._slow_start(violation)
        factors = stretch_factors(self.req, sampled.joints, sampled.history)
        edges = [*starts.tolist(), sampled.joints.shape[0] - 1]
        for p, piece in enumerate(self.pieces):
            if not (self.moving and p == 0):
                _slow(piece, float(factors[edges[p]:edges[p + 1] + 1].max()))
        return True

    def _slow_start(self, violation: Violation) -> bool:
        assert self.state is not None and self.start is not None
        if self.braking:
            return False
        if self.limits.j is None:
            # the blend-out failed between samples: brake and go instead
            brake = moving_start.brake_line(self.state, self.limits, self.req.rate_hz)
            braked = _brake_then_go(self.req, brake, self.limits, self.fine)
            if braked is not None:
                self.pieces = braked
                self.start = StartSegment("brake", brake=brake, scale=self.start.scale)
                return True
        # a moving start cannot be stretched: blend out over longer and time the path with
        # lower limits (the residual of the projection grows as ṡ₀ falls)
        log.debug("optimal: moving start fails %s %.4g > %.4g at sample %d (scale %.2f): "
                  "next try", violation.quantity, violation.value, violation.limit,
                  violation.sample, self.start.scale)
        nxt = moving_start.retry(self.start, self.state, self.path.q, self.path.s,
                                 self.limits, self.req.rate_hz)
        if nxt is None:
            return False
        self.path.law = nxt.law
        self.start = nxt
        return True

    def annotate(self, violation: Violation) -> Violation:
        return violation

