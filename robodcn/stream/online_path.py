"""A joint path q(σ) of a running execution and the time laws an online operation puts on it.

The path of a running execution is its planned joint samples re-parameterised by joint-space
arc length σ (radians of ‖Δq‖₂; repeated samples, where the plan dwells, are merged), so
q'(σ) is a unit vector wherever the arm moves and a new time law σ(t) re-times the same
geometry. Interior samples where the plan comes to rest (a via without blending: a corner
of q(σ)) are stops, at rest in every law.

Three laws, all sampled at the stream rate:

* :func:`brake` — phase-plane braking (Bobrow, Dubowsky & Gibson, "Time-optimal control of
  robotic manipulators along specified paths", IJRR 4(3), 1985): from the present (σ, σ̇)
  integrate the most negative σ̈ that keeps every joint's acceleration
  q'σ̈ + q''σ̇² within ±a (and, on an arm with torque limits, every joint's torque
  τ = A(σ)σ̈ + B(σ)σ̇² + C(σ) within ±τ_max: :func:`robodcn.dynamics.
  path_torque_coefficients`, the rows TOPP-RA takes), until σ̇ = 0. With the
  semi-implicit step σ̇ₙ₊₁ = σ̇ₙ + uₙΔt, σₙ₊₁ = σₙ + σ̇ₙ₊₁Δt the second difference of σ
  is exactly uₙΔt², so the joints' finite-difference accelerations on the wire are the
  ones the step allowed.
* :func:`retime` — :func:`robodcn.path_timing.time_optimal` (TOPP-RA) on the rest of the
  path from the present σ̇ (speed scaling: limits v·k, a·k², j·k³; a move's tool limits
  (``tool_speed`` …, :mod:`robodcn.path_timing.tool`) join its constraints; the torque limits, which
  are physical, unscaled).

Every law is checked on the joints it sends (:func:`excess`: finite differences at the
stream rate; the torque of each sample from its central differences by
:func:`robodcn.dynamics.inverse_dynamics`, as the planner's validation does) and slowed
until it holds.
* :func:`brake_jerk` — the same brake on an arm with jerk limits: the path acceleration σ̈
  moves at most one sample of the jerk bound per sample (|q'σ⃛ + 3q''σ̇σ̈| ≤ j), down to the
  most negative σ̈ the acceleration limits allow and back up to 0 exactly when σ̇ reaches
  its target: the discrete form of the time-optimal jerk-limited stop of a triple
  integrator (a ramp, a plateau, a ramp; Kröger, "On-Line Trajectory Generation in Robotic
  Systems", Springer 2010, §3, type IV for one degree of freedom), on the path parameter.
* :func:`blend_start` — a new geometric path whose tangent at σ = 0 is the present joint
  velocity direction (a retarget from a moving state): the cubic Hermite correction
  L·b(σ/L)·(d₀ − q'(0)), b(u) = u(1 − u)², added over the first L of the path.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodcn.dynamics import inverse_dynamics, path_torque_coefficients
from robodcn.errors import InputError
from robodcn.path_timing import (
    JointLimits,
    PathTiming,
    max_start_speed,
    path_derivatives,
    time_optimal,
)
from robodcn.path_timing.tool import ToolLimits
from robodcn.path_timing.torque import TorqueLimits
from robodcn.planner import validate

log = logging.getLogger("robodcn.stream")

#: share of each acceleration limit a brake uses (margin for the O(Δt) error of the step)
BRAKE_SHARE = 0.995
#: share of each limit the time-optimal re-timing aims for (the finite differences of the
#: sampled law, linear between path samples, land a little off the continuous optimum)
RETIME_SHARE = 0.97
#: reachability stages of an online re-timing (the law is checked at the stream rate after)
ONLINE_STAGES = 400
#: shares of the limits a checked jerk-limited brake tries before it gives up
BRAKE_TRIES = 6
#: a plan's sample where the joint step is below this (rad) is at rest
REST_STEP = 1e-9


@dataclass(frozen=True)
class JointPath:
    """Joint samples q (m, k) at arc lengths sigma (m,), strictly increasing, with stops."""

    q: NDArray[np.float64]
    sigma: NDArray[np.float64]
    stops: tuple[float, ...] = ()
    #: q'(0) when it is known exactly (a retarget: the direction of motion), else None
    start_tangent: NDArray[np.float64] | None = None
    #: C² between the samples (quintic Hermite on q', q''): a jerk-limited law sees no
    #: curvature steps at the samples of a coarse path (a retarget's geometry from rest)
    smooth: bool = False

    @classmethod
    def of_samples(cls, joints: NDArray[np.float64]) -> tuple[JointPath, NDArray[np.float64]]:
        """The path of planned joint samples and each sample's σ (n,).

        Samples that do not move (the plan dwells) are merged; an interior run of them is a
        stop (the plan is at rest there)."""
        joints = np.asarray(joints, dtype=np.float64)
        step = np.linalg.norm(np.diff(joints, axis=0), axis=1)
        sample_sigma = np.concatenate([[0.0], np.cumsum(step)])
        keep = np.concatenate([[True], step > REST_STEP])
        q, sigma = joints[keep], sample_sigma[keep]
        if q.shape[0] < 2:
            return cls(np.vstack([q[:1], q[:1]]), np.array([0.0, 1.0])), np.zeros(len(joints))
        # a stop: the plan's speed falls to (near) zero between two moving stretches
        speed = np.concatenate([[0.0], step, [0.0]])
        rest = (speed[1:-1] <= REST_STEP)
        stops = []
        for i in np.flatnonzero(rest[1:-1]) + 1:
            s = float(sample_sigma[i])
            if sigma[0] < s < sigma[-1] and (not stops or s - stops[-1] > 1e-9):
                stops.append(s)
        # local minima of the step that are near rest also stop (quintic vias)
        if step.size > 2:
            peak = step.max()
            mins = np.flatnonzero((step[1:-1] < step[:-2]) & (step[1:-1] <= step[2:])
                                  & (step[1:-1] < 1e-3 * peak)) + 1
            for i in mins:
                s = float(sample_sigma[i])
                if sigma[0] < s < sigma[-1] and all(abs(s - t) > 1e-6 for t in stops):
                    stops.append(s)
        return cls(q, sigma, tuple(sorted(stops))), sample_sigma

    @property
    def length(self) -> float:
        return float(self.sigma[-1])

    def at(self, sigma: NDArray[np.float64]) -> NDArray[np.float64]:
        """q(σ) (len(σ), k): cubic Hermite between samples on q' (C¹, so the curvature of
        the path is spread over each interval instead of sitting at the samples)."""
        sigma = np.clip(np.asarray(sigma, dtype=np.float64), self.sigma[0], self.sigma[-1])
        i = np.clip(np.searchsorted(self.sigma, sigma, side="right") - 1, 0,
                    len(self.sigma) - 2)
        h = self.sigma[i + 1] - self.sigma[i]
        u = ((sigma - self.sigma[i]) / h)[:, None]
        dq = self._tangents()
        u2, u3 = u * u, u * u * u
        hh = h[:, None]
        if self.smooth:
            # quintic Hermite on q, q', q'' at both ends of the interval
            ddq = self._curvatures()
            u4, u5 = u3 * u, u3 * u2
            return ((1 - 10 * u3 + 15 * u4 - 6 * u5) * self.q[i]
                    + (u - 6 * u3 + 8 * u4 - 3 * u5) * hh * dq[i]
                    + (0.5 * u2 - 1.5 * u3 + 1.5 * u4 - 0.5 * u5) * hh * hh * ddq[i]
                    + (0.5 * u3 - u4 + 0.5 * u5) * hh * hh * ddq[i + 1]
                    + (-4 * u3 + 7 * u4 - 3 * u5) * hh * dq[i + 1]
                    + (10 * u3 - 15 * u4 + 6 * u5) * self.q[i + 1])
        h00, h10, h01, h11 = 2 * u3 - 3 * u2 + 1, u3 - 2 * u2 + u, -2 * u3 + 3 * u2, u3 - u2
        return (h00 * self.q[i] + h10 * hh * dq[i] + h01 * self.q[i + 1]
                + h11 * hh * dq[i + 1])

    def _curvatures(self) -> NDArray[np.float64]:
        cached = self.__dict__.get("_ddq")
        if cached is None:
            cached = self.derivatives()[1]
            object.__setattr__(self, "_ddq", cached)
        return cached

    def _tangents(self) -> NDArray[np.float64]:
        cached = self.__dict__.get("_dq")
        if cached is None:
            cached = self.derivatives()[0]
            if self.start_tangent is not None:
                cached[0] = self.start_tangent
            object.__setattr__(self, "_dq", cached)
        return cached

    def rest_from(self, sigma0: float) -> tuple[NDArray, NDArray, tuple[float, ...]]:
        """q, σ and stops of the path from σ₀ on (σ₀ itself the first sample)."""
        after = self.sigma > sigma0 + 1e-12
        q = np.vstack([self.at(np.array([sigma0])), self.q[after]])
        s = np.concatenate([[sigma0], self.sigma[after]])
        if s.shape[0] < 2:
            return q, s, ()
        stops = tuple(t for t in self.stops if s[0] + 1e-9 < t < s[-1] - 1e-9)
        return q, s, stops

    def derivatives(self, order: int = 2) -> tuple[NDArray, ...]:
        """q'(σ), q''(σ) (and q''' with ``order`` 3) at the samples (piecewise between
        stops)."""
        cuts = [int(np.argmin(np.abs(self.sigma - t))) for t in self.stops]
        return tuple(path_derivatives(self.q, self.sigma, cuts, order))


class LawExceedsLimits(InputError):
    """A sampled law keeps exceeding a joint limit (``excess``: the worst ratio to it) at
    every share of the limits tried."""

    def __init__(self, message: str, excess: float) -> None:
        super().__init__(message, field="limits", value=float(excess))
        self.excess = float(excess)


#: the arm's joint limits (:class:`robodcn.path_timing.JointLimits`, ``JointLimits.of(arm)``)
Limits = JointLimits  # re-export (transitional): the old name of the one JointLimits


def brake(path: JointPath, sigma0: float, sd0: float, a: NDArray[np.float64], rate_hz: float,
          *, until_sd: float = 0.0, max_samples: int = 1_000_000,
          torque: TorqueLimits | None = None) -> NDArray[np.float64]:
    """σ of the samples after (σ₀, σ̇₀) of the fastest brake along the path (module doc).

    Ends at the first sample with σ̇ ≤ ``until_sd`` (0: at rest; the last σ then repeats no
    earlier one). Uses ``BRAKE_SHARE`` of ``a``; ``torque`` (None: none) bounds σ̈ by the
    torque rows A σ̈ + B σ̇² + C within ±τ_max as given (a share is the caller's:
    :func:`brake_checked`). Returns σ (m,), m ≥ 0.
    """
    dt = 1.0 / rate_hz
    derivs = path.derivatives()
    rows = None if torque is None else torque_coefficients(path, torque)
    grid = path.sigma
    amax = np.asarray(a, dtype=np.float64) * BRAKE_SHARE
    out: list[float] = []
    s, sd = float(sigma0), float(sd0)
    while sd > until_sd and len(out) < max_samples:
        d1, d2 = _local(derivs, grid, s)
        lo = _bounds(d1, d2 * sd * sd, amax)[0]
        t_lo = -math.inf
        if rows is not None:
            ta, tb, tc = _local(rows, grid, s)
            t_lo = _bounds(ta, tb * sd * sd + tc, torque.tau)[0]
            lo = max(lo, t_lo)
        u = min(lo, 0.0)
        nxt = sd + u * dt
        if nxt <= until_sd or not math.isfinite(nxt):
            if until_sd > 0.0:
                nxt = until_sd
            else:
                # the last step to rest has no centripetal part: |q'|·σ̇/Δt within a
                # (and A·(−σ̇/Δt) + C within the torque limits)
                final = _bounds(d1, np.zeros_like(d1), amax)[1] * dt
                if rows is not None:
                    final = min(final, max(-_bounds(ta, tc, torque.tau)[0], 0.0) * dt)
                if sd <= final:
                    break
                nxt = final
        sd = nxt
        s = min(s + sd * dt, path.length)
        out.append(s)
        if s >= path.length:
            break
    return np.asarray(out, dtype=np.float64)


def brake_checked(path: JointPath, sigma0: float, sd0: float, a: NDArray[np.float64],
                  rate_hz: float, torque: TorqueLimits | None,
                  history: NDArray[np.float64] | None = None, *,
                  until_sd: float = 0.0) -> NDArray[np.float64]:
    """:func:`brake` under ``torque`` (None: exactly :func:`brake`), checked on the joints
    it sends after ``history`` (the commanded samples up to the switch, or None) by
    :func:`torque_excess`: the torque limits' share is lowered until every sample holds
    (the chords between samples and the σ̇ of a central difference land a little off the
    rows' model); the last share tried when none within :data:`BRAKE_TRIES` does (a
    warning: a stop is not refused)."""
    if torque is None:
        return brake(path, sigma0, sd0, a, rate_hz, until_sd=until_sd)
    share = BRAKE_SHARE
    for _ in range(BRAKE_TRIES):
        out = brake(path, sigma0, sd0, a, rate_hz, until_sd=until_sd,
                    torque=torque.shrunk(share))
        if not out.size:
            return out
        joints = path.at(out) if history is None else np.vstack([history, path.at(out)])
        over = torque_excess(joints, torque, rate_hz, to_rest=until_sd <= 0.0)
        if over <= 1.0:
            return out
        share *= 0.99 / over
    log.warning("brake: %.4g × a torque limit at every share tried (gravity alone may "
                "need that much here); braking with the last", over)
    return out


def torque_coefficients(path: JointPath, torque: TorqueLimits
                        ) -> tuple[NDArray, NDArray, NDArray]:
    """(A, B, C) (m, k) at the path samples: τ = A σ̈ + B σ̇² + C
    (:func:`robodcn.dynamics.path_torque_coefficients` on q, q′, q″; kept per payload)."""
    key = (id(torque.chain), torque.payload_kg)
    cached = path.__dict__.get("_abc")
    if cached is None or cached[0] != key:
        d1, d2 = path.derivatives()
        cached = (key, path_torque_coefficients(torque.chain, path.q, d1, d2,
                                                torque.payload_kg))
        object.__setattr__(path, "_abc", cached)
    return cached[1]


def torque_excess(joints: NDArray[np.float64], torque: TorqueLimits, rate_hz: float, *,
                  to_rest: bool = True) -> float:
    """Largest |τ|/τ_max of the samples of ``joints`` (at ``rate_hz``; with ``to_rest`` the
    arm holds the last sample after): τ of each interior sample q_i from the central
    differences q̇ = (q_{i+1} − q_{i−1})·rate/2, q̈ = (q_{i+1} − 2q_i + q_{i−1})·rate²
    (:func:`robodcn.dynamics.inverse_dynamics`: links, payload, gravity, rotor inertia), as
    the planner's validation charges it. ≤ 1 when every torque limit holds."""
    q = np.vstack([joints, joints[-1:], joints[-1:]]) if to_rest else joints
    if q.shape[0] < 3:
        return 0.0
    mid = q[1:-1]
    qd = (q[2:] - q[:-2]) * (0.5 * rate_hz)
    qdd = (q[2:] - 2.0 * mid + q[:-2]) * (rate_hz * rate_hz)
    tau = inverse_dynamics(torque.chain, mid, qd, qdd, torque.payload_kg)
    return float((np.abs(tau) / torque.tau).max())


