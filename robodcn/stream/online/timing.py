"""The time laws an online operation puts on the present path, from a commanded state.

A :class:`Timing` holds an execution's full limits (with the torque limits of its arm and
payload when the arm sets ``max_torque_nm``: ``limits.torque``, and the move's tool limits:
``limits.tool``; every law below keeps them)
and stream rate and the first law each path was timed with (what a speed scale k must stay
k × under):

* :meth:`Timing.brake` — the fastest brake along the path to a speed (jerk-limited on an
  arm with jerk limits: :func:`~robodcn.stream.online_path.brake_jerk_checked`), or None
  where the path ends before it could (the move's own end is then the stop);
* :meth:`Timing.timed` — brake with the full limits while over what the target limits
  allow, then the time-optimal law under them to the path's end
  (:func:`~robodcn.stream.online_path.retime`); under jerk limits from (σ̇, σ̈), else after
  a brake, else from rest;
* :meth:`Timing.retimed` — that law for a speed change or resume, capped at k × the path's
  own first law.

:class:`NoLaw` says no law under the limits joins the state (data: the speed scale).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from robodcn.errors import InputError
from robodcn.path_timing import JointLimits
from robodcn.path_timing.tool import ToolLimits
from robodcn.path_timing.torque import TorqueLimits
from robodcn.stream.online.samples import Segment
from robodcn.stream.online.state import State
from robodcn.stream.online_path import (
    JointPath,
    brake_checked,
    brake_jerk_checked,
    controllable_speed,
    retime,
)

#: re-timings tried by a speed change or resume, braking further between them
RETIME_TRIES = 8

SpeedCap = Callable[[NDArray[np.float64]], NDArray[np.float64]]


class NoLaw(InputError):
    """No law under the scaled limits joins the present state (near the path's end the
    move already brakes to rest at the full limits): the samples planned stand."""

    def __init__(self, message: str, speed: float) -> None:
        super().__init__(message, field="speed", value=speed)
        self.speed = speed


def samples(path: JointPath, sigma: NDArray) -> list[Segment]:
    """One segment: the joints of ``path`` at ``sigma``."""
    return [(path.at(sigma), sigma, path)]


class Timing:
    """Time laws at one stream rate under one arm's full limits (thread-safe for reads)."""

    def __init__(self, limits: JointLimits, rate_hz: float) -> None:
        self.limits = limits
        self.rate = float(rate_hz)
        self.jerk = limits.j is not None
        #: id(path) → (path, σ midpoints, σ̇ at speed 1) of the first law on each path
        self._laws: dict[int, tuple[JointPath, NDArray, NDArray]] = {}

    def with_torque(self, torque: TorqueLimits | None) -> Timing:
        """The same laws under other torque limits (another payload); the first laws of
        the paths (:meth:`register_law`) are shared."""
        other = Timing(dataclasses.replace(self.limits, torque=torque), self.rate)
        other._laws = self._laws
        return other

    def with_tool(self, tool: ToolLimits | None) -> Timing:
        """The same laws under other tool limits (a retarget told another ``tool_speed``
        …); the first laws of the paths are shared."""
        other = Timing(dataclasses.replace(self.limits, tool=tool), self.rate)
        other._laws = self._laws
        return other

    def brake(self, state: State, until_sd: float = 0.0) -> NDArray | None:
        """σ samples of the fastest brake along the present path from ``state`` (to
        ``until_sd``) under the full limits; None when the path ends first."""
        limits, rate = self.limits, self.rate
        if limits.j is None:
            sigma = brake_checked(state.path, state.sigma, state.sd, limits.a, rate,
                                  limits.torque, state.history, until_sd=until_sd)
            # a brake that runs into the path's end is cut there (a step to rest): the move's
            # own end, braking within the limits, comes first
            ends = sigma.size and sigma[-1] >= state.path.length - 1e-12 and state.sd > 0.0
            return None if ends else sigma
        return brake_jerk_checked(state.path, state.sigma, state.sd, state.sdd, limits, rate,
                                  state.history, until_sd=until_sd)

    def braked(self, state: State, sigma: NDArray, *, at_rest: bool) -> State:
        """The state where the σ samples ``sigma`` of a brake on ``state.path`` end."""
        if not sigma.size:
            return state
        q = state.path.at(sigma[-3:])
        history = np.vstack([state.history, q])[-3:] if state.history is not None else None
        rate = self.rate
        sd = 0.0 if at_rest else float(np.linalg.norm(history[-1] - history[-2]) * rate)
        return dataclasses.replace(state, index=state.index + len(sigma), q=history[-1],
                                   qd=(history[-1] - history[-2]) * rate,
                                   qdd=np.zeros_like(state.q), sigma=float(sigma[-1]), sd=sd,
                                   sdd=0.0, history=history)

    @staticmethod
    def allowed(path: JointPath, sigma: float, limits: JointLimits, cap: SpeedCap | None) -> float:
        """The fastest σ̇ a re-timing may start with at ``sigma``: the controllable speed
        under ``limits``, and under the speed ``cap`` when there is one."""
        top = controllable_speed(path, sigma, limits)
        return top if cap is None else min(top, float(cap(np.array([sigma]))[0]))

    def timed(self, state: State, limits: JointLimits, path: JointPath | None = None,
              sigma0: float | None = None, allowed: float | None = None,
              cap: SpeedCap | None = None, speed: float = 1.0) -> NDArray:
        """σ samples: brake with the full limits while over what ``limits`` allow, then the
        time-optimal law under ``limits`` (and the speed ``cap``) to the end of the path.

        Raises
        ------
        NoLaw
            no re-timing from the present speed (``speed``: the scale, for the message)."""
        if self.jerk:
            return self.timed_jerk(state, limits, path, sigma0, cap, speed)
        path = state.path if path is None else path
        s0 = state.sigma if sigma0 is None else sigma0
        rate, full = self.rate, self.limits
        sd = state.sd
        pre = np.zeros(0)

        def allow(at: float) -> float:
            return self.allowed(path, at, limits, cap)

        if allowed is None:
            allowed = allow(s0) if sd > 0 else math.inf
        if sd > allowed * 0.98:
            pre = brake_checked(path, s0, sd, full.a, rate, full.torque,
                                state.history if path is state.path else None,
                                until_sd=allowed * 0.95)
            if pre.size:
                sd = (pre[-1] - (pre[-2] if pre.size > 1 else s0)) * rate
                s0 = float(pre[-1])
        for attempt in range(RETIME_TRIES):
            try:
                rest = retime(path, s0, sd, limits, rate, sd_cap=cap)
                break
            except InputError:
                if sd <= 0.0:
                    raise
                # Too fast for ``limits`` here: the brake ran on to where less speed is
                # allowed (near the path's end). Brake again to what is allowed where it
                # now is; the last tries brake to rest (always possible under the full
                # limits), from where the scaled law starts.
                to_rest = attempt >= RETIME_TRIES - 2
                until = 0.0 if to_rest else min(0.8 * sd, 0.95 * allow(s0))
                prev = pre[-1] if pre.size else s0
                more = brake_checked(path, s0, sd, full.a, rate, full.torque,
                                     until_sd=until)
                if to_rest:
                    # one sample at rest where the brake ends (its last step and the law's
                    # first step from rest are two accelerations, not one)
                    more = np.concatenate([more, more[-1:]]) if more.size else np.array([s0])
                    sd = 0.0
                elif more.size:
                    sd = (more[-1] - (more[-2] if more.size > 1 else prev)) * rate
                else:
                    continue
                pre = np.concatenate([pre, more])
                s0 = float(more[-1])
        else:
            raise NoLaw("cannot re-time the path from the present speed", speed)
        if pre.size and pre[-1] >= path.length - 1e-12 and rest.size == 0:
            # the brake (a share of the full limits) ran to the path's end still moving:
            # the move is already braking to its end as fast as the limits allow
            last = pre[-1] - (pre[-2] if pre.size > 1 else state.sigma)
            if last * rate > 1e-9:
                raise NoLaw("cannot re-time the path from the present speed: it ends "
                            "before a brake could reach the scaled limits", speed)
        return np.concatenate([pre, rest])

    def timed_jerk(self, state: State, limits: JointLimits, path: JointPath | None = None,
                   sigma0: float | None = None, cap: SpeedCap | None = None,
                   speed: float = 1.0) -> NDArray:
        """:meth:`timed` under jerk limits: the law from the moving state (σ̇, σ̈); else a
        jerk-limited brake under the full limits to below what ``limits`` allow and the law
        from there; else a brake to rest and the law from rest (always possible).

        Raises
        ------
        NoLaw
            the path ends before any brake could (the move's own end)."""
        path = state.path if path is None else path
        st = dataclasses.replace(state, path=path,
                                 sigma=state.sigma if sigma0 is None else sigma0)
        rate = self.rate

        def law(at: State) -> NDArray:
            return retime(path, at.sigma, at.sd, limits, rate, sdd0=at.sdd,
                          history=at.history, sd_cap=cap)

        try:
            return law(st)
        except InputError:
            pass
        if st.sd > 0.0:
            allowed = self.allowed(path, st.sigma, limits, cap)
            if 0.0 < allowed < st.sd:
                pre = self.brake(st, until_sd=0.9 * allowed)
                if pre is not None:
                    try:
                        return np.concatenate([pre, law(self.braked(st, pre,
                                                                    at_rest=False))])
                    except InputError:
                        pass
        pre = self.brake(st) if st.sd > 0.0 or st.sdd != 0.0 else np.zeros(0)
        if pre is None:
            raise NoLaw("cannot re-time the path from the present speed: it ends before a "
                        "jerk-limited brake could stop", speed)
        return np.concatenate([pre, law(self.braked(st, pre, at_rest=True))])

    # -- a speed scale stays k × the path's own first law -----------------------------------

    def register_law(self, path: JointPath, sigma: NDArray, scale: float) -> None:
        """Keep the first law a path was timed with, at speed scale 1 (σ̇ / ``scale`` at the
        midpoints of its samples): what a speed scale k must not exceed k × of."""
        if id(path) in self._laws or sigma.size < 2:
            return
        step = np.diff(sigma)
        keep = step > 0.0
        if not keep.any():
            return
        mid = 0.5 * (sigma[1:] + sigma[:-1])[keep]
        self._laws[id(path)] = (path, mid, step[keep] * self.rate / max(scale, 1e-9))

    def speed_cap(self, state: State, k: float) -> SpeedCap | None:
        """σ ↦ the largest σ̇ a re-timing at speed scale k may reach: k × the path's own
        first law, so a slower, fixed-duration plan stays k × as slow (as with
        joint_trajectory_controller's speed scaling) instead of becoming time-optimal. The
        k-scaled law itself keeps v·k, a·k², j·k³, so a law under the cap exists from any
        state below it; :meth:`timed` brakes to it first."""
        entry = self._laws.get(id(state.path))
        if entry is None or entry[0] is not state.path:
            return None
        _, mid, speed = entry

        def cap(s: NDArray[np.float64]) -> NDArray[np.float64]:
            return k * np.interp(s, mid, speed) * (1.0 + 1e-6) + 1e-9

        return cap

    def retimed(self, state: State, k: float) -> NDArray | None:
        """:meth:`timed` on the present path at speed scale ``k`` (a speed change or a
        resume); None when nothing of the path is left to re-time (the switch is at its
        end: the samples planned stand).

        Raises
        ------
        NoLaw, LawExceedsLimits
            no law under the scaled limits from this state."""
        sigma = self.timed(state, self.limits.scaled(k), cap=self.speed_cap(state, k),
                           speed=k)
        return sigma if sigma.size else None


__all__ = ["RETIME_TRIES", "NoLaw", "SpeedCap", "Timing", "samples"]
