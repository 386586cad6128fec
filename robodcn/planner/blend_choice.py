"""Whether a blended plan keeps its blended curve or stops at the vias: decided by geometry
and limits alone, so the duration, the rate and the profile never change the tool's path.

A blend never takes longer than stopping at the vias: the blended curve departs from the
segments (its Hermite corrections, :func:`robodcn.planner.path.blended_path`) and can be
longer or more curved than they are, so when stopping is faster the plan stops there.
"Faster" is measured once, on one canonical timing: the time-optimal law (:func:`robodcn.
path_timing.time_optimal`, jerk and torque limits included) of each geometry's dense joint
path, in continuous time at the arm's own ``[bus] rate_hz``. The requested profile,
duration and stream rate play no part, so the console's preview, a slow dry run and a fast
real move trace one path (industrial blends are likewise zones in space: ABB's z10, UR's
blend radius). A uniform law keeps the blended curve and may come to rest at its vias
(:mod:`~robodcn.planner.uniform`).
"""

from __future__ import annotations

import dataclasses
import logging

from robodcn.contract.request import PlanRequest
from robodcn.path_timing import moving_start
from robodcn.planner import arm_arrays, holding
from robodcn.planner.arc import by_arc_length
from robodcn.planner.pieces import DensePiece, build_pieces

log = logging.getLogger(__name__)


def _optimal_duration(req: PlanRequest, pieces: list[DensePiece]) -> float:
    """Σ of the pieces' time-optimal durations (s) at the canonical rate."""
    limits = arm_arrays.limits_of(req.arm, getattr(req, "payload_kg", None))
    rate = req.arm.bus.rate_hz
    total = 0.0
    for piece in by_arc_length(req, pieces):
        law = moving_start.timed(piece.q, piece.s, limits, rate)
        total += 0.0 if law is None else law.duration
    return total


def stops_beat_blend(req: PlanRequest) -> bool:
    """True when ``req`` (``blend=True``, from rest) should stop at its vias: stopping is
    faster under the canonical optimal law (module doc); False for one segment, a plan
    without blend, a moving start (joined to the blended curve as it is), or when the
    blended geometry leaves the workspace (validation then names its sample)."""
    if not req.blend or req.segments < 2:
        return False
    if req.start_state is not None and req.start_state.moving:
        return False
    canonical = dataclasses.replace(req, duration="auto", profile="optimal",
                                    rate_hz=req.arm.bus.rate_hz)
    stopping = dataclasses.replace(canonical, blend=False)
    blended, _ = build_pieces(canonical)
    stops, _ = build_pieces(stopping)
    if blended is None or stops is None:
        return False
    # a blended curve the arm cannot hold somewhere is not timed (its law crawls:
    # planner.holding); the plan stops at the vias, whose path the planner checked first
    if holding.overload(canonical, blended) is not None:
        log.debug("blend: the blended curve passes a pose the arm cannot hold: stopping")
        return True
    t_blend = _optimal_duration(canonical, blended)
    t_stops = _optimal_duration(canonical, stops)
    if t_stops < t_blend:
        log.debug("blend: stopping at the vias (%.4f s optimal) beats the blend (%.4f s)",
                  t_stops, t_blend)
        return True
    return False
