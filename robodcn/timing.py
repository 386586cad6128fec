"""Time laws s(τ) on normalised time τ = t/T ∈ [0, 1], and the shortest feasible duration.

Profiles (s(0) = 0, s(1) = 1):

* ``linear``:    s = τ (constant speed; velocity steps at both ends).
* ``quintic``:   s = 10τ³ − 15τ⁴ + 6τ⁵, the minimum-jerk rest-to-rest law (Flash & Hogan
  1985); peak ds/dτ = 15/8 at τ = ½, peak |d²s/dτ²| = 10/√3 at τ = ½ ∓ √3/6.
* ``trapezoid``: constant acceleration for a fraction ρ of the time, cruise, constant
  deceleration (ρ ∈ (0, ½], ρ = ½ is the triangular profile); cruise speed 1/(1 − ρ),
  acceleration 1/(ρ(1 − ρ)). :func:`trapezoid_min_time` gives T and ρ for path-space limits.

Uniform time scaling (design.md §4): a joint path q(τ) run in time T has velocity
(dq/dτ)/T and acceleration (d²q/dτ²)/T², so the shortest T within limits v, a is

    T = max_j max_τ ( |dq_j/dτ| / v_j ,  √(|d²q_j/dτ²| / a_j) )          (:func:`auto_duration`)

and with a jerk limit j (jerk (d³q/dτ³)/T³) also T ≥ ∛(|d³q_j/dτ³| / j_j). A law whose
acceleration steps (trapezoid) or whose velocity steps (linear) has no finite d³q/dτ³: its
sampled jerk is set by the step over one period (about a·rate resp. v·rate²), which depends
on where the steps fall on the sample grid, so its finite-difference need is not monotone
in T (the search's N passes and N − 1 fails; a shorter N may pass again).

and the same law for finite differences of N + 1 samples τ_i = i/N, with Δt = T/N, is
:func:`fd_min_duration`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn.errors import InputError

#: Uniform time laws s(τ) stretched over a whole piece (this module).
UNIFORM_PROFILES = ("linear", "quintic", "trapezoid")
#: Every profile a plan may name: the uniform laws and "optimal", the time-optimal
#: (optionally jerk-limited) law along the path (robodcn.path_timing), the default.
PROFILES = ("optimal", *UNIFORM_PROFILES)
QUINTIC_PEAK_VELOCITY = 15.0 / 8.0
QUINTIC_PEAK_ACCELERATION = 10.0 / math.sqrt(3.0)
DEFAULT_ACCEL_FRACTION = 0.25


def _tau(tau: ArrayLike) -> NDArray[np.float64]:
    tau = _checks.finite("tau", tau)
    if tau.size and (tau.min() < 0.0 or tau.max() > 1.0):
        raise InputError("tau must lie in [0, 1]", field="tau", value=tau)
    return tau


def _fraction(rho: float) -> float:
    rho = float(rho)
    if not 0.0 < rho <= 0.5:
        raise InputError(f"accel_fraction must be in (0, 0.5], got {rho!r}",
                         field="accel_fraction", value=rho)
    return rho


def linear(tau: ArrayLike) -> NDArray[np.float64]:
    """s = τ."""
    return _tau(tau).copy()


def quintic(tau: ArrayLike) -> NDArray[np.float64]:
    """Minimum-jerk s = 10τ³ − 15τ⁴ + 6τ⁵ (zero velocity and acceleration at both ends)."""
    tau = _tau(tau)
    return tau ** 3 * (10.0 + tau * (-15.0 + 6.0 * tau))


def quintic_derivatives(tau: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(ds/dτ, d²s/dτ²) of the quintic: 30τ²(1 − τ)², 60τ(1 − τ)(1 − 2τ)."""
    tau = _tau(tau)
    return 30.0 * tau ** 2 * (1.0 - tau) ** 2, 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau)


