"""The uniform timing laws (linear, quintic, trapezoid): one law per piece, whole periods.

Pieces (:class:`~robodcn.planner.path.Piece`): each stop segment, or the blended path, and
a joint-space approach from ``start_joints``. Their sample periods come from the auto
search (:mod:`~robodcn.planner.search`) or a numeric duration split over them; the pipeline
(:mod:`robodcn.planner.build`) samples and validates them through :class:`UniformTiming`,
which slows every path piece by a violation's ratio when their joins fail (uniform time
scaling: v ∝ 1/T, a ∝ 1/T², jerk ∝ 1/T³).

Whether a blend keeps its blended curve or stops at the vias is decided before, from
geometry and limits alone (:mod:`~robodcn.planner.blend_choice`), so the profile never
changes the path. On a blended curve with ``duration="auto"`` the curve is also timed with
a law per segment, at rest at the vias, and that is taken when it takes fewer periods (a
uniform law over the whole blended curve runs as slowly as its hardest stretch needs).
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
from numpy.typing import NDArray

from robodcn import timing
from robodcn.contract import MAX_SAMPLES, intervals
from robodcn.contract.request import PlanRequest, StartState
from robodcn.errors import TooLargeError, Violation
from robodcn.planner import reach, search, validate
from robodcn.planner.path import (
    COARSE,
    Path,
    Piece,
    blended_path,
    first_joints,
    fit_trapezoid,
    joints_of,
    pose_width,
    segments_of,
    shape_trapezoid,
    within_limits,
)
from robodcn.planner.samples import Sampled


def _pieces(req: PlanRequest, pause_at_vias: bool = False
            ) -> tuple[list[Piece], NDArray | None]:
    arm = req.arm
    start = None if req.start_joints is None else np.asarray(req.start_joints)
    segments = segments_of(req)
    if req.blend and pause_at_vias and len(segments) > 1:
        # the blended curve, one piece per segment: the same geometry, at rest at the vias
        curve = blended_path(req, segments, start)
        assert curve.corrections is not None
        paths = [Path([seg], np.array([0.0, 1.0]), [correction])
                 for seg, correction in zip(segments, curve.corrections, strict=True)]
    elif req.blend:
        paths = [blended_path(req, segments, start)]
    else:
        paths = [Path([seg], np.array([0.0, 1.0]), None) for seg in segments]
    pieces = [Piece(path=p, profile=req.profile, elbow=req.branch) for p in paths]
    if start is None:
        return pieces, start
    limits = [(j.min_angle, j.max_angle) for j in arm.joints]
    first = within_limits(first_joints(arm, segments[0].start, start, req.branch), limits)
    # Half the finest servo step: closer than that the servos cannot tell the difference.
    tolerance = min(math.pi / j.servo.ticks_per_turn for j in arm.joints)
    if np.max(np.abs(first - start)) > tolerance:
        pieces.insert(0, Piece(q_from=start, q_to=first, elbow=req.branch))
    return pieces, start


def _counts(req: PlanRequest, pieces: list[Piece], start: NDArray | None,
            caches: list[tuple[NDArray | None, dict]] | None = None) -> list[int]:
    """Sample periods per piece; the joint reference threads through the pieces. With
    ``caches`` (a list), each piece's (reference, {N: piece.sample(N, …)}) of the search is
    appended to it."""
    arm = req.arm
    rate = req.rate_hz
    counts: list[int] = []
    estimates: list[float] = []
    ref = start
    for piece in pieces:
        shape_trapezoid(piece, arm, ref)
        last = None
        cache: dict[int, tuple] = {}
        if caches is not None:
            caches.append((ref, cache))
        if req.duration == "auto" or piece.path is None:
            counts.append(search.search(piece, arm, ref, rate, cache))
        else:
            need, last = search.estimate(piece, arm, ref)
            estimates.append(need)
            counts.append(0)
        if last is None:
            n = counts[-1] or COARSE
            sampled = cache[n] if n in cache else piece.sample(n, arm, ref)
            cache[n] = sampled
            q = sampled[1]
            last = ref if q is None else q[-1]
        ref = last
    if req.duration != "auto":
        shares = iter(search.split(intervals(req.duration, rate), estimates))
        counts = [c if c else next(shares) for c in counts]
        for i, (piece, n) in enumerate(zip(pieces, counts, strict=True)):
            if fit_trapezoid(piece, arm, n / rate) and caches is not None:
                caches[i][1].clear()            # samples taken with the minimum-time ρ
    return counts


#: the tool quantities of a Violation (robodcn.planner.validate)
_TOOL = ("tool_speed", "tool_angular_speed", "tool_acceleration")


class UniformTiming:
    """A uniform law per piece (module doc), for the pipeline's loop."""

    rounds = 1 + search.MAX_SEARCH_STEPS
    #: a uniform law starts from rest (a start state at rest is not carried on)
    start_state: StartState | None = None

    def __init__(self, req: PlanRequest, counts: list[int] | None = None, *,
                 pause_at_vias: bool = False) -> None:
        self.req = req
        self.pieces, self.reference = _pieces(req, pause_at_vias)
        if counts is not None and len(counts) != len(self.pieces):
            counts = [COARSE] * len(self.pieces)  # an approach on one branch, not the other
        #: per piece the search's samples by count, and the reference they were taken from
        self._cache: list[tuple[NDArray | None, dict]] = []
        self.counts = _counts(req, self.pieces, self.reference, self._cache) \
            if counts is None else counts
        if counts is None and not pause_at_vias and req.blend and req.segments > 1 \
                and req.duration == "auto":
            self._pause_if_faster()

    def _pause_if_faster(self) -> None:
        """The blended curve with a law per segment, at rest at the vias, when that takes
        fewer periods than one law over the whole curve (module doc): the geometry stays
        the blend's; only the time law differs."""
        paused = UniformTiming(self.req, pause_at_vias=True)
        if sum(paused.counts) < sum(self.counts):
            self.pieces, self.reference = paused.pieces, paused.reference
            self.counts, self._cache = paused.counts, paused._cache
    def sample(self) -> Sampled | Violation:
        """Every piece sampled at its count; or the first sample out of reach (or an earlier
        sample's other violation)."""
        req, arm, counts = self.req, self.req.arm, self.counts
        rate = req.rate_hz
        total = 1 + sum(counts)
        if total > MAX_SAMPLES:
            raise TooLargeError(f"the plan needs {total} samples at {rate:g} Hz, more than "
                                f"{MAX_SAMPLES}: lower rate_hz or shorten the motion",
                                field="duration", value=req.duration)
        poses = np.empty((total, pose_width(arm)))
        joints = np.empty((total, arm.dof))
        segment_of = np.full(total, -1, dtype=np.int64)
        offset = 0
        ref = self.reference
        marks: dict[int, int] = {}  # sample index → waypoint index, where one is sampled
        starts = []
        segment = 0
        for piece, n in zip(self.pieces, counts, strict=True):
            if piece.path is not None:
                last = segment + len(piece.path.segments)
                marks[offset], marks[offset + n] = segment, last
                if last == segment + 1:  # one segment, no inner knot: every sample on it
                    segment_of[offset:offset + n + 1] = segment
                else:
                    u = timing.profile_unchecked(piece.profile, np.arange(n + 1) / n,
                                                 piece.accel_fraction)
                    inner = np.searchsorted(piece.path.knots[1:-1], u, side="right")
                    segment_of[offset:offset + n + 1] = segment + np.minimum(
                        inner, len(piece.path.segments) - 1)
                segment = last
            p, q, bad = self._sampled(len(starts), piece, n, ref)
            if q is None:
                assert bad is not None
                return self._unreachable(piece, ref, offset, poses, joints, segment_of, p, bad)
            if len(self.pieces) == 1:  # one piece: its own arrays are the plan's, not copies
                poses, joints = p, q
            else:
                lo = 0 if offset == 0 else 1
                poses[offset + lo: offset + n + 1] = p[lo:]
                joints[offset + lo: offset + n + 1] = q[lo:]
            starts.append(offset)
            offset += n
            ref = q[-1]
        approach = counts[0] if self.pieces[0].path is None else 0
        return Sampled(poses, joints, segment_of, marks, np.asarray(starts, dtype=np.int64),
                       approach)

    def _sampled(self, index: int, piece: Piece, n: int, ref: NDArray | None) -> tuple:
        """piece.sample(n, arm, ref), taken from the search's evaluations when it made this
        one from the same reference (the same computation)."""
        if index < len(self._cache):
            cached_ref, cache = self._cache[index]
            same = (ref is None and cached_ref is None) or (
                ref is not None and cached_ref is not None and np.array_equal(ref, cached_ref))
            if same and n in cache:
                return cache[n]
        return piece.sample(n, self.req.arm, ref)

    def _unreachable(self, piece: Piece, ref: NDArray | None, offset: int, poses: NDArray,
                     joints: NDArray, segment_of: NDArray, piece_poses: NDArray,
                     local: int) -> Violation:
        """The violation at the piece's sample ``local`` (out of reach), or an earlier
        sample's other violation."""
        req = self.req
        # The piece's sample 0 is the plan's sample ``offset`` (shared with the piece before).
        i = offset + local
        if local > 0:
            p = piece_poses[:local]
            q, _ = joints_of(req.arm, p, ref, piece.elbow)
            if req.position_only:
                p = p.copy()
                p[:, 2] = q[:, 0] + q[:, 1]
            poses[offset:i] = p
            joints[offset:i] = q
        if i > 0:
            # With "auto" the search could not time a path that leaves the workspace, so
            # speeds before the gap say nothing: report the gap itself.
            _, earlier = validate.check(req, poses[:i], joints[:i], segment_of=segment_of[:i],
                                        dynamics=req.duration != "auto")
            if earlier is not None:
                return earlier
        segment = (int(segment_of[i]), int(segment_of[i]) + 1) if segment_of[i] >= 0 else None
        return reach.reach_violation(req, i, piece_poses[local], segment)

    def slow(self, violation: Violation, sampled: Sampled | None) -> bool:
        """Auto pieces are each minimal; their joins can still fail (a linear profile's
        velocity step between segments): every path piece slowed by the violation's ratio
        (uniform time scaling); a tool limit's, each piece by its own samples' largest.
        False when that changes nothing."""
        ratio = max(1.0, violation.value / violation.limit)
        factor = ratio ** (1.0 / validate.ORDER[violation.quantity]) * (1.0 + 1e-6)
        factors = [factor] * len(self.pieces)
        tool = validate.tool_limits(self.req) if violation.quantity in _TOOL else None
        if tool is not None and sampled is not None:
            # a tool limit binds where the tool is fastest, not where it first fails: each
            # piece by its own samples' largest ratio at once (uniform scaling: speed 1/T,
            # acceleration 1/T²), a piece within the limits left as it is
            edges = [*sampled.starts.tolist(), sampled.joints.shape[0] - 1]
            need = np.ones(sampled.joints.shape[0])
            for quantity, r in validate.tool_ratios(tool, sampled.joints,
                                                    self.req.rate_hz).items():
                need = np.maximum(need, r ** (1.0 / validate.ORDER[quantity]))
            worst = [float(need[edges[k]:edges[k + 1] + 1].max())
                     for k in range(len(self.pieces))]
            factors = [w * (1.0 + 1e-6) if w > 1.0 else 1.0 for w in worst]
        scaled = [math.ceil(c * f) if p.path is not None and f > 1.0 else c
                  for c, p, f in zip(self.counts, self.pieces, factors, strict=True)]
        if scaled == self.counts:
            return False
        self.counts = scaled
        return True

    def refine(self) -> bool:
        """The uniform laws sample the path itself: no finer geometry to time on."""
        return False

    def annotate(self, violation: Violation) -> Violation:
        """A position, tick or keep-out violation says whether the other elbow branch would
        pass."""
        if violation.quantity not in ("position", "ticks", "keepout"):
            return violation
        return dataclasses.replace(violation, other_branch_ok=self._other_branch_ok())

    def _other_branch_ok(self) -> bool:
        """Whether the same request on the other elbow branch passes position and tick limits
        and keeps out of the keep-out zones (sampled as the failed plan was: timing plays
        no part in these checks)."""
        req = self.req
        other = "down" if req.branch == "up" else "up"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            alt = dataclasses.replace(req, elbow=other)
        sampled = UniformTiming(alt, self.counts).sample()
        if isinstance(sampled, Violation):
            return False
        _, violation = validate.check(alt, sampled.poses, sampled.joints, marks=sampled.marks,
                                      segment_of=sampled.segment_of, dynamics=False)
        return violation is None