def _local(derivs: tuple[NDArray, ...], grid: NDArray, s: float) -> list[NDArray]:
    """q'(σ), q''(σ), … linearly interpolated between the path samples."""
    i = min(max(int(np.searchsorted(grid, s, side="right")) - 1, 0), len(grid) - 2)
    w = min(max((s - grid[i]) / (grid[i + 1] - grid[i]), 0.0), 1.0)
    return [d[i] + w * (d[i + 1] - d[i]) for d in derivs]


def _bounds(d1: NDArray, c: NDArray, limit: NDArray) -> tuple[float, float]:
    """The interval of x with |d1_i x + c_i| ≤ limit_i for every moving joint i."""
    moving = np.abs(d1) > 1e-9
    if not moving.any():
        return -math.inf, math.inf
    d, cc, lim = d1[moving], c[moving], limit[moving]
    one, two = (-lim - cc) / d, (lim - cc) / d
    return float(np.minimum(one, two).max()), float(np.maximum(one, two).min())


def _ramp_loss(u: float, up: float, dt: float) -> float:
    """σ̇ lost while σ̈ = u < 0 ramps back to 0 by ``up``·Δt a sample (the σ̈ after this
    sample's: k = 1 … K, the last one clipped to 0)."""
    if u >= 0.0:
        return 0.0
    n = math.ceil(-u / (up * dt) - 1e-12)
    return -dt * ((n - 1) * u + up * dt * (n - 1) * n / 2.0)


