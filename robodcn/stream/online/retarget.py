"""Retarget strategies: a new path from the moving state to new waypoints.

:meth:`Retargeting.tail` picks one (a later step moves all three onto the one moving start
of :mod:`robodcn.path_timing`):

* **planned** — the planner's plan from the moving state (``start_state``, profile
  "optimal") at full speed;
* **own** — brake along the present path as far as needed (a turn the limits cannot take
  at the present speed), then the planner's geometry bent at its start to the present
  direction of motion (:func:`~robodcn.stream.online_path.blend_start`), timed
  time-optimally from the moving state; at a speed scale below 1, or when the planner
  cannot start from the state;
* **through rest** — under jerk limits: brake to rest along the present path (or follow it
  to its end when that comes first), then the new path from rest. From a moving state
  neither the planner's moving start (it joins the state within its own sampled model:
  7–24 × the jerk limit on the wire across the switch) nor the bent start (the bend's own
  q⁽³⁾σ̇³ at speed) keeps a jerk limit; measured, every jerk-limited attempt ended braking
  to rest anyway, after a wasted planning.

The geometry is the planner's path from the switch joints (a request: planned from them as
:func:`robodcn.planner.plan_request` with ``start_joints`` would, an approach to its first
waypoint if the arm is not there; waypoints: the first None is the switch pose), sampled
slowly and re-timed afterwards.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn import kinematics
from robodcn.config import Arm
from robodcn.errors import AccelerationLimitError, RobodcnError, VelocityLimitError
from robodcn.planner import PlanRequest, StartState, plan, plan_request
from robodcn.stream.online.samples import Segment
from robodcn.stream.online.state import State
from robodcn.stream.online.timing import Timing
from robodcn.stream.online_path import (
    RETIME_SHARE,
    JointPath,
    blend_start,
    brake,
    controllable_speed,
    evenly_spaced,
)

#: geometry of a retarget: sampled at this rate over this many seconds (quintic, slow)
GEOMETRY_RATE_HZ = 200.0
GEOMETRY_DURATION_S = 5.0
#: arc-length samples a jerk-limited retarget keeps of that geometry
GEOMETRY_SAMPLES = 400
#: reachability stages of the quick checks while choosing a retarget's start blend
SEARCH_STAGES = 200

Target = PlanRequest | Sequence[Any]


def _with_start(waypoints: Sequence[Any], here: tuple[float, ...]) -> list[Any]:
    """``waypoints`` from ``here``: a first None is it, else it is put first."""
    out = list(waypoints)
    if out and out[0] is None:
        out[0] = here
    else:
        out.insert(0, here)
    return out


class Retargeting:
    """One retarget's planning: ``arm``, the stream's time laws, its present ``source`` (read
    only under jerk limits, where the move's own way to its end may be the brake; None
    without them) and speed scale."""

    def __init__(self, arm: Arm, timing: Timing, source: Any | None,
                 speed: float = 1.0) -> None:
        self.arm = arm
        self.timing = timing
        self.source = source
        self.speed = speed

    def tail(self, state: State, target: Target, options: dict[str, Any]) -> list[Segment]:
        """The new samples after ``state`` (segments on their paths). Raises the planner's
        errors (then nothing changes)."""
        if self.timing.jerk:
            return self.through_rest(state, target, options)
        if self.speed >= 1.0:
            try:
                return self.planned(state, target, options)
            except RobodcnError as exc:
                try:
                    return self.own(state, target, options)
                except RobodcnError:
                    raise exc from None
        return self.own(state, target, options)

    # -- the geometry ---------------------------------------------------------------------

    def geometry(self, q: NDArray, target: Target, options: dict[str, Any]) -> NDArray:
        """Joint samples of the planner's path from joints ``q`` to ``target`` (geometry
        only: a slow quintic, re-timed afterwards)."""
        start = tuple(float(v) for v in q)
        slow = {"profile": "quintic", "rate_hz": GEOMETRY_RATE_HZ}

        def planned(duration: float) -> NDArray:
            if isinstance(target, PlanRequest):
                request = dataclasses.replace(target, duration=duration, start_joints=start,
                                              **slow)
                return plan_request(request).joints
            here = tuple(kinematics.fk(self.arm.links, q[None, :])[0])
            waypoints = _with_start(target, here)
            return plan(self.arm, waypoints, start_joints=start,
                        **{**options, **slow, "duration": duration}).joints

        try:
            return self._even(planned(GEOMETRY_DURATION_S))
        except (VelocityLimitError, AccelerationLimitError):
            # a long way: the slow geometry plan needs longer (only its path is used)
            return self._even(planned(4 * GEOMETRY_DURATION_S))

    def _even(self, q: NDArray) -> NDArray:
        """Under jerk limits, the geometry's samples thinned to about even arc-length steps
        (:func:`~robodcn.stream.online_path.evenly_spaced`): the slow quintic crowds them at
        both ends, where third differences on them are noise of 10⁵ × the path's own q⁽³⁾."""
        return evenly_spaced(q, GEOMETRY_SAMPLES) if self.timing.jerk else q

    # -- the strategies -------------------------------------------------------------------

    def planned(self, state: State, target: Target, options: dict[str, Any]) -> list[Segment]:
        """The planner's plan from the moving state (profile "optimal", at full speed)."""
        rate = self.timing.rate
        start = StartState(tuple(state.q), tuple(state.qd), tuple(state.qdd))
        if isinstance(target, PlanRequest):
            request = dataclasses.replace(target, start_state=start, start_joints=None,
                                          profile="optimal", duration="auto", rate_hz=rate)
            trajectory = plan_request(request)
        else:
            here = tuple(kinematics.fk(self.arm.links, state.q[None, :])[0])
            trajectory = plan(self.arm, _with_start(target, here),
                              **{**options, "profile": "optimal", "duration": "auto",
                                 "rate_hz": rate, "start_state": start})
        path, sigma = JointPath.of_samples(trajectory.joints)
        return [(trajectory.joints[1:], sigma[1:], path)]

    def through_rest(self, state: State, target: Target,
                     options: dict[str, Any]) -> list[Segment]:
        """Under jerk limits: brake to rest along the present path (or follow it to its end
        when that comes first), then the new path from rest, timed under the present speed
        scale's limits."""
        timing = self.timing
        sigma = timing.brake(state)
        if sigma is None:
            segments = self._rest_of_source(state)
            q = segments[-1][0][-1] if segments else state.q
            history = np.vstack([state.history, *(seg[0] for seg in segments)])[-3:]
            rest = dataclasses.replace(state, q=q, history=history)
        else:
            segments = [(state.path.at(sigma), sigma, state.path)] if sigma.size else []
            rest = timing.braked(state, sigma, at_rest=True)
        path, _ = JointPath.of_samples(self.geometry(rest.q, target, options))
        path = dataclasses.replace(path, smooth=True)
        start = dataclasses.replace(rest, qd=np.zeros_like(rest.q), sd=0.0, sdd=0.0,
                                    path=path, sigma=0.0)
        tail = timing.timed_jerk(start, timing.limits.scaled(self.speed), speed=self.speed)
        return [*segments, (path.at(tail), tail, path)]

    def own(self, state: State, target: Target, options: dict[str, Any]) -> list[Segment]:
        """Brake along the present path as far as needed (a turn the limits cannot take at
        the present speed), then the new path, bent to the direction of motion."""
        timing = self.timing
        full = timing.limits
        limits = full.scaled(self.speed)
        rate = timing.rate
        segments: list[Segment] = []
        st = state
        path = None
        best_speed = math.inf
        for attempt in range(5):
            q_new = self.geometry(st.q, target, options)
            if st.sd <= 1e-9:
                path, _ = JointPath.of_samples(q_new)
                break
            direction = st.qd / st.sd
            total = float(np.sum(np.linalg.norm(np.diff(q_new, axis=0), axis=1)))
            length = max(st.sd ** 2 / (2.0 * float(np.min(limits.a))), 1e-3)
            coarse = q_new[::max(1, len(q_new) // SEARCH_STAGES)]
            best, best_speed = length, -1.0
            for _ in range(4):
                bent = blend_start(coarse, direction, min(length, max(total, 1e-3)))
                speed = controllable_speed(JointPath.of_samples(bent)[0], 0.0, limits,
                                           max_stages=SEARCH_STAGES)
                if speed > best_speed:
                    best, best_speed = length, speed
                if speed >= st.sd * 1.01 or length >= total:
                    break
                length *= 2.0
            path, _ = JointPath.of_samples(blend_start(q_new, direction,
                                                       min(best, max(total, 1e-3))))
            path = dataclasses.replace(path, start_tangent=direction)
            # the decision on the full path, under the limits the re-timing aims for
            best_speed = controllable_speed(path, 0.0, limits.scaled(1.0).shrunk(RETIME_SHARE))
            if st.sd <= best_speed * 0.99:
                break
            # too fast for the turn: brake along the present path first, then try again
            until = 0.0 if attempt >= 1 else 0.85 * best_speed
            more = brake(st.path, st.sigma, st.sd, full.a, rate, until_sd=until)
            if until == 0.0:
                # one sample at rest where the brake ends: the last step to rest and the
                # new path's first step from rest do not add up in one acceleration
                more = np.concatenate([more, more[-1:]]) if more.size else \
                    np.array([st.sigma])
            if not more.size:
                break
            segments.append((st.path.at(more), more, st.path))
            ends = st.path.at(np.concatenate([[st.sigma], more])[-2:])
            qd = (ends[1] - ends[0]) * rate
            st = dataclasses.replace(st, q=ends[1], qd=qd, sigma=float(more[-1]),
                                     sd=float(np.linalg.norm(qd)))
        assert path is not None
        tail = timing.timed(dataclasses.replace(st, path=path, sigma=0.0), limits,
                            allowed=best_speed if st.sd > 1e-9 else math.inf, speed=self.speed)
        segments.append((path.at(tail), tail, path))
        return segments

    def _rest_of_source(self, state: State) -> list[Segment]:
        """The samples after ``state`` as they are (one segment per path): the present
        move's own way to rest."""
        src = self.source
        segments: list[tuple[list, list, JointPath]] = []
        for i in range(state.index + 1, src.end):
            path, sigma = src.path_at(i)
            if segments and segments[-1][2] is path:
                segments[-1][0].append(src.joint(i))
                segments[-1][1].append(sigma)
            else:
                segments.append(([src.joint(i)], [sigma], path))
        return [(np.array(q), np.array(s), p) for q, s, p in segments]


__all__ = [
    "GEOMETRY_DURATION_S",
    "GEOMETRY_RATE_HZ",
    "GEOMETRY_SAMPLES",
    "SEARCH_STAGES",
    "Retargeting",
]
