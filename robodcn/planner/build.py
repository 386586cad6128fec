"""Planning a PlanRequest: pieces, their sample counts, assembly and validation."""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import kinematics, timing
from robodcn.contract import MAX_SAMPLES, intervals
from robodcn.errors import BranchSwitchWarning, TooLargeError, Violation
from robodcn.planner import search, validate
from robodcn.planner.path import (
    COARSE,
    Path,
    Piece,
    blended_path,
    joints_of,
    segments_of,
    shape_trapezoid,
    within_limits,
)
from robodcn.planner.request import PlanRequest, StartState
from robodcn.planner.trajectory import Trajectory


def _pieces(req: PlanRequest) -> tuple[list[Piece], NDArray | None]:
    arm = req.arm
    start = None if req.start_joints is None else np.asarray(req.start_joints)
    limits = [(j.min_angle, j.max_angle) for j in arm.joints]
    segments = segments_of(req)
    if req.blend:
        paths = [blended_path(req, segments, start)]
    else:
        paths = [Path([seg], np.array([0.0, 1.0]), None) for seg in segments]
    pieces = [Piece(path=p, profile=req.profile, elbow=req.branch) for p in paths]
    first = kinematics.ik_path(arm.links, np.array([segments[0][0]]), reference=start,
                               elbow=req.branch, limits=limits)[0]
    if start is not None:
        first = within_limits(first, limits)
    # Half the finest servo step: closer than that the servos cannot tell the difference.
    tolerance = min(math.pi / j.servo.ticks_per_turn for j in arm.joints)
    if start is not None and np.max(np.abs(first - start)) > tolerance:
        pieces.insert(0, Piece(q_from=start, q_to=first, elbow=req.branch))
    return pieces, start


def _counts(req: PlanRequest, pieces: list[Piece], start: NDArray | None) -> list[int]:
    """Sample periods per piece; the joint reference threads through the pieces."""
    arm = req.arm
    rate = req.rate_hz
    counts: list[int] = []
    estimates: list[float] = []
    ref = start
    for piece in pieces:
        shape_trapezoid(piece, arm, ref)
        last = None
        if req.duration == "auto" or piece.path is None:
            counts.append(search.search(piece, arm, ref, rate))
        else:
            need, last = search.estimate(piece, arm, ref)
            estimates.append(need)
            counts.append(0)
        if last is None:
            q = piece.sample(counts[-1] or COARSE, arm, ref)[1]
            last = ref if q is None else q[-1]
        ref = last
    if req.duration != "auto":
        shares = iter(search.split(intervals(req.duration, rate), estimates))
        counts = [c if c else next(shares) for c in counts]
    return counts


def warn_switches(samples: tuple[int, ...], rate: float) -> None:
    """Never silent: a branch switch is data on the trajectory and a warning of our own."""
    warnings.warn(BranchSwitchWarning(
        f"the elbow branch changes at sample {samples[0]} (t={samples[0] / rate:.3f}"
        f" s) passing a stretched-out or folded pose"
        + (f", and {len(samples) - 1} more time(s)" if len(samples) > 1 else ""),
        samples=samples), stacklevel=3)