def trapezoid(tau: ArrayLike, accel_fraction: float = DEFAULT_ACCEL_FRACTION
              ) -> NDArray[np.float64]:
    """Trapezoidal-velocity s(τ) accelerating for τ < ρ, cruising, decelerating for τ > 1 − ρ.

    With V = 1/(1 − ρ), A = V/ρ: s = ½Aτ² (τ ≤ ρ), ½Aρ² + V(τ − ρ) (cruise),
    1 − ½A(1 − τ)² (τ ≥ 1 − ρ).
    """
    tau = _tau(tau)
    rho = _fraction(accel_fraction)
    v = 1.0 / (1.0 - rho)
    a = v / rho
    head = 0.5 * a * tau * tau
    cruise = 0.5 * a * rho * rho + v * (tau - rho)
    tail = 1.0 - 0.5 * a * (1.0 - tau) ** 2
    return np.where(tau <= rho, head, np.where(tau >= 1.0 - rho, tail, cruise))


def trapezoid_min_time(distance: float, v_max: float, a_max: float) -> tuple[float, float]:
    """Shortest rest-to-rest time over ``distance`` with |v| ≤ v_max, |a| ≤ a_max.

    Returns (T, ρ): T = d/v + v/a with ρ = (v/a)/T when d ≥ v²/a (a cruise phase exists),
    else the triangular T = 2√(d/a), ρ = ½.
    """
    for name, value in (("distance", distance), ("v_max", v_max), ("a_max", a_max)):
        if not math.isfinite(value) or value <= 0.0:
            raise InputError(f"{name} must be positive and finite, got {value!r}", field=name,
                             value=value)
    if distance >= v_max * v_max / a_max:
        total = distance / v_max + v_max / a_max
        return total, (v_max / a_max) / total
    return 2.0 * math.sqrt(distance / a_max), 0.5


def profile(name: str, tau: ArrayLike, accel_fraction: float = DEFAULT_ACCEL_FRACTION
            ) -> NDArray[np.float64]:
    """s(τ) of the named uniform profile ("linear" | "quintic" | "trapezoid").

    "optimal" is not a law of normalised time (it depends on the path and the limits):
    robodcn.path_timing times it.
    """
    _checks.one_of("profile", name, UNIFORM_PROFILES)
    return profile_unchecked(name, _tau(tau), accel_fraction)


def profile_unchecked(name: str, tau: NDArray[np.float64],
                      accel_fraction: float = DEFAULT_ACCEL_FRACTION) -> NDArray[np.float64]:
    """:func:`profile` without the checks of ``name`` and ``tau`` (a uniform profile's name,
    finite float64 τ in [0, 1]): the planner's hot path, its τ built by itself."""
    if name == "linear":
        return tau.copy()
    if name == "quintic":
        return tau ** 3 * (10.0 + tau * (-15.0 + 6.0 * tau))
    return trapezoid(tau, accel_fraction)


