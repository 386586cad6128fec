"""The online motion generator: the commanded state, one period on, toward the newest input.

Every online operation is an :class:`~robodcn.online.state.Input` to one generator (Ruckig's
``update(input, output)``): following a stream of targets, a retarget, a smooth stop, a
pause (a stop that stays), a speed change (the scale). Each period :meth:`Generator.update`
returns the next :class:`~robodcn.online.state.Sample` (q, q̇, q̈) of the time-optimal law
from the commanded state to the input's target state within every joint's velocity,
acceleration and jerk limits, scaled by the input's speed scale k (v·k, a·k², j·k³).

The law is Ruckig's (Berscheid & Kröger, RSS 2021; the ``ruckig`` package, MIT community
edition): a time-optimal, per-joint jerk-limited profile, the joints synchronised to the
slowest, with a brake pre-trajectory when the state lies outside the (scaled) limits — so a
lower speed scale or a reversal is met from any commanded state, and one brake family serves
every operation. An arm without jerk limits gets Ruckig's acceleration-limited (second-order)
profile (jerk = inf). A new input costs one calculation (microseconds); a period without one
only samples the law.

Torque limits (``max_torque_nm``, with the payload) are not Ruckig's: :meth:`Generator.check`
validates an input's whole law with the rigid-body inverse dynamics
(:meth:`robodcn.path_timing.TorqueLimits.torques`) at most :data:`TORQUE_SAMPLES` instants and,
where a sample would exceed a joint's τ_max, lowers the input's speed scale (the inertial
and Coriolis torques fall as k², gravity not at all) through :data:`TORQUE_SCALES` until
the law keeps them — or returns :class:`~robodcn.online.state.Infeasible` ("torque") when
even the slowest does not (gravity alone overloads a joint). The check costs a few
milliseconds: a caller runs it when an input arrives, off the streaming thread, and hands
the checked input to :meth:`update` (the commanded state moves on meanwhile by the time the
check took; the law from there differs by as little).
"""

from __future__ import annotations

import math
import threading
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from ruckig import (
    ControlInterface,
    InputParameter,
    OutputParameter,
    Result,
    Ruckig,
    RuckigError,
    Trajectory,
)

from robodcn.online.state import MODES, Infeasible, Input, Sample
from robodcn.path_timing import JointLimits

#: the speed scales :meth:`Generator.check` tries, in order, when a law exceeds a torque limit
TORQUE_SCALES = (1.0, 0.85, 0.7, 0.55, 0.4, 0.3, 0.2, 0.1)
#: instants of a law whose torques :meth:`Generator.check` evaluates at most (evenly spaced,
#: at most one period apart; one vectorised inverse dynamics)
TORQUE_SAMPLES = 400
#: a law with a minimum duration this many times longer than asked fell into a blocked
#: interval (:meth:`Generator._unblocked`)
BLOCKED_RATIO = 1.5
#: Ruckig's results that carry a law
_GOOD = (Result.Working, Result.Finished)