def plan_request(req: PlanRequest) -> Trajectory:
    """Plan a validated :class:`PlanRequest` (package docstring); see :func:`plan`."""
    if req.profile == "optimal":
        from robodcn.planner import optimal

        return optimal.plan(req)
    validate.check_waypoints(req)
    pieces, start = _pieces(req)
    counts = _counts(req, pieces, start)
    traj, violation = _assemble(req, pieces, counts, start)
    if req.duration == "auto":
        # Auto pieces are each minimal; their joins can still fail (a linear profile's
        # velocity step between segments): slow every path piece down by the violation's
        # ratio (uniform time scaling: v ∝ 1/T, a ∝ 1/T², jerk ∝ 1/T³) and check again.
        order = {"velocity": 1, "acceleration": 2, "jerk": 3}
        for _ in range(search.MAX_SEARCH_STEPS):
            if violation is None or violation.quantity not in order:
                break
            ratio = max(1.0, violation.value / violation.limit)
            factor = ratio ** (1.0 / order[violation.quantity]) * (1.0 + 1e-6)
            scaled = [math.ceil(c * factor) if p.path is not None else c
                      for c, p in zip(counts, pieces, strict=True)]
            if scaled == counts:
                break
            counts = scaled
            traj, violation = _assemble(req, pieces, counts, start)
    if violation is not None:
        if violation.quantity in ("position", "ticks"):
            violation = dataclasses.replace(violation,
                                            other_branch_ok=_other_branch_ok(req, counts))
        validate.raise_for(violation)
    assert traj is not None
    if traj.branch_switches:
        # Never silent: the switch is data on the trajectory and a warning of our own.
        samples = traj.branch_switches
        warnings.warn(BranchSwitchWarning(
            f"the elbow branch changes at sample {samples[0]} (t={samples[0] / req.rate_hz:.3f}"
            f" s) passing a stretched-out or folded pose"
            + (f", and {len(samples) - 1} more time(s)" if len(samples) > 1 else ""),
            samples=samples), stacklevel=2)
    return traj


def _other_branch_ok(req: PlanRequest, counts: list[int]) -> bool:
    """Whether the same request on the other elbow branch passes position and tick limits
    (sampled as the failed plan was: timing plays no part in these checks)."""
    other = "down" if req.branch == "up" else "up"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            alt = dataclasses.replace(req, elbow=other)
    except Exception:  # pragma: no cover - the same fields validated once already
        return False
    pieces, start = _pieces(alt)
    if len(pieces) != len(counts):  # an approach on one branch and not the other
        counts = [COARSE] * len(pieces)
    _, violation = _assemble(alt, pieces, counts, start, dynamics=False)
    return violation is None


def _assemble(req: PlanRequest, pieces: list[Piece], counts: list[int],
              reference: NDArray | None, dynamics: bool = True
              ) -> tuple[Trajectory | None, Violation | None]:
    """Sample every piece and check the whole plan: (trajectory, None) or (None, violation).

    A sample out of reach is a "reach" violation (unless an earlier sample already fails
    another check: then that one is returned).
    """
    arm = req.arm
    rate = req.rate_hz
    total = 1 + sum(counts)
    if total > MAX_SAMPLES:
        raise TooLargeError(f"the plan needs {total} samples at {rate:g} Hz, more than "
                            f"{MAX_SAMPLES}: lower rate_hz or shorten the motion",
                            field="duration", value=req.duration)
    poses = np.empty((total, 3))
    joints = np.empty((total, arm.dof))
    segment_of = np.full(total, -1, dtype=np.int64)
    offset = 0
    ref = reference
    marks: dict[int, int] = {}  # sample index → waypoint index, where a waypoint is sampled
    segment = 0
    for piece, n in zip(pieces, counts, strict=True):
        if piece.path is not None:
            last = segment + len(piece.path.segments)
            marks[offset], marks[offset + n] = segment, last
            u = timing.profile(piece.profile, np.arange(n + 1) / n, piece.accel_fraction)
            inner = np.searchsorted(piece.path.knots[1:-1], u, side="right")
            segment_of[offset:offset + n + 1] = segment + np.minimum(
                inner, len(piece.path.segments) - 1)
            segment = last
        p, q, bad = piece.sample(n, arm, ref)
        if q is None:
            return None, _unreachable(req, piece, n, ref, offset, poses, joints, segment_of,
                                      p, bad)
        lo = 0 if offset == 0 else 1
        poses[offset + lo: offset + n + 1] = p[lo:]
        joints[offset + lo: offset + n + 1] = q[lo:]
        offset += n
        ref = q[-1]
    ticks, violation = validate.check(req, poses, joints, marks=marks, segment_of=segment_of,
                                      dynamics=dynamics)
    if violation is not None:
        return None, violation
    t = np.arange(total) / rate
    elbow, switches = validate.elbow_branches(joints)
    approach = counts[0] if pieces[0].path is None else 0
    return Trajectory(t, poses, joints, ticks, arm.joint_names, arm.servo_ids, rate,
                      req.method if isinstance(req.method, str) else list(req.method),
                      req, elbow, switches, approach), None


