"""Retargeting: a new path from the commanded moving state to new goals.

:meth:`Retargeting.tail` plans the replacement :class:`~robodcn.stream.online.replacement.
Replacement` describes (goals after the switch pose, plan fields honoured or refused):

* **geometry** — the planner's path from the switch joints through the goals (a slow
  uniform plan whose joint samples only are used), cut into pieces at its stops (vias
  without blend);
* **moving start** (no jerk limit) — the one moving start of the planner,
  :func:`robodcn.path_timing.moving_start.join`: along the tangent, blended out in joint
  space, or braking along q̇₀ and leaving from rest where the brake ends; the samples are
  checked with the three commanded before the switch (:func:`~robodcn.stream.online_path.
  excess`) and a start that fails takes the next, slower blend
  (:func:`~robodcn.path_timing.moving_start.retry`); when none is left it goes through
  rest (below) — each step says what it found as data, nothing is caught; on an arm with
  torque limits (which the checks count) a start found only after retries is compared
  with the way through rest, and the one with fewer samples taken;
* **through rest** (under jerk limits, and the last resort without) — the jerk-limited
  brake to rest along the present path (or its own end when that comes first), then the
  new path from rest. From a moving state neither the blend (its q⁽³⁾ at speed) nor the
  planner's moving start keeps a jerk limit across the switch (7–24 × it on the wire).

Every law is timed under the limits × k: k is the execution's speed scale, and for a
numeric ``duration`` the k (≤ the speed scale) whose motion takes that long from the switch
(:meth:`Retargeting.fitted`; duration ∝ 1/k for a law under v·k, a·k², j·k³).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable
from typing import Any, NoReturn

import numpy as np
from numpy.typing import NDArray

from robodcn.config import Arm
from robodcn.errors import (
    AccelerationLimitError,
    InputError,
    RobodcnError,
    VelocityLimitError,
)
from robodcn.path_timing import JointLimits, moving_start
from robodcn.path_timing.moving_start import JointState, StartSegment
from robodcn.path_timing.tool import ToolLimits
from robodcn.path_timing.torque import TorqueLimits
from robodcn.planner.path import user_pose
from robodcn.stream.online.replacement import Replacement, Target
from robodcn.stream.online.samples import Segment
from robodcn.stream.online.state import State
from robodcn.stream.online.timing import Timing
from robodcn.stream.online_path import JointPath, evenly_spaced, excess, retime

#: geometry of a retarget: sampled at this rate over this many seconds (quintic, slow)
GEOMETRY_RATE_HZ = 200.0
GEOMETRY_DURATION_S = 5.0
#: arc-length samples kept of that geometry
GEOMETRY_SAMPLES = 400
#: rounds of fitting k to a numeric duration, and how close (samples, share) is met
FIT_ROUNDS = 8
#: rounds of fitting the moving start's stretch (met within 3 on the omx's paths; where it
#: is not met by then it seldom is: through rest is fitted instead)
MOVING_FIT_ROUNDS = 3
FIT_SAMPLES, FIT_SHARE = 2, 0.005
#: the commanded samples may pass a limit by rounding only
LIMIT_SLACK = 1e-9
#: a new path whose start lies within this angle (joint space) of the motion is ahead
AHEAD_DEG = 60.0
#: below this σ̇ (rad/s) the commanded state is at rest (a held pause, a brake's end)
AT_REST = 1e-9


def segment_of(q0: NDArray, joints: NDArray) -> Segment:
    """New samples ``joints`` after the switch joints ``q0`` as one segment on their own
    path (a later operation brakes or re-times along what was sent)."""
    path, sigma = JointPath.of_samples(np.vstack([q0, joints]))
    return (joints, sigma[1:], path)


def _pieces(path: JointPath) -> list[tuple[NDArray, NDArray]]:
    """(q, σ) of the path between its stops (each piece from and to rest but the first)."""
    cuts = [0.0, *path.stops, path.length]
    out = []
    for lo, hi in itertools.pairwise(cuts):
        inner = (path.sigma > lo + 1e-12) & (path.sigma < hi - 1e-12)
        s = np.concatenate([[lo], path.sigma[inner], [hi]])
        out.append((path.at(s), s))
    return out


class Retargeting:
    """One retarget's planning: ``arm``, the stream's time laws, its present ``source``
    (the move's own way to its end, read when a brake along the present path cannot stop
    before it; None: not read) and speed scale."""

    def __init__(self, arm: Arm, timing: Timing, source: Any | None,
                 speed: float = 1.0) -> None:
        self.arm = arm
        self.timing = timing
        self.source = source
        self.speed = speed

    def tail(self, state: State, target: Target, options: dict[str, Any]) -> list[Segment]:
        """The new samples after ``state`` (segments on their paths). Raises the planner's
        errors and InputError for a field the replacement cannot honour (nothing
        changes). A replacement told another ``payload_kg`` (on an arm with torque limits)
        is timed with it, and one told tool limits with those: ``self.timing`` is then that
        payload's and those tools' (the execution keeps it
        for the operations after the switch)."""
        rep = Replacement.of(self.arm, target, options, self.timing.rate)
        torque = self.timing.limits.torque
        if torque is not None and rep.payload_kg is not None \
                and rep.payload_kg != torque.payload_kg:
            # told another payload: every law of the replacement carries it
            self.timing = self.timing.with_torque(TorqueLimits.of(self.arm, rep.payload_kg))
        told, fields = rep.tool
        if told:
            tool = ToolLimits.of(self.arm, fields["tool_speed"], fields["tool_angular_speed"],
                                 fields["tool_acceleration"])
            if tool != self.timing.limits.tool:
                self.timing = self.timing.with_tool(tool)
        k = self.speed
        if self.timing.jerk:
            # from rest: the law under the limits × k λ lasts 1/λ × as long
            return self.met(self.fitted(self.rest_law(state, rep, k), rep.duration),
                            rep.duration)
        fastest = self.moving(state, rep, k)
        if rep.duration == "auto":
            return fastest
        if not _moves(fastest):
            return self.held(state, fastest, rep.duration)
        want, tol = self._wanted(rep.duration)
        if _count(fastest) > want + tol:  # shorter than the fastest way: nothing to fit
            self.refuse(rep.duration, fastest)
        try:
            segments = self.fitted(lambda lam: fastest if lam >= 1.0 else
                                   self.stretched(state, fastest, lam), rep.duration,
                                   MOVING_FIT_ROUNDS)
        except RobodcnError:
            # a stretch the limits refuse (LawExceedsLimits; or its path stuck where the
            # moving start stops: "cannot move from s"): through rest below
            segments = None
        if segments is not None and self._within(segments, rep.duration) \
                and self._keeps_limits(state, np.vstack([seg[0] for seg in segments])):
            return segments
        # The moving start's law stretched along its own path has no λ that lasts the
        # duration (its brake to the slower law's speed jumps in length: 222 → 400 samples
        # for λ 0.5821 → 0.5803 on the omx), or the limits refuse the stretch, or its
        # samples pass them across the switch (up to 1.27 × on the omx, where it slows
        # from the moving state): the way through rest, whose law from rest scales
        # smoothly, is fitted instead.
        try:
            rest = self.fitted(self.rest_law(state, rep, k), rep.duration)
        except RobodcnError:
            # no way through rest either (the present path ends before a brake could stop,
            # no source to follow; or it takes longer than the duration): refused below
            rest = None
        if rest is not None and self._within(rest, rep.duration):
            return rest
        self.refuse(rep.duration, fastest)

    def _keeps_limits(self, state: State, joints: NDArray) -> bool:
        """Whether the samples ``joints`` after the switch keep every limit with the
        commanded ones before it (:func:`~robodcn.stream.online_path.excess` on the wire's
        finite differences)."""
        history = state.history if state.history is not None else state.q[None]
        return excess(np.vstack([history, joints]), self.timing.limits,
                      self.timing.rate) <= 1.0 + LIMIT_SLACK

    def _wanted(self, duration: float | str) -> tuple[float, float]:
        """(samples, tolerance) a numeric ``duration`` / speed scale asks for."""
        want = float(duration) * self.timing.rate / self.speed
        return want, max(FIT_SAMPLES, FIT_SHARE * want)

    def _within(self, segments: list[Segment], duration: float | str) -> bool:
        """Whether ``segments`` last ``duration`` / speed scale within the fit's tolerance."""
        want, tol = self._wanted(duration)
        return abs(_count(segments) - want) <= tol

    def met(self, segments: list[Segment], duration: float | str) -> list[Segment]:
        """``segments``, when they last ``duration`` (within the fit's tolerance); else
        :meth:`refuse`: a replacement never runs for another time than the one asked."""
        if duration == "auto" or self._within(segments, duration):
            return segments
        self.refuse(duration)

    def refuse(self, duration: float | str, fastest: list[Segment] | None = None) -> NoReturn:
        """InputError naming ``duration``: no law found lasts it within every limit
        (``fastest``: the moving start's own law, whose length the message says)."""
        rate = self.timing.rate / self.speed
        low = "" if fastest is None else \
            f" (as fast as the limits allow: {_count(fastest) / rate:.3f} s)"
        raise InputError(f"the replacement cannot be timed to duration {duration!r} from the "
                         f"moving state within every limit{low}; ask for another duration "
                         f"or \"auto\"", field="duration", value=duration)

    def held(self, state: State, segments: list[Segment],
             duration: float | str) -> list[Segment]:
        """A replacement whose way there does not move (the arm is already at its goal) with
        a numeric ``duration``: it holds the goal that long (at rest), or — from a moving
        state, which cannot stay where it is — refuses the duration (InputError)."""
        if state.sd > AT_REST:
            raise InputError(f"the replacement's goal is where the moving arm is: it cannot "
                             f"take duration {duration!r} there (use \"auto\")",
                             field="duration", value=duration)
        q_end = segments[-1][0][-1] if segments and len(segments[-1][0]) else state.q
        n = max(1, round(float(duration) * self.timing.rate / self.speed))
        joints = np.tile(np.asarray(q_end, dtype=np.float64), (n, 1))
        return [(joints, np.zeros(n), JointPath.of_samples(np.vstack([state.q, joints]))[0])]

    # -- the duration -----------------------------------------------------------------

    def fitted(self, build: Callable[[float], list[Segment]],
               duration: float | str, rounds: int = FIT_ROUNDS) -> list[Segment]:
        """``build(1)``, or (a numeric ``duration``) ``build(λ)`` at the λ ≤ 1 whose samples
        last ``duration`` / speed scale (log-linear secant steps within a bracket: the
        samples grow about as 1/λ), in at most ``rounds``; the closest found (the caller
        checks it: :meth:`met`).

        Raises
        ------
        InputError
            the duration is shorter than the motion at the present speed scale takes."""
        segments = build(1.0)
        if duration == "auto":
            return segments
        rate = self.timing.rate
        want, tol = self._wanted(duration)
        n = _count(segments)
        if n > want + tol:
            raise InputError(f"the replacement needs at least {n / rate * self.speed:.3f} s "
                             f"from the moving state, got duration {duration!r}",
                             field="duration", value=duration)
        best = (abs(n - want), segments)
        short, long_ = (1.0, max(n, 1)), None
        lam = max(n, 1) / want
        for _ in range(rounds):
            if best[0] <= tol:
                break
            segments = build(lam)
            n = max(_count(segments), 1)
            best = min(best, (abs(n - want), segments), key=lambda b: b[0])
            if n < want:
                short = (lam, n)
            else:
                long_ = (lam, n)
            if long_ is None:
                lam *= n / want
            else:
                (l0, n0), (l1, n1) = short, long_
                w = (math.log(want) - math.log(n0)) / (math.log(n1) - math.log(n0) or 1.0)
                lam = math.exp(math.log(l0) + w * (math.log(l1) - math.log(l0)))
        return best[1]

    def stretched(self, state: State, segments: list[Segment], lam: float) -> list[Segment]:
        """The moving start's samples re-timed along their own path at λ × its law (under
        the limits × λ k; as a speed scale λ, braking along the path first while faster)."""
        timing, rate = self.timing, self.timing.rate
        _joints, sigma, path = segments[-1] if len(segments) == 1 else segment_of(
            state.q, np.vstack([seg[0] for seg in segments]))
        step = np.diff(np.concatenate([[0.0], sigma]))
        mid = np.concatenate([[0.0], sigma])[:-1] + 0.5 * step
        keep = step > 0.0
        law = step[keep] * rate
        at = mid[keep]

        def cap(s: NDArray[np.float64]) -> NDArray[np.float64]:
            return lam * np.interp(s, at, law) * (1.0 + 1e-6) + 1e-9

        start = dataclasses.replace(state, path=path, sigma=0.0)
        out = timing.timed(start, timing.limits.scaled(self.speed * lam), cap=cap,
                           speed=lam)
        return [(path.at(out), out, path)]

    # -- the geometry -----------------------------------------------------------------

    def geometry(self, q: NDArray, rep: Replacement) -> JointPath:
        """The planner's path from joints ``q`` through the goals, by arc length (its
        first sample exactly ``q``; C² between its samples)."""
        here = tuple(float(v) for v in user_pose(self.arm, q[None, :])[0])
        try:
            joints = rep.geometry(q, here, GEOMETRY_RATE_HZ, GEOMETRY_DURATION_S)
        except (VelocityLimitError, AccelerationLimitError):
            # a long way: the slow geometry plan needs longer (only its path is used)
            joints = rep.geometry(q, here, GEOMETRY_RATE_HZ, 4 * GEOMETRY_DURATION_S)
        joints = evenly_spaced(joints, GEOMETRY_SAMPLES)
        joints[0] = q
        path, _ = JointPath.of_samples(joints)
        return dataclasses.replace(path, smooth=True)

    # -- from the moving state (no jerk limit) ---------------------------------------------

    def moving(self, state: State, rep: Replacement, k: float) -> list[Segment]:
        """The moving start onto the new path under the limits × ``k`` (module doc)."""
        full, rate = self.timing.limits, self.timing.rate
        limits = full.scaled(k)
        at_rest = state.sd <= AT_REST
        js = JointState(state.q, np.zeros_like(state.q) if at_rest else state.qd,
                        np.zeros_like(state.q) if at_rest else state.qdd)
        path = self.geometry(state.q, rep)
        pieces = _pieces(path)
        q1, s1 = pieces[0]
        # a new path that starts ahead of the motion (within AHEAD_DEG of q̇₀) is blended
        # into, not braked to: no stop unless the goal lies behind or to the side
        ahead = _cosine(q1[1] - q1[0], js.qd) >= math.cos(math.radians(AHEAD_DEG))
        seg: StartSegment | None = moving_start.join(js, q1, s1, limits, rate,
                                                     allow_brake=not ahead)
        blended = ahead
        braked = not ahead
        tried = 0
        while seg is not None:
            joints = self._sampled(seg, q1, s1, rep, limits)
            if joints is None:  # a brake that would end outside the joint limits
                seg, blended = moving_start.join(js, q1, s1, limits, rate,
                                                 allow_brake=False), True
                continue
            joints = np.vstack([joints, self._rest(path, pieces, limits)])
            tried += 1
            if self._keeps_limits(state, joints):
                found = [segment_of(state.q, joints)]
                if full.torque is None or tried == 1:
                    return found
                # the torque limits slowed the moving start (its blend and brake along q̇₀
                # keep them only when slow): through rest may be the faster way
                rest = self.through_rest(state, rep, k)
                return rest if _count(rest) < _count(found) else found
            if seg.kind == "brake" and not blended:
                seg, blended = moving_start.join(js, q1, s1, limits, rate,
                                                 allow_brake=False), True
                continue
            seg = moving_start.retry(seg, js, q1, s1, limits, rate)
            if seg is None and ahead and not braked:
                # no blend keeps the limits: brake along q̇₀ and leave from rest
                seg, braked = moving_start.join(js, q1, s1, limits, rate), True
                seg = seg if seg.kind == "brake" else None
        return self.through_rest(state, rep, k)

    def _sampled(self, seg: StartSegment, q: NDArray, s: NDArray, rep: Replacement,
                 limits: JointLimits) -> NDArray | None:
        """The joints after the switch of the start ``seg`` on the piece (q, s): its law
        with the blend-out added, or the brake and the path from rest where it ends (None
        when the brake ends outside the joint limits)."""
        rate = self.timing.rate
        if seg.kind == "brake":
            brake = seg.brake
            assert brake is not None
            lo = np.array([j.min_angle for j in self.arm.joints])
            hi = np.array([j.max_angle for j in self.arm.joints])
            if (brake.q_stop < lo).any() or (brake.q_stop > hi).any():
                return None
            m = brake.law.sample(rate)
            stopping = brake.q0 + np.outer(m.s[1:], brake.q_stop - brake.q0)
            rest = JointState(brake.q_stop, np.zeros_like(brake.q0), np.zeros_like(brake.q0))
            path = self.geometry(brake.q_stop, rep)
            pieces = _pieces(path)
            q1, s1 = pieces[0]
            go = self._sampled(moving_start.join(rest, q1, s1, limits, rate), q1, s1, rep,
                               limits)
            assert go is not None  # from rest: never a brake
            return np.vstack([stopping, go, self._rest(path, pieces, limits)])
        piece = JointPath(q, s, smooth=True)
        if seg.law is None:  # nothing moves along the piece
            return q[-1:].copy()
        m = seg.law.sample(rate)
        joints = piece.at(m.s)
        if seg.blend is not None:
            tb = min(seg.blend.duration, m.t[-1])
            blend = dataclasses.replace(seg.blend, duration=max(tb, 1.0 / rate))
            joints = joints + blend.correction(m.t)
        return joints[1:]

    def _rest(self, path: JointPath, pieces: list[tuple[NDArray, NDArray]],
              limits: JointLimits) -> NDArray:
        """The joints of the path after its first stop, from rest there (empty without
        one)."""
        if len(pieces) < 2:
            return np.zeros((0, path.q.shape[1]))
        sigma = retime(path, path.stops[0], 0.0, limits, self.timing.rate)
        return path.at(sigma)

    # -- through rest ----------------------------------------------------------------------

    def through_rest(self, state: State, rep: Replacement, k: float) -> list[Segment]:
        """Brake to rest along the present path (or follow it to its end when that comes
        first), then the new path from rest, timed under the limits × ``k``."""
        return self.rest_law(state, rep, k)(1.0)

    def rest_law(self, state: State, rep: Replacement, k: float
                 ) -> Callable[[float], list[Segment]]:
        """λ ↦ :meth:`through_rest` under the limits × k λ: the brake and the new path are
        found once (neither depends on λ), the law from rest for each λ."""
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
        path = self.geometry(rest.q, rep)
        start = dataclasses.replace(rest, qd=np.zeros_like(rest.q), sd=0.0, sdd=0.0,
                                    qdd=np.zeros_like(rest.q), path=path, sigma=0.0)

        def law(lam: float) -> list[Segment]:
            tail = timing.timed(start, timing.limits.scaled(k * lam), speed=k * lam)
            return [*segments, (path.at(tail), tail, path)]

        return law

    def _rest_of_source(self, state: State) -> list[Segment]:
        """The samples after ``state`` as they are (one segment per path): the present
        move's own way to rest."""
        src = self.source
        if src is None:
            raise InputError("cannot retarget through rest: the present path ends before a "
                             "brake could stop and the execution's samples were not given",
                             field="source", value=None)
        segments: list[tuple[list, list, JointPath]] = []
        for i in range(state.index + 1, src.end):
            path, sigma = src.path_at(i)
            if segments and segments[-1][2] is path:
                segments[-1][0].append(src.joint(i))
                segments[-1][1].append(sigma)
            else:
                segments.append(([src.joint(i)], [sigma], path))
        return [(np.array(q), np.array(s), p) for q, s, p in segments]


def _cosine(a: NDArray, b: NDArray) -> float:
    norm = float(np.linalg.norm(a) * np.linalg.norm(b))
    return float(a @ b) / norm if norm > 0.0 else 0.0


def _moves(segments: list[Segment]) -> bool:
    """Whether the segments' samples go anywhere (a σ step above 0)."""
    return any(len(seg[1]) and float(np.max(seg[1])) > 0.0 for seg in segments)


def _count(segments: list[Segment]) -> int:
    return sum(len(seg[1]) for seg in segments)


__all__ = [
    "AHEAD_DEG",
    "FIT_ROUNDS",
    "GEOMETRY_DURATION_S",
    "GEOMETRY_RATE_HZ",
    "GEOMETRY_SAMPLES",
    "MOVING_FIT_ROUNDS",
    "Retargeting",
    "segment_of",
]