def brake_jerk(path: JointPath, sigma0: float, sd0: float, sdd0: float, limits: JointLimits,
               rate_hz: float, *, until_sd: float = 0.0, share: float = BRAKE_SHARE,
               max_samples: int = 1_000_000) -> NDArray[np.float64] | None:
    """σ of the samples after (σ₀, σ̇₀, σ̈₀) of the fastest jerk-limited brake (module doc).

    Each sample chooses σ̈ₙ: as low as the acceleration bound (|q'σ̈ + q''σ̇²| ≤ a; with
    ``limits.torque`` also |Aσ̈ + Bσ̇² + C| ≤ τ_max, :func:`torque_coefficients`) and the
    jerk bound from σ̈ₙ₋₁ (|q'(σ̈ₙ − σ̈ₙ₋₁)/Δt + 3q''σ̇σ̈ₙ₋₁ + q'''σ̇³| ≤ j) allow, but no lower than
    the ramp back to σ̈ = 0 can recover: σ̇ₙ − loss(σ̈ₙ) ≥ ``until_sd`` (the velocity a ramp
    at the jerk bound takes, :func:`_ramp_loss`, from the quadratic's root). What rounding
    leaves of σ̇ at the end is spread over the last ramp (a constant on its σ̈, so its jerk
    barely changes) and the brake ends at exactly ``until_sd`` with σ̈ = 0. Steps as
    :func:`brake` (σ̇ₙ = σ̇ₙ₋₁ + σ̈ₙΔt, σₙ = σₙ₋₁ + σ̇ₙΔt: the wire's finite differences are
    these σ̈ and their jerk). ``share`` of every limit is used.

    Returns σ (m,), or None when the path ends before the brake can (the move's own end is
    then the fastest stop)."""
    dt = 1.0 / rate_hz
    derivs = path.derivatives(3)
    grid = path.sigma
    amax, jmax = limits.a * share, limits.j * share
    torque = None if limits.torque is None else limits.torque.shrunk(share)
    rows = None if torque is None else torque_coefficients(path, torque)
    s, sd, u = float(sigma0), float(sd0), float(sdd0)
    accel: list[float] = []
    ramp_start = 0
    rising = False
    while sd > until_sd + 1e-12 or u < 0.0:
        if len(accel) >= max_samples:
            raise InputError("the jerk-limited brake did not come to rest",
                             field="sd_start", value=sd0)
        d1, d2, d3 = _local(derivs, grid, s)
        a_lo, _ = _bounds(d1, d2 * sd * sd, amax)
        if rows is not None:
            ta, tb, tc = _local(rows, grid, s)
            a_lo = max(a_lo, _bounds(ta, tb * sd * sd + tc, torque.tau)[0])
        w_lo, w_hi = _bounds(d1, 3.0 * d2 * sd * u + d3 * sd ** 3, jmax)
        w_lo, w_hi = min(w_lo, 0.0), max(w_hi, 1e-9)
        hi = u + w_hi * dt
        if u < 0.0:
            hi = min(hi, 0.0)
        lo = min(max(u + w_lo * dt, a_lo), hi)
        # the most negative σ̈ from which a ramp back at w_hi ends at until_sd:
        # σ̇ + σ̈Δt − loss(σ̈) = until_sd with loss ≈ σ̈²/(2 w_hi) − σ̈Δt/2
        b = 1.5 * dt
        root = w_hi * (b - math.sqrt(b * b + 2.0 * max(sd - until_sd, 0.0) / w_hi))
        nxt = min(max(root, lo), hi)
        if nxt > u and not rising:
            ramp_start = len(accel)
        rising = nxt > u
        u = nxt
        sd += u * dt
        accel.append(u)
        if sd <= until_sd:
            break
        s += sd * dt
        if s >= path.length:
            return None
    u_arr = np.asarray(accel, dtype=np.float64)
    if not u_arr.size:
        return np.zeros(0)
    # what rounding leaves of σ̇ at the end, spread over the last ramp: σ̇ ends at until_sd
    residual = sd0 + float(u_arr.sum()) * dt - until_sd
    tail = max(len(u_arr) - ramp_start, 1)
    u_arr[-tail:] -= residual / (tail * dt)
    sd_n = sd0 + np.cumsum(u_arr) * dt
    sigma = sigma0 + np.cumsum(sd_n) * dt
    if until_sd <= 0.0 and sigma.size > 1:
        sigma = sigma[:-1]  # σ̇ = 0 there: the hold that follows repeats the sample before
    if sigma.size and sigma[-1] >= path.length:
        return None
    return sigma


