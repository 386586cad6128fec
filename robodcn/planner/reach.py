"""Reach, branches and reported poses by the arm's kind: planar arms as
:mod:`~robodcn.planner.validate` says, yawed arms (:mod:`~robodcn.planner.yawed`) here.

A yawed arm's path poses are plane poses (yaw, r, z, pitch) with a signed r; a pose is out
of reach on or behind the yaw axis (r < AXIS_TOLERANCE: over the top), with its tool axis
past ±90° (3-link chains) or with its wrist point outside the chain's annulus about the
shoulder (:func:`robodcn.kinematics.why_unreachable`). Violations carry path poses inside
the planner; :func:`user_violation` turns them into the user's (x, y, z, pitch) once, where
the pipeline raises them.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import NoReturn

import numpy as np
from numpy.typing import NDArray

from robodcn import kinematics
from robodcn.contract.request import PlanRequest
from robodcn.errors import UnreachableError, Violation
from robodcn.planner import path, validate, yawed


def fmt_pose(pose: Sequence[float]) -> str:
    """A user's pose for a message: x, y (and z) in metres, θ (pitch) in degrees."""
    if len(pose) == 4:
        return (f"x={pose[0]:.4f} m, y={pose[1]:.4f} m, z={pose[2]:.4f} m, "
                f"pitch={math.degrees(pose[3]):.1f}°")
    return validate.fmt_pose(pose)


def check_waypoints(req: PlanRequest) -> None:
    """Every waypoint reachable, else UnreachableError naming it (``waypoints[j]``) and why
    (behind the base, on the yaw axis, out of the annulus), and its tool point outside the
    keep-out zones (KeepOutError: :func:`robodcn.planner.validate.check_waypoint_zones`);
    a lone waypoint's path starts at the start's pose, which must be reachable too
    (:func:`check_start`)."""
    arm = req.arm
    if not arm.yawed:
        validate.check_waypoints(req)
        validate.check_waypoint_zones(req, fmt_pose)
        check_start(req)
        return
    chain = arm.chain
    assert chain is not None
    wp = req.waypoints_array
    ok = kinematics.reachable_yawed(chain, wp)
    if ok.all():
        validate.check_waypoint_zones(req, fmt_pose)
        check_start(req)
        return
    j = int(np.argmin(ok))
    why = kinematics.why_unreachable(chain, wp[j]) or "cannot be reached"
    raise UnreachableError(f"waypoints[{j}] ({fmt_pose(wp[j])}) {why}",
                           field=f"waypoints[{j}]", value=wp[j].tolist(),
                           pose=wp[j].tolist(), waypoint=j)


def check_start(req: PlanRequest) -> None:
    """A lone waypoint's path starts at the pose of the start (``start_joints`` or the start
    state's joints): UnreachableError naming that field when no IK solution there lies
    within the joint limits (the start joints put the tool behind the yaw axis, over the
    top, or below what the chain's IK covers): the path could not begin."""
    if req.waypoints_array.shape[0] != 1:
        return
    start = path.start_of(req)
    assert start is not None, "the contract needs a start for a lone waypoint"
    first = path.plan_waypoints(req)[:1]
    q, _ = path.joints_of(req.arm, first, start, req.branch)
    if q is not None:
        return
    field = "start_joints" if req.start_joints is not None else "start_state"
    user = path.user_pose(req.arm, start[None, :])[0]
    why = ""
    if req.arm.yawed:
        assert req.arm.chain is not None
        why = kinematics.why_unreachable(req.arm.chain, user) or ""
    raise UnreachableError(
        f"{field} put the tool at {fmt_pose(user)}, where a lone waypoint's path would "
        f"start: {why or 'no IK solution there lies within the joint limits'}; give a "
        f"first waypoint the arm can reach", field=field,
        value=[float(v) for v in start], pose=user.tolist())


def _plane_reach(req: PlanRequest, pose: NDArray[np.float64]) -> tuple[float, float, str]:
    """(value, limit, unit) of why a plane pose is out of reach (module notes)."""
    chain = req.arm.chain
    assert chain is not None
    if pose[1] < kinematics.AXIS_TOLERANCE:
        return float(pose[1]), kinematics.AXIS_TOLERANCE, "m"
    if len(chain.links) == 3 and abs(float(kinematics.wrap(pose[3]))) > kinematics.MAX_PITCH:
        return abs(float(kinematics.wrap(pose[3]))), 0.5 * math.pi, "rad"
    inner, outer = chain.workspace()
    w = float(kinematics.wrist_radius_yawed(chain, yawed.to_user(pose[None, :]))[0])
    return w, outer if w > outer else inner, "m"