def _limits(q: NDArray[np.float64], v_max: ArrayLike, a_max: ArrayLike
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    v = np.asarray(v_max, dtype=np.float64)
    a = np.asarray(a_max, dtype=np.float64)
    if q.ndim != 2 or v.shape != (q.shape[1],) or a.shape != (q.shape[1],):
        raise InputError(f"need q of shape (n, k) and limits of shape (k,), got {q.shape}, "
                         f"{v.shape}, {a.shape}", field="q", value=q.shape)
    return v, a


def auto_duration(dq_dtau: ArrayLike, d2q_dtau2: ArrayLike, v_max: ArrayLike,
                  a_max: ArrayLike, d3q_dtau3: ArrayLike | None = None,
                  j_max: ArrayLike | None = None) -> float:
    """Closed-form shortest T under uniform time scaling (module docstring).

    dq_dtau, d2q_dtau2 : (n, k) derivatives of the joint path with respect to τ.
    v_max, a_max : (k,) joint limits.
    d3q_dtau3, j_max : (n, k) third derivative and (k,) jerk limits (inf: none); both or
        neither. Jerk scales 1/T³: T ≥ ∛(max |d³q/dτ³| / j).
    """
    d1 = np.abs(_checks.finite("dq_dtau", dq_dtau))
    d2 = np.abs(_checks.finite("d2q_dtau2", d2q_dtau2))
    v, a = _limits(d1, v_max, a_max)
    if d1.shape[0] == 0:
        return 0.0
    need = max(np.max(d1.max(axis=0) / v), np.sqrt(np.max(d2.max(axis=0) / a)))
    if (d3q_dtau3 is None) != (j_max is None):
        raise InputError("give d3q_dtau3 and j_max together", field="j_max", value=j_max)
    if j_max is not None:
        d3 = np.abs(_checks.finite("d3q_dtau3", d3q_dtau3))
        j = np.asarray(j_max, dtype=np.float64)
        if d3.shape != d1.shape or j.shape != v.shape:
            raise InputError(f"need d3q_dtau3 of shape {d1.shape} and j_max of shape "
                             f"{v.shape}, got {d3.shape}, {j.shape}", field="j_max",
                             value=j.shape)
        need = max(need, float(np.max(d3.max(axis=0) / j)) ** (1.0 / 3.0))
    return float(need)


def fd_min_duration(q: ArrayLike, v_max: ArrayLike, a_max: ArrayLike, *,
                    at_rest: bool = True, j_max: ArrayLike | None = None) -> float:
    """Shortest T for which N + 1 samples q_i = q(i/N), spaced T/N, pass finite differences.

    Velocity (q_{i} − q_{i−1})·N/T ≤ v and acceleration (q_{i+1} − 2q_i + q_{i−1})·N²/T² ≤ a
    give T ≥ N·max|Δq|/v and T ≥ N·√(max|Δ²q|/a); with ``j_max`` (k,) (inf: no limit) the
    jerk (third difference)·N³/T³ ≤ j gives T ≥ N·∛(max|Δ³q|/j). With ``at_rest`` the arm
    rests before the first and after the last sample (q_{−1} = q_0, q_{N+1} = q_N), as it
    does when a streamed move starts and ends, so a velocity step there counts as an
    acceleration (and, for jerk, as a jerk).
    """
    q = _checks.finite("q", q)
    v, a = _limits(q, v_max, a_max)
    j = None
    if j_max is not None:
        j = np.asarray(j_max, dtype=np.float64)
        if j.shape != v.shape:
            raise InputError(f"j_max must have shape {v.shape}, got {j.shape}", field="j_max",
                             value=j.shape)
    return fd_min_duration_unchecked(q, v, a, at_rest=at_rest, j_max=j)


def fd_min_duration_unchecked(q: NDArray[np.float64], v: NDArray[np.float64],
                              a: NDArray[np.float64], *, at_rest: bool = True,
                              j_max: NDArray[np.float64] | None = None) -> float:
    """:func:`fd_min_duration` without the argument checks: q a finite float64 (n, k)
    array, v, a (and j_max, inf where unlimited, or None) float64 (k,) arrays."""
    n = q.shape[0] - 1
    need = 0.0
    samples = q
    # array methods and slices rather than np.diff / np.max: a search calls this per
    # candidate, where numpy's Python wrappers cost as much as the arithmetic
    if n >= 1:
        d = q[1:] - q[:-1]
        np.abs(d, out=d)
        need = float((d.max(axis=0) / v).max()) * n
        if at_rest:
            q = np.concatenate([q[:1], q, q[-1:]])
    if q.shape[0] >= 3:
        d2 = q[2:] - 2.0 * q[1:-1] + q[:-2]
        np.abs(d2, out=d2)
        need = max(need, n * math.sqrt(float((d2.max(axis=0) / a).max())))
    if j_max is not None:
        j = j_max
        limited = np.isfinite(j)
        if limited.any() and n >= 1:
            p = samples[:, limited]
            if at_rest:
                p = np.concatenate([p[:1], p[:1], p, p[-1:], p[-1:]])
            if p.shape[0] >= 4:
                d3 = np.abs(np.diff(p, n=3, axis=0)).max(axis=0)
                need = max(need, n * float(np.max(d3 / j[limited])) ** (1.0 / 3.0))
    return need