def brake_jerk_checked(path: JointPath, sigma0: float, sd0: float, sdd0: float,
                       limits: JointLimits, rate_hz: float, history: NDArray[np.float64], *,
                       until_sd: float = 0.0) -> NDArray[np.float64] | None:
    """:func:`brake_jerk`, checked on the joints it sends after ``history`` (the three
    commanded samples up to the switch): the finite differences also see the curvature
    steps of the sampled path between its samples, which the law's model leaves out, so
    the share of the limits is lowered until every velocity, acceleration and jerk holds.

    Raises
    ------
    LawExceedsLimits
        no share within :data:`BRAKE_TRIES` keeps them."""
    share, over = BRAKE_SHARE, math.inf
    for _ in range(BRAKE_TRIES):
        out = brake_jerk(path, sigma0, sd0, sdd0, limits, rate_hz, until_sd=until_sd,
                         share=share)
        if out is None or not out.size:
            return out
        over = excess(np.vstack([history, path.at(out)]), limits, rate_hz,
                      to_rest=until_sd <= 0.0)
        if over <= 1.0:
            return out
        share *= 0.99 / over
    raise LawExceedsLimits(f"the jerk-limited brake keeps exceeding a joint limit "
                           f"({over:.4g} × it)", over)


def controllable_speed(path: JointPath, sigma0: float, limits: JointLimits, *,
                       max_stages: int | None = None) -> float:
    """The fastest σ̇ at σ₀ from which the rest of the path can still be followed within
    ``limits`` and brought to rest (:func:`robodcn.path_timing.max_start_speed`)."""
    q, s, stops = path.rest_from(sigma0)
    if s.shape[0] < 3:
        return 0.0
    return max_start_speed(q, s, limits.v, limits.a, stops=stops,
                           max_stages=ONLINE_STAGES if max_stages is None else max_stages,
                           **_torque_kw(limits.torque), **_tool_kw(limits.tool))


