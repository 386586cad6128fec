"""A yawed arm in the planner: its path poses live in the arm's vertical plane.

A yawed arm (a base yaw turning a planar chain, :mod:`robodcn.kinematics._yawed`) is planned
on *plane poses* (yaw, r, z, pitch): the interpolation (ScLERP, KenLERP, SEP-LERP, DLB) is
the planar rigid motion of (r, z, pitch) in the arm's plane (r outward, z up, pitch CCW
from r: a right-handed planar frame, so (x, y, θ) := (r, z, pitch) for
:func:`robodcn.interpolate.interpolate`), and the yaw follows the same path parameter,
linear in s on the unwrapped yaw: yaw(s) = yaw₀ + s·(yaw₁ − yaw₀).

The yaw column carries the joint angle itself (unwrapped, never atan2 of a position), and
r is signed: a path whose r falls to the yaw axis or below (the "over the top" branch) is
out of reach, as is a pitch past ±90°, so the IK of a plane pose is the yaw, then the
planar chain on (r, z − h, pitch) (:func:`plane_joints`). The user's pose (x, y, z, pitch)
is :func:`robodcn.kinematics.from_plane` of it (:func:`to_user`).

Waypoint yaws are unwrapped with :func:`yaw_near`: the first nearest the start (the start
joints' yaw, else the middle of the yaw joint's limits), each next the 2π turn nearest the
one before among those within the yaw joint's limits (the long way round when the short way
leaves them; the yaw is linear in s, so a segment whose ends are inside stays inside).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import kinematics
from robodcn.config import Arm
from robodcn.interpolate import interpolate_unchecked

#: Slack (rad) on the yaw joint's limits when choosing a waypoint's turn: float rounding.
YAW_SLACK = 1e-9
_TWO_PI = 2.0 * math.pi


def yaw_near(yaw: float, target: float, limits: tuple[float, float]) -> float:
    """``yaw`` + 2πk nearest ``target`` among the turns within ``limits`` (min, max); the
    nearest turn of all when none is within them (validation then names the limit)."""
    base = yaw + _TWO_PI * round((target - yaw) / _TWO_PI)
    lo, hi = limits[0] - YAW_SLACK, limits[1] + YAW_SLACK
    inside = [c for c in (base, base - _TWO_PI, base + _TWO_PI) if lo <= c <= hi]
    if not inside:
        return base
    return min(inside, key=lambda c: abs(c - target))


def start_yaw(arm: Arm, reference: ArrayLike | None) -> float:
    """The yaw the first waypoint is unwrapped towards: the reference joints' yaw, else the
    middle of the yaw joint's limits."""
    if reference is not None:
        return float(np.asarray(reference, dtype=np.float64)[0])
    j = arm.joints[0]
    return 0.5 * (j.min_angle + j.max_angle)


def plane_waypoints(arm: Arm, waypoints: NDArray[np.float64], reference: ArrayLike | None
                    ) -> NDArray[np.float64]:
    """User waypoints (m, 4) (x, y, z, pitch) → plane poses (m, 4) (yaw, r, z, pitch), the
    yaw unwrapped (module notes) from ``reference`` ((k,) joints or None)."""
    plane = kinematics.to_plane(waypoints)
    limits = (arm.joints[0].min_angle, arm.joints[0].max_angle)
    yaw = start_yaw(arm, reference)
    for j in range(plane.shape[0]):
        yaw = yaw_near(float(plane[j, 0]), yaw, limits)
        plane[j, 0] = yaw
    return plane


def interpolate_plane(start: NDArray[np.float64], end: NDArray[np.float64],
                      s: NDArray[np.float64], method: str, beta: float, turn: str
                      ) -> NDArray[np.float64]:
    """Plane poses (n, 4) at path parameters s between plane poses ``start`` and ``end``:
    the planar rigid motion of (r, z, pitch) by ``method`` and the yaw linear in s."""
    out = np.empty((s.shape[0], 4))
    out[:, 1:] = interpolate_unchecked(start[1:], end[1:], s, method, beta, turn)
    out[:, 0] = start[0] + s * (end[0] - start[0])
    return out


def plane_pose_of(arm: Arm, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Plane poses (n, 4) (yaw, r, z, pitch) of joints q (n, k+1): the yaw joint itself and
    the chain's :func:`robodcn.kinematics.plane_fk`."""
    chain = arm.chain
    assert chain is not None
    q = np.atleast_2d(q)
    return np.column_stack([q[:, 0], kinematics.plane_fk(chain, q[:, 1:])])


def to_user(plane: NDArray[np.float64]) -> NDArray[np.float64]:
    """Plane poses (n, 4) → the user's poses (n, 4) (x, y, z, pitch) in the base frame."""
    return kinematics.from_plane(plane)


def off_axis(plane: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether each plane pose lies on the arm's side of the yaw axis (signed r ≥
    AXIS_TOLERANCE): the others are on the axis or over the top."""
    return plane[:, 1] >= kinematics.AXIS_TOLERANCE


def plane_joints(arm: Arm, plane: NDArray[np.float64], reference: ArrayLike | None,
                 elbow: str, limits: ArrayLike | None = None
                 ) -> tuple[NDArray[np.float64] | None, int | None]:
    """Branch-continuous IK of plane poses (n, 4): (joints (n, k+1), None), or (None, index
    of the first pose out of reach).

    The yaw is the pose's own yaw column; the chain joints follow
    :func:`robodcn.kinematics.try_ik_yawed_path` (nearest ``reference`` first, else on
    ``elbow``). A pose on or behind the yaw axis (signed r, :func:`off_axis`) is out of
    reach even where its mirror image over the top is not.
    """
    ok = off_axis(plane)
    behind = None if ok.all() else int(np.argmin(ok))
    upto = plane if behind is None else plane[:behind]
    if upto.shape[0] == 0:
        return None, behind
    chain = arm.chain
    assert chain is not None
    q, bad = kinematics.try_ik_yawed_path(chain, to_user(upto), reference=reference,
                                          elbow=elbow, limits=limits)
    if q is None:
        return None, bad
    if behind is not None:
        return None, behind
    q[:, 0] = plane[:, 0]
    return q, None