def reach_violation(req: PlanRequest, sample: int, pose: Sequence[float],
                    segment: tuple[int, int] | None = None) -> Violation:
    """The "reach" Violation of a sample whose path pose the arm cannot reach (planar:
    :func:`robodcn.planner.validate.reach_violation`). A yawed arm's value/limit/unit: the
    signed r against AXIS_TOLERANCE (m) on or behind the yaw axis, |pitch| against 90°
    (rad) over the top, else the wrist's distance from the shoulder against the annulus."""
    if not req.arm.yawed:
        return validate.reach_violation(req, sample, pose, segment)
    p = np.asarray(pose, dtype=np.float64)
    value, limit, unit = _plane_reach(req, p)
    return Violation(sample=sample, t=sample / req.rate_hz, pose=tuple(float(x) for x in p),
                     quantity="reach", value=value, limit=limit, unit=unit, segment=segment,
                     field="waypoints")


def why(req: PlanRequest, pose: NDArray[np.float64]) -> str:
    """Why a yawed arm's plane pose is out of reach, as a phrase."""
    if pose[1] < kinematics.AXIS_TOLERANCE:
        return (f"passes the yaw axis (r = {pose[1]:.4f} m in the arm's plane): the arm does "
                "not reach over the top; turn the yaw instead")
    chain = req.arm.chain
    assert chain is not None
    return kinematics.why_unreachable(chain, yawed.to_user(pose[None, :])[0]) or \
        "cannot be reached"


def raise_unreachable_pose(req: PlanRequest, pose: Sequence[float]) -> NoReturn:
    """UnreachableError for a path pose no sample names (the geometry leaves the workspace
    before any timing); planar: :func:`robodcn.planner.validate.raise_unreachable_pose`."""
    if not req.arm.yawed:
        validate.raise_unreachable_pose(req, pose)
    p = np.asarray(pose, dtype=np.float64)
    user = yawed.to_user(p[None, :])[0].tolist()
    raise UnreachableError(f"the path leaves the workspace at {fmt_pose(user)}: it "
                           f"{why(req, p)}", field="waypoints", value=user, pose=user)


def _lone_waypoint(req: PlanRequest, violation: Violation) -> Violation:
    """A one-waypoint request's path runs from the start (path waypoint 0) to waypoints[0]
    (path waypoint 1): the violation's waypoint named in the request's own indices."""
    w = violation.waypoint
    if w is None:
        return violation
    start = "start_joints" if req.start_joints is not None else "start_state"
    field = violation.field
    if field.startswith("waypoints["):
        field = "waypoints[0]" if w == 1 else start
    return dataclasses.replace(violation, waypoint=0 if w == 1 else None, field=field)


def user_violation(req: PlanRequest, violation: Violation) -> Violation:
    """``violation`` in the request's terms: the user's pose (a yawed arm's (x, y, z,
    pitch)) and, for a one-waypoint request, the waypoint as the request numbers it."""
    if len(req.waypoints) == 1:
        violation = _lone_waypoint(req, violation)
    if not req.arm.yawed:
        return violation
    pose = yawed.to_user(np.asarray(violation.pose, dtype=np.float64)[None, :])[0]
    return dataclasses.replace(violation, pose=tuple(float(x) for x in pose))


def elbow_branches(req: PlanRequest, joints: NDArray[np.float64]
                   ) -> tuple[str | None, tuple[int, ...]]:
    """The elbow branch at the first sample and where it changes
    (:func:`robodcn.planner.validate.elbow_branches`); a yawed arm's on its chain's planar
    angles q̃ = d − q ("up": q̃₂ ≤ 0, :mod:`robodcn.kinematics._yawed`)."""
    if not req.arm.yawed:
        return validate.elbow_branches(joints)
    chain = req.arm.chain
    assert chain is not None
    return validate.elbow_branches(chain.offsets - joints[:, 1:])