def retime(path: JointPath, sigma0: float, sd0: float, limits: JointLimits, rate_hz: float,
           *, sdd0: float = 0.0, history: NDArray[np.float64] | None = None,
           sd_cap: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None
           ) -> NDArray[np.float64]:
    """σ of the samples after (σ₀, σ̇₀, σ̈₀) of the time-optimal law to rest at the path's
    end (σ̈₀ counts with jerk limits only). The law is checked on the joints it sends after
    ``history`` (the commanded samples up to σ₀; by default two on the tangent at σ̇₀).
    ``sd_cap`` maps σ to the largest σ̇ allowed there (:func:`time_optimal`'s ``sd_cap``).

    Raises
    ------
    InputError
        σ̇₀ faster than the rest of the path allows (``sd_start``; brake first);
        LawExceedsLimits when the sampled law keeps exceeding a limit.
    """
    q, s, stops = path.rest_from(sigma0)
    if s.shape[0] < 3 or s[-1] - s[0] < 1e-9:
        return np.zeros(0)
    here = path.at(np.array([sigma0]))[0]
    tangent = path._tangents()[min(int(np.searchsorted(path.sigma, sigma0)), len(path.sigma) - 1)]
    start = np.vstack([here - tangent * sd0 / rate_hz, here]) if history is None else history
    share = RETIME_SHARE
    for _ in range(4):
        v, a = limits.v * share, limits.a * share
        j = None if limits.j is None else limits.j * share
        torque = None if limits.torque is None else limits.torque.shrunk(share)
        tool = None if limits.tool is None else limits.tool.shrunk(share)
        law = _law(q, s, v, a, j, sd0, sdd0 if limits.j is not None else 0.0, stops,
                   rate_hz, None if sd_cap is None else sd_cap(s), torque, tool)
        out = law.sample(rate_hz).s[1:]
        # the final samples may sit at the end within rounding: keep one
        end = np.flatnonzero(out >= s[-1] - 1e-12)
        if end.size:
            out = out[:end[0] + 1]
            out[-1] = s[-1]
        over = excess(np.vstack([start, path.at(out)]), limits, rate_hz)
        if over <= 1.0:
            return out
        share *= 0.995 / over
    raise LawExceedsLimits(f"the re-timed path keeps exceeding a joint limit ({over:.4g} × "
                           "it)", over)