def _unreachable(req: PlanRequest, piece: Piece, n: int, ref: NDArray | None, offset: int,
                 poses: NDArray, joints: NDArray, segment_of: NDArray,
                 piece_poses: NDArray, local: int) -> Violation:
    """The violation at the piece's sample ``local`` (out of reach), or an earlier
    sample's other violation."""
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
        # With "auto" the search could not time a path that leaves the workspace, so speeds
        # before the gap say nothing: report the gap itself.
        _, earlier = validate.check(req, poses[:i], joints[:i], segment_of=segment_of[:i],
                                    dynamics=req.duration != "auto")
        if earlier is not None:
            return earlier
    arm = req.arm
    inner, outer = kinematics.workspace(arm.links)
    pose = [float(v) for v in piece_poses[local]]
    r = float(kinematics.wrist_radius(arm.links, [pose])[0])
    segment = (int(segment_of[i]), int(segment_of[i]) + 1) if segment_of[i] >= 0 else None
    return Violation(sample=i, t=i / req.rate_hz, pose=tuple(pose), quantity="reach",
                     value=r, limit=outer if r > outer else inner, unit="m", segment=segment,
                     field="waypoints")


def plan(arm, waypoints: ArrayLike, *, method: str | Sequence[str] = "sclerp",
         beta: float | Sequence[float] = 1.0, turn: str | Sequence[str] = "shortest",
         duration: float | str = "auto", profile: str = "optimal", rate_hz: float = 100,
         blend: bool = False, start_joints: ArrayLike | None = None,
         elbow: str | None = None, start_state: StartState | None = None) -> Trajectory:
    """Plan a validated trajectory through ``waypoints`` for ``arm``.

    Parameters
    ----------
    arm : Arm (robodcn.load_arm)
    waypoints : (m, 3), m ≥ 2 poses (x, y, θ), metres and radians; (m, 2) on a 2-joint arm
    method, turn : interpolation method / turn direction, or a list with one per segment
    beta : KenLERP bias (contract.BETA_RANGE), or a list with one per segment
    duration : total seconds (rounded up to whole sample periods) or "auto" (shortest
        feasible; package docstring)
    profile : "optimal" (default; time-optimal along the path within the velocity,
        acceleration and configured jerk limits: robodcn.planner.optimal) | "linear" |
        "quintic" | "trapezoid" (uniform laws)
    rate_hz : 1..1000 Hz
    blend : pass through via points with continuous velocity
    start_joints : (k,) present joints; a joint-space approach is prepended when they differ
        from the IK of waypoints[0]
    elbow : "up" | "down", or None for the arm's configured branch
    start_state : a moving :class:`StartState` (joints, velocities, accelerations) to plan
        from (a retarget); the path runs from the pose FK(joints) (PlanRequest docstring)

    Raises
    ------
    InputError
        Bad arguments (naming the field); TooLargeError past the caps.
    UnreachableError, JointLimitError, TickLimitError, VelocityLimitError,
    AccelerationLimitError, JerkLimitError
        The first failing sample, with its :class:`~robodcn.errors.Violation`.
    """
    if isinstance(method, list):
        method = tuple(method)
    if isinstance(turn, list):
        turn = tuple(turn)
    if isinstance(beta, list):
        beta = tuple(beta)
    req = PlanRequest(arm=arm, waypoints=waypoints, method=method, beta=beta, turn=turn,
                      duration=duration, profile=profile, rate_hz=rate_hz, blend=blend,
                      start_joints=start_joints, elbow=elbow, start_state=start_state)
    return plan_request(req)
