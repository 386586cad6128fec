"""Poses the arm cannot hold: the static holding torque checked before any timing.

At rest a joint needs its gravity torque g(q) (links and the request's payload at the tool
point; :meth:`robodcn.path_timing.torque.TorqueLimits.gravity`, i.e. inverse dynamics at
q̇ = q̈ = 0). Where |g_j(q)| > τ_max,j·(1 + SLACK) no timing helps: every law passes there
at some speed, and the torque it needs is g plus a dynamic part that vanishes only as the
law crawls (the optimal law near such a pose took 1567 s and hundreds of MB before its
validation refused it, issue 27 §2). So the planner refuses at once, naming

* the first **waypoint** the arm cannot hold (its joints are the dense path's at that
  waypoint, on the branch the path takes), else
* the first **dense path sample** between waypoints (the samples the law would be timed on;
  a joint-space approach is sampled at :data:`APPROACH_SAMPLES`),

as a :class:`~robodcn.errors.Violation` (quantity "torque", field ``payload_kg``, no sample:
nothing is timed) that the pipeline raises as TorqueLimitError. The comparison is
:meth:`~robodcn.path_timing.torque.TorqueLimits.overloaded`, the one the timing's torque rows
and the validation use, so a path the precheck passes is one the timing keeps its torque
rows on, and a path it refuses is one no law could carry.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from robodcn.contract.request import PlanRequest
from robodcn.errors import Violation
from robodcn.path_timing.torque import TorqueLimits
from robodcn.planner import path, validate
from robodcn.planner.pieces import DensePiece

__all__ = ["APPROACH_SAMPLES", "overload"]

#: Samples of a joint-space approach (a straight joint line) the holding check reads: g is
#: smooth in q, and the line's own three dense samples would miss a peak between its ends.
APPROACH_SAMPLES = 65


def _waypoint_joints(req: PlanRequest, pieces: list[DensePiece]
                     ) -> list[tuple[int, NDArray, NDArray]]:
    """(path waypoint index, joints, path pose) of every path waypoint a piece ends at: the
    dense path's own joints there (a piece's first and last rows are its ends), matched to
    :func:`robodcn.planner.path.plan_waypoints` by :func:`robodcn.planner.path.same_pose`."""
    arm = req.arm
    wp = path.plan_waypoints(req)
    wp_user = path.to_user(arm, wp)
    found: dict[int, tuple[NDArray, NDArray]] = {}
    for piece in pieces:
        if piece.path is None or piece.q is None:
            continue
        ends = piece.path(np.array([0.0, 1.0]))
        for row, pose, user in zip((0, -1), ends, path.to_user(arm, ends), strict=True):
            for i in range(wp.shape[0]):
                if i not in found and path.same_pose(req, user, wp_user[i]):
                    found[i] = (piece.q[row], pose)
    return [(i, *found[i]) for i in sorted(found)]


def _violation(req: PlanRequest, torque: TorqueLimits, q: NDArray, pose: NDArray,
               g: NDArray, waypoint: int | None, segment: tuple[int, int] | None
               ) -> Violation:
    """The Violation of joints q (k,) whose holding torques g (k,) overload a joint: the
    joint with the largest share of its limit."""
    share = np.where(torque.overloaded(g), np.abs(g) / torque.tau, -np.inf)
    j = int(np.argmax(share))
    return Violation(sample=None, t=None, pose=tuple(float(x) for x in pose),
                     quantity="torque", value=float(abs(g[j])), limit=float(torque.tau[j]),
                     unit="N*m", joint=req.arm.joints[j].name, joint_index=j,
                     segment=segment, waypoint=waypoint, field="payload_kg")


def _dense(piece: DensePiece) -> NDArray:
    """The joints the check reads along a piece: its dense samples, or an approach's line
    at :data:`APPROACH_SAMPLES`."""
    assert piece.q is not None
    if piece.path is None and piece.q_from is not None:
        return piece.joints_line(np.linspace(0.0, 1.0, APPROACH_SAMPLES))
    return piece.q


def overload(req: PlanRequest, pieces: list[DensePiece]) -> Violation | None:
    """The first pose of ``pieces`` (:func:`robodcn.planner.pieces.build_pieces` of ``req``)
    the arm cannot hold with the request's payload (module doc): a waypoint first, then a
    dense sample in path order; None when every pose holds or no joint has a torque
    limit. The violation's waypoint is a path waypoint and its pose a path pose
    (:func:`robodcn.planner.reach.user_violation` puts both in the request's terms)."""
    torque = validate.torque_limits(req)
    if torque is None:
        return None
    at_waypoints = _waypoint_joints(req, pieces)
    if at_waypoints:
        q = np.vstack([row[1] for row in at_waypoints])
        g = torque.gravity(q)
        bad = torque.overloaded(g).any(axis=1)
        if bad.any():
            w = int(np.argmax(bad))
            index, _, pose = at_waypoints[w]
            return _violation(req, torque, q[w], pose, g[w], index, None)
    for piece in pieces:
        q = _dense(piece)
        g = torque.gravity(q)
        bad = torque.overloaded(g).any(axis=1)
        if not bad.any():
            continue
        i = int(np.argmax(bad))
        pose = path.pose_of(req.arm, q[i:i + 1])[0] if piece.path is None or piece.s is None \
            else piece.path(piece.s[i:i + 1])[0]
        segment = None if piece.segment0 < 0 else _segment_at(req, piece, i)
        return _violation(req, torque, q[i], pose, g[i], None, segment)
    return None


def _segment_at(req: PlanRequest, piece: DensePiece, i: int) -> tuple[int, int]:
    """The path segment (waypoint j → j + 1) dense sample i of a path piece lies on."""
    assert piece.path is not None and piece.s is not None
    knots = piece.path.knots
    k = int(np.searchsorted(knots, piece.s[i], side="right")) - 1
    j = piece.segment0 + min(max(k, 0), len(knots) - 2)
    return (j, j + 1)