def excess(joints: NDArray[np.float64], limits: JointLimits, rate_hz: float, *,
           to_rest: bool = True) -> float:
    """Largest ratio of a finite-difference joint velocity, acceleration or (with jerk
    limits) jerk of ``joints`` (sampled at ``rate_hz``; with ``to_rest`` the arm holds the
    last sample after) to its limit, and (with ``limits.torque``) of a sample's torque
    (:func:`torque_excess`): ≤ 1 when every limit holds. The jerk needs four
    samples: give the three commanded before a switch first to check across it."""
    q = np.vstack([joints, joints[-1:], joints[-1:]]) if to_rest else joints
    if q.shape[0] < 3:
        return 0.0
    vel = np.diff(q, axis=0) * rate_hz
    acc = np.diff(vel, axis=0) * rate_hz
    worst = max((np.abs(vel) / limits.v).max(), (np.abs(acc) / limits.a).max())
    if limits.j is not None and acc.shape[0] > 1:
        worst = max(worst, (np.abs(np.diff(acc, axis=0)) * rate_hz / limits.j).max())
    if limits.torque is not None:
        worst = max(worst, torque_excess(joints, limits.torque, rate_hz, to_rest=to_rest))
    if limits.tool is not None:
        worst = max(worst, tool_excess(joints, limits.tool, rate_hz, to_rest=to_rest))
    return float(worst)