class Generator:
    """The commanded state of one arm's joints and the law toward the newest input.

    Parameters
    ----------
    limits : the joints' limits (:class:`~robodcn.path_timing.JointLimits`; ``torque``
        validated by :meth:`check`).
    rate_hz : the bus rate: :meth:`update` steps one period 1/rate_hz.
    q : the commanded joints (k,) rad to start from (at rest unless ``qd``, ``qdd``).
    position_limits : (k, 2) rad; a target velocity is clamped so each joint can still brake
        to rest before them.

    :meth:`update` runs on one thread (the stream's); :meth:`check` may run on another.
    """

    def __init__(self, limits: JointLimits, rate_hz: float, q: ArrayLike, *,
                 qd: ArrayLike | None = None, qdd: ArrayLike | None = None,
                 position_limits: ArrayLike | None = None) -> None:
        q0 = np.array(q, dtype=np.float64).reshape(-1)
        k = len(q0)
        self.k = k
        self.limits = limits
        self.rate_hz = float(rate_hz)
        self.period = 1.0 / self.rate_hz
        self.position_limits = (None if position_limits is None
                                else np.asarray(position_limits, dtype=np.float64))
        zero = np.zeros(k)
        #: (q, q̇, q̈) of the last sample, one tuple (read whole from any thread)
        self.state: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] = (
            q0, zero.copy() if qd is None else np.array(qd, dtype=np.float64),
            zero.copy() if qdd is None else np.array(qdd, dtype=np.float64))
        self.input = Input(target=q0)
        self._jerk = limits.jerk        # inf where a joint has none: Ruckig's 2nd order
        self._otg = Ruckig(k, self.period)
        self._inp = InputParameter(k)
        self._out = OutputParameter(k)
        self._set_state(*self.state)
        self._apply(self.input, self._inp)
        self._lock = threading.Lock()

    # -- the input -------------------------------------------------------------------------

    def _target_velocity(self, inp: Input, scale: float) -> NDArray[np.float64]:
        """q̇* clamped to the scaled velocity limit and to √(2·a·d) toward the position limit
        it heads for (d: the target's distance to it), so the joint can brake in time."""
        if inp.velocity is None:
            return np.zeros(self.k)
        v = np.asarray(inp.velocity, dtype=np.float64)
        vmax = self.limits.v * scale * (1.0 - 1e-9)
        v = np.clip(v, -vmax, vmax)
        if self.position_limits is not None and inp.target is not None:
            a = self.limits.a * scale * scale
            lo, hi = self.position_limits[:, 0], self.position_limits[:, 1]
            target = np.asarray(inp.target, dtype=np.float64)
            up = np.sqrt(2.0 * a * np.maximum(hi - target, 0.0))
            down = np.sqrt(2.0 * a * np.maximum(target - lo, 0.0))
            v = np.clip(v, -down, up)
        return v

    def _target_acceleration(self, inp: Input, scale: float,
                             v: NDArray[np.float64]) -> NDArray[np.float64]:
        """q̈* clamped to the scaled acceleration limit, zero where it cannot settle within
        the velocity limit (:class:`~robodcn.online.state.Input`)."""
        if inp.acceleration is None:
            return np.zeros(self.k)
        amax = self.limits.a * scale * scale * (1.0 - 1e-9)
        a = np.clip(np.asarray(inp.acceleration, dtype=np.float64), -amax, amax)
        settle = np.abs(v) + a * a / (2.0 * self._jerk * scale ** 3)
        return np.where(settle < self.limits.v * scale * (1.0 - 1e-6), a, 0.0)

    def _apply(self, inp: Input, ip: InputParameter) -> None:
        """Write ``inp`` into Ruckig's input parameter ``ip`` (limits scaled by its k)."""
        if inp.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {inp.mode!r}")
        k = float(inp.scale)
        ip.max_velocity = list(self.limits.v * k)
        ip.max_acceleration = list(self.limits.a * k * k)
        ip.max_jerk = list(self._jerk * k ** 3)
        if inp.mode == "stop":
            ip.control_interface = ControlInterface.Velocity
            ip.minimum_duration = None
            ip.target_velocity = [0.0] * self.k
            ip.target_acceleration = [0.0] * self.k
            return
        ip.control_interface = ControlInterface.Position
        ip.minimum_duration = inp.duration
        ip.target_position = list(np.asarray(inp.target, dtype=np.float64))
        v = self._target_velocity(inp, k)
        ip.target_velocity = list(v)
        ip.target_acceleration = list(self._target_acceleration(inp, k, v))

    def _set_state(self, q: NDArray, qd: NDArray, qdd: NDArray) -> None:
        self._inp.current_position = list(q)
        self._inp.current_velocity = list(qd)
        self._inp.current_acceleration = list(qdd)

    # -- one period ------------------------------------------------------------------------

    def update(self, inp: Input | None = None) -> Sample | Infeasible:
        """The commanded state one period on toward ``inp`` (None: the present input).

        A new input is met from the commanded state (q, q̇, q̈) at once: the sample returned
        is already on its law. Infeasible (nothing changes: the state stays, the previous
        input stands) when Ruckig refuses the input or finds no law."""
        if inp is not None and inp is not self.input:
            try:
                self._apply(self._unblocked(inp), self._inp)
            except (ValueError, TypeError) as exc:
                self._apply(self.input, self._inp)
                return Infeasible("input", str(exc))
            previous, self.input = self.input, inp
        else:
            previous = None
        try:
            result = self._otg.update(self._inp, self._out)
        except RuckigError as exc:        # the input's limits or target
            result, why = None, " ".join(str(exc).split())
        else:
            why = f"Ruckig: {result}"
        if result not in _GOOD:
            if previous is not None:
                self.input = previous
                self._apply(previous, self._inp)
            return Infeasible("input" if result is None else "calculation", why)
        out = self._out
        q = np.array(out.new_position)
        qd = np.array(out.new_velocity)
        qdd = np.array(out.new_acceleration)
        out.pass_to_input(self._inp)
        self.state = (q, qd, qdd)
        reached = result == Result.Finished
        remaining = 0.0 if reached else max(0.0, out.trajectory.duration - out.time)
        return Sample(q, qd, qdd, reached, remaining, float(self.input.scale))

    def _unblocked(self, inp: Input) -> Input:
        """``inp``, or ``inp`` with a shorter minimum duration where its own falls in a
        blocked interval of Ruckig's time synchronisation: every joint could arrive sooner,
        but not in about that time (a profile that long would have to overshoot and
        return), and the synchronised law jumps to several times it (over
        :data:`BLOCKED_RATIO`). Tried in turn: the asked duration, one to three periods
        less, none (as soon as the limits allow); the first that is not blocked, else the
        one closest to the asked duration. The target state is then reached a little
        early (a follow session goes on past it at its velocity until the next target)."""
        if inp.duration is None or inp.mode != "target":
            return inp
        best, gap = inp, math.inf
        shorter = [replace(inp, duration=inp.duration - m * self.period) for m in (1, 2, 3)
                   if inp.duration - m * self.period > 0]
        for tried in (inp, *shorter, replace(inp, duration=None)):
            law = self.law(tried)
            if isinstance(law, Infeasible):
                continue
            if law.duration <= BLOCKED_RATIO * inp.duration:
                return tried
            if abs(law.duration - inp.duration) < gap:
                best, gap = tried, abs(law.duration - inp.duration)
        return best

    def reset(self, q: ArrayLike, qd: ArrayLike | None = None,
              qdd: ArrayLike | None = None) -> None:
        """Put the commanded state somewhere else (a stream that resumed elsewhere)."""
        q0 = np.array(q, dtype=np.float64)
        zero = np.zeros(self.k)
        self.state = (q0, zero if qd is None else np.array(qd, dtype=np.float64),
                      zero.copy() if qdd is None else np.array(qdd, dtype=np.float64))
        self._set_state(*self.state)

    # -- the whole law ---------------------------------------------------------------------

    def law(self, inp: Input, state: tuple[NDArray, NDArray, NDArray] | None = None
            ) -> Trajectory | Infeasible:
        """Ruckig's whole law from ``state`` (default: the commanded one) to ``inp``: its
        ``duration`` and ``at_time(t)``. Infeasible where Ruckig refuses it."""
        q, qd, qdd = self.state if state is None else state
        ip = InputParameter(self.k)
        ip.current_position, ip.current_velocity, ip.current_acceleration = (
            list(q), list(qd), list(qdd))
        try:
            self._apply(inp, ip)
        except ValueError as exc:
            return Infeasible("input", str(exc))
        trajectory = Trajectory(self.k)
        with self._lock:            # one Ruckig per generator for whole laws
            otg = getattr(self, "_whole", None)
            if otg is None:
                otg = self._whole = Ruckig(self.k)
            try:
                result = otg.calculate(ip, trajectory)
            except RuckigError as exc:
                return Infeasible("input", " ".join(str(exc).split()))
        if result not in _GOOD:
            return Infeasible("calculation", f"Ruckig: {result}")
        return trajectory

    def check(self, inp: Input) -> Input | Infeasible:
        """``inp`` with the speed scale the torque limits allow (module doc): the first of
        :data:`TORQUE_SCALES` × ``inp.scale`` whose law from the commanded state keeps
        |τ_j| ≤ τ_max,j at every evaluated instant; ``inp`` itself without torque limits.
        Infeasible ("torque", naming the joint, τ and τ_max of the slowest scale's worst
        sample) when none does."""
        torque = self.limits.torque
        if torque is None:
            return inp
        state = self.state
        worst: tuple[int, float, float] | None = None
        for share in TORQUE_SCALES:
            tried = replace(inp, scale=inp.scale * share)
            law = self.law(tried, state)
            if isinstance(law, Infeasible):
                return law
            n = max(2, min(TORQUE_SAMPLES, math.ceil(law.duration / self.period) + 1))
            rows = [law.at_time(float(t)) for t in np.linspace(0.0, law.duration, n)]
            q, qd, qdd = (np.array([r[i] for r in rows]) for i in range(3))
            tau = np.abs(torque.torques(q, qd, qdd))
            over = tau / torque.tau[None, :]
            if not (over > 1.0).any():
                return tried
            s, j = np.unravel_index(int(np.argmax(over)), over.shape)
            worst = (int(j), float(tau[s, j]), float(torque.tau[j]))
        assert worst is not None
        j, value, limit = worst
        return Infeasible("torque", f"joint {j} needs {value:.3g} N·m on the way to the "
                          f"target even at speed scale {inp.scale * TORQUE_SCALES[-1]:.2g}, "
                          f"its limit is {limit:.3g} N·m", joint=j, value=value, limit=limit)


__all__ = ["BLOCKED_RATIO", "TORQUE_SAMPLES", "TORQUE_SCALES", "Generator"]
