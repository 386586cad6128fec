"""The planner's one pipeline: pieces → time (uniform or optimal law) → sample → validate.

:func:`plan_request` picks the timing law (:class:`~robodcn.planner.uniform.UniformTiming`
or :class:`~robodcn.planner.optimal.OptimalTiming`), then one loop samples it, validates the
samples (:func:`robodcn.planner.validate.check`) and, while an ``auto`` plan fails a dynamic
limit, asks the law to slow what failed; one assembly makes the :class:`Trajectory` and one
place raises what failed (:func:`robodcn.planner.validate.raise_for`).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence
from typing import NoReturn

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.config import Arm
from robodcn.contract import DEFAULTS
from robodcn.contract.request import PlanRequest, StartState
from robodcn.errors import (
    AccelerationLimitError,
    BranchSwitchWarning,
    JerkLimitError,
    ToolLimitError,
    TorqueLimitError,
    VelocityLimitError,
    Violation,
)
from robodcn.planner import arm_arrays, holding, reach, validate
from robodcn.planner.blend_choice import stops_beat_blend
from robodcn.planner.optimal import OptimalTiming
from robodcn.planner.path import to_user
from robodcn.planner.pieces import build_pieces
from robodcn.planner.samples import Sampled, Timing
from robodcn.planner.trajectory import Trajectory, planned
from robodcn.planner.uniform import UniformTiming

#: what a law's samples past a dynamic limit raise (validate.raise_for)
_LIMIT_ERRORS = (VelocityLimitError, AccelerationLimitError, JerkLimitError, TorqueLimitError,
                 ToolLimitError)


def warn_switches(samples: tuple[int, ...], rate: float) -> None:
    """Never silent: a branch switch is data on the trajectory and a warning of our own."""
    warnings.warn(BranchSwitchWarning(
        f"the elbow branch changes at sample {samples[0]} (t={samples[0] / rate:.3f}"
        f" s) passing a stretched-out or folded pose"
        + (f", and {len(samples) - 1} more time(s)" if len(samples) > 1 else ""),
        samples=samples), stacklevel=4)


def assemble(req: PlanRequest, sampled: Sampled, ticks: NDArray[np.int64],
             start_state: StartState | None) -> Trajectory:
    """The Trajectory of validated samples (t every 1/rate_hz from 0, the user's poses, the
    elbow branch and its switches, the approach's periods)."""
    rate = req.rate_hz
    arm = req.arm
    t = np.arange(sampled.joints.shape[0]) / rate
    elbow, switches = reach.elbow_branches(req, sampled.joints)
    if switches:
        warn_switches(switches, rate)
    # validated samples: the Trajectory's own checks need not run again (trajectory.planned)
    return planned(t, to_user(arm, sampled.poses), sampled.joints, ticks, request=req,
                   method=req.method if isinstance(req.method, str) else list(req.method),
                   elbow=elbow, branch_switches=switches, approach_samples=sampled.approach,
                   start_state=start_state)


def run(req: PlanRequest, law: Timing) -> Trajectory:
    """Sample → validate → (auto: slow what failed, sample again) → the Trajectory, or the
    first failing sample raised."""
    violation: Violation | None = None
    for _ in range(law.rounds):
        sampled = law.sample()
        if isinstance(sampled, Violation):
            violation, sampled = sampled, None
        else:
            ticks, violation = validate.check(req, sampled.poses, sampled.joints,
                                              marks=sampled.marks,
                                              segment_of=sampled.segment_of,
                                              history=sampled.history)
            if violation is None:
                return assemble(req, sampled, ticks, law.start_state)
        if violation.quantity not in validate.ORDER:
            break
        if law.refine():  # a finer geometry first: it may pass without slowing
            continue
        if req.duration != "auto":
            break  # a fixed duration is the caller's: never lengthened to pass
        if not law.slow(violation, sampled):
            break
    assert violation is not None
    validate.raise_for(reach.user_violation(req, law.annotate(violation)))


def _unreachable_path(req: PlanRequest, pose: NDArray) -> NoReturn:
    """The optimal law's geometry leaves the workspace: the uniform law names the first
    sample out of reach (timed by its estimate); failing that (a prepended segment from a
    moving start), the pose itself."""
    if req.start_state is None:
        try:
            run(req, UniformTiming(dataclasses.replace(req, profile="quintic")))
        except (VelocityLimitError, AccelerationLimitError, JerkLimitError):
            if req.duration != "auto":  # a fixed duration's earlier failure is real
                raise
            # its retiming never sampled the gap (the joints race near it, a jerk limit
            # most of all): the pose out of reach is what is wrong, said below
    reach.raise_unreachable_pose(req, pose)


def _refuse_unholdable(req: PlanRequest, pieces: list | None) -> None:
    """TorqueLimitError at once where gravity alone overloads a joint along ``pieces``
    (planner.holding: no law could carry it, and the optimal one crawls before failing)."""
    if pieces is None:
        return
    violation = holding.overload(req, pieces)
    if violation is not None:
        validate.raise_for(reach.user_violation(req, violation))


def plan_request(req: PlanRequest) -> Trajectory:
    """Plan a validated :class:`PlanRequest` (package docstring); see :func:`plan`."""
    reach.check_waypoints(req)
    if validate.torque_limits(req) is not None:
        # every waypoint and the path between them (stopping at the vias) held at rest,
        # before any law is timed (the blend choice below times two)
        stops = dataclasses.replace(req, blend=False)
        _refuse_unholdable(stops, build_pieces(stops)[0])
    # the geometry: a blend stops at its vias where that is faster under any time law,
    # decided whatever this request's profile, duration and rate (planner.blend_choice)
    geometry = dataclasses.replace(req, blend=False) if stops_beat_blend(req) else req
    if req.profile != "optimal":
        return run(req, UniformTiming(geometry))
    # an auto law from rest at a high rate nearly always needs the finer geometry
    # (pieces.DENSE_RATE_HZ): timed on it at once; a fixed duration's slower law seldom does,
    # and a moving start's (an online operation's, whose planning time counts) may not:
    # those are refined on a failure
    fine = req.duration == "auto" and req.start_state is None
    pieces, bad_pose = build_pieces(geometry, fine=fine)
    if pieces is None:
        assert bad_pose is not None
        _unreachable_path(req, bad_pose)
    if geometry.blend:  # the blended curve departs from the segments checked above
        _refuse_unholdable(geometry, pieces)
    if req.start_state is not None or not arm_arrays.arrays_of(req.arm).jerk_limited:
        return run(req, OptimalTiming(geometry, pieces, fine=fine))
    return _no_slower_than_quintic(req, geometry, pieces, fine)


def _no_slower_than_quintic(req: PlanRequest, geometry: PlanRequest, pieces, fine: bool
                            ) -> Trajectory:
    """The optimal law from rest under a jerk limit, or the uniform quintic on the same
    geometry where that is faster (``auto``) or meets a ``duration`` the optimal law cannot.

    Without a jerk limit TOPP-RA's law is the optimum; with one, the jerk pass filters it
    (``path_timing.optimal``: about one window's overhead a piece, and validation slows what
    its model of the samples misjudged), which under a tight limit lost to the quintic by up
    to 1.5× (issue 17 §1: the default profile is never slower than quintic). The request
    stays the caller's: only the time law along the path differs (``geometry`` is ``req``
    with the blend decided, planner.blend_choice)."""
    quintic = UniformTiming(dataclasses.replace(geometry, profile="quintic"))
    try:
        best = run(req, OptimalTiming(geometry, pieces, fine=fine))
    except _LIMIT_ERRORS as refused:
        if req.duration == "auto":
            raise
        try:  # a fixed duration the optimal law cannot keep: the quintic may
            return run(req, quintic)
        except _LIMIT_ERRORS:
            raise refused from None
    if req.duration != "auto":
        return best
    try:
        uniform = run(req, quintic)
    except _LIMIT_ERRORS:
        return best
    return uniform if uniform.t.shape[0] < best.t.shape[0] else best


def plan(arm: Arm, waypoints: ArrayLike, *, method: str | Sequence[str] = DEFAULTS.method,
         beta: float | Sequence[float] = DEFAULTS.beta,
         turn: str | Sequence[str] = DEFAULTS.turn, duration: float | str = DEFAULTS.duration,
         profile: str = DEFAULTS.profile, rate_hz: float | None = DEFAULTS.rate_hz,
         blend: bool = DEFAULTS.blend, start_joints: ArrayLike | None = DEFAULTS.start_joints,
         elbow: str | None = DEFAULTS.elbow,
         start_state: StartState | None = DEFAULTS.start_state,
         payload_kg: float | None = DEFAULTS.payload_kg,
         tool_speed: float | None = DEFAULTS.tool_speed,
         tool_angular_speed: float | None = DEFAULTS.tool_angular_speed,
         tool_acceleration: float | None = DEFAULTS.tool_acceleration) -> Trajectory:
    """Plan a validated trajectory through ``waypoints`` for ``arm``.

    Parameters
    ----------
    arm : Arm (robodcn.load_arm)
    waypoints : (m, 3), m ≥ 2 poses (x, y, θ), metres and radians; (m, 2) on a 2-joint arm;
        (m, 4) (x, y, z, pitch) in the base frame on an arm with a base yaw
    method, turn : interpolation method / turn direction, or a list with one per segment
    beta : KenLERP bias (contract.BETA_RANGE), or a list with one per segment
    duration : total seconds (rounded up to whole sample periods) or "auto" (shortest
        feasible; package docstring)
    profile : "optimal" (default; time-optimal along the path within the velocity,
        acceleration and configured jerk limits: robodcn.planner.optimal) | "linear" |
        "quintic" | "trapezoid" (uniform laws)
    rate_hz : 1..1000 Hz; None (the default): the arm's ``[bus] rate_hz``
    blend : pass through via points with continuous velocity
    start_joints : (k,) present joints; a joint-space approach is prepended when they differ
        from the IK of waypoints[0]
    elbow : "up" | "down", or None for the arm's configured branch
    start_state : a moving :class:`StartState` (joints, velocities, accelerations) to plan
        from (a retarget); the path runs from the pose FK(joints) (PlanRequest docstring)
    payload_kg : mass (kg) at the tool point for the torque limits; None: the arm's
    tool_speed, tool_angular_speed, tool_acceleration : the tool point's largest speed
        (m/s), orientation rate (rad/s) and acceleration along its path (m/s²), kept with
        every joint limit (robodcn.path_timing.tool); None: the arm's ``[tool]`` defaults

    Raises
    ------
    InputError
        Bad arguments (naming the field); TooLargeError past the caps.
    UnreachableError, JointLimitError, TickLimitError, VelocityLimitError,
    AccelerationLimitError, JerkLimitError, ToolLimitError
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
                      start_joints=start_joints, elbow=elbow, start_state=start_state,
                      payload_kg=payload_kg, tool_speed=tool_speed,
                      tool_angular_speed=tool_angular_speed,
                      tool_acceleration=tool_acceleration)
    return plan_request(req)