def tool_excess(joints: NDArray[np.float64], tool: ToolLimits, rate_hz: float, *,
                to_rest: bool = True) -> float:
    """Largest ratio of the tool point's finite-difference speed, orientation rate or
    acceleration along its path to its limit (:func:`robodcn.planner.validate.tool_ratios`,
    after the first sample, which the ratios count from rest), ≤ 1 when every one holds;
    with ``to_rest`` the arm holds the last sample after."""
    q = np.vstack([joints, joints[-1:]]) if to_rest else joints
    if q.shape[0] < 3:
        return 0.0
    ratios = validate.tool_ratios(tool, q, rate_hz)
    return max((float(r[2:].max()) if r.shape[0] > 2 else 0.0 for r in ratios.values()),
               default=0.0)


def _law(q: NDArray, s: NDArray, v: NDArray, a: NDArray, j: NDArray | None, sd0: float,
         sdd0: float, stops: Sequence[float], rate_hz: float,
         sd_cap: NDArray | None = None, torque: TorqueLimits | None = None,
         tool: ToolLimits | None = None) -> PathTiming:
    """time_optimal from σ̇₀ (under ``torque`` and ``tool`` too); a σ̇₀ over the
    controllable speed by rounding only (1e-3) starts at that speed instead (a larger excess
    is raised: brake first)."""
    extra = {**_torque_kw(torque), **_tool_kw(tool)}
    try:
        return time_optimal(q, s, v, a, j, sd_start=sd0, sdd_start=sdd0, stops=stops,
                            rate_hz=rate_hz, max_stages=ONLINE_STAGES, sd_cap=sd_cap,
                            **extra)
    except InputError:
        # (time_optimal refuses a σ̇₀ above the controllable speed before anything else:
        # within rounding of it, start at it)
        top = controllable_at(q, s, v, a, stops, torque, tool)
        if not top < sd0 <= top * 1.001:
            raise
        return time_optimal(q, s, v, a, j, sd_start=top, sdd_start=sdd0, stops=stops,
                            rate_hz=rate_hz, max_stages=ONLINE_STAGES, sd_cap=sd_cap,
                            **extra)


def controllable_at(q: NDArray, s: NDArray, v: NDArray, a: NDArray,
                    stops: Sequence[float], torque: TorqueLimits | None = None,
                    tool: ToolLimits | None = None) -> float:
    """max_start_speed of (q, s) under v, a, ``torque`` and ``tool`` (the start speed
    time_optimal accepts)."""
    return max_start_speed(q, s, v, a, stops=stops, max_stages=ONLINE_STAGES,
                           **_torque_kw(torque), **_tool_kw(tool))


def _torque_kw(torque: TorqueLimits | None) -> dict[str, TorqueLimits]:
    """``torque=`` for the path timing when there are torque limits (none otherwise: an arm
    without them is timed by exactly the call it always was)."""
    return {} if torque is None else {"torque": torque}


def _tool_kw(tool: ToolLimits | None) -> dict[str, ToolLimits]:
    """``tool=`` for the path timing when the move has tool limits (none otherwise)."""
    return {} if tool is None else {"tool": tool}


def blend_start(q_new: NDArray[np.float64], direction: NDArray[np.float64],
                length: float) -> NDArray[np.float64]:
    """Joint samples of ``q_new`` bent to start along ``direction`` and straight.

    q(σ) + L·b(σ/L)·(d₀ − q'(0)), b(u) = u(1 − u)² (b(0) = 0, b'(0) = 1, b(1) = b'(1) = 0),
    then minus L²·c(σ/L)·q''(0) of that curve, c(u) = u²(1 − u)³/2 (c''(0) = 1, zero with
    two derivatives at 1): the path starts at q(0) in the direction d₀ with no curvature and
    is unchanged after arc length L (σ measured on ``q_new``). No curvature at the start
    matters at the switch: the last two samples streamed lie on the chord d₀, so a
    curved start would add ½·q''·σ̇² to the joint acceleration of the first new sample."""
    path, _ = JointPath.of_samples(q_new)
    if path.length <= 0 or length <= 0:
        return q_new
    step = np.linalg.norm(np.diff(q_new, axis=0), axis=1)
    sig = np.concatenate([[0.0], np.cumsum(step)])
    u = np.clip(sig / length, 0.0, 1.0)[:, None]
    dq, _ = path.derivatives()
    bent = q_new + length * u * (1.0 - u) ** 2 * (np.asarray(direction) - dq[0])[None, :]
    _, ddq = JointPath(bent, sig).derivatives()
    return bent - length ** 2 * 0.5 * u ** 2 * (1.0 - u) ** 3 * ddq[0][None, :]


def evenly_spaced(q: NDArray[np.float64], count: int) -> NDArray[np.float64]:
    """The samples of ``q`` (n, k) at least 1/``count`` of its arc length apart (the first
    and the last always kept): a path's own points, no longer crowded where it was slow."""
    step = np.linalg.norm(np.diff(q, axis=0), axis=1)
    sigma = np.concatenate([[0.0], np.cumsum(step)])
    gap = sigma[-1] / count
    if gap <= 0.0:
        return q
    keep = [0]
    for i in range(1, len(q) - 1):
        if sigma[i] - sigma[keep[-1]] >= gap and sigma[-1] - sigma[i] >= 0.5 * gap:
            keep.append(i)
    keep.append(len(q) - 1)
    return q[keep]


def check_limits_named(name: str, value: float) -> float:
    """A speed scale k ∈ (0, 1] (InputError naming ``name`` otherwise)."""
    ok = isinstance(value, int | float) and not isinstance(value, bool) \
        and math.isfinite(value) and 0.0 < value <= 1.0
    if not ok:
        raise InputError(f"{name} must be a number in (0, 1], got {value!r}", field=name,
                         value=value)
    return float(value)
