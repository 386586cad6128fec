"""Time-optimal, jerk-limited timing of a fixed joint path q(s): :func:`time_optimal`.

Jerk-free part: TOPP-RA (H. Pham and Q.-C. Pham, "A New Approach to Time-Optimal Path
Parameterization Based on Reachability Analysis", IEEE T-RO 34(3), 2018) with the per-stage
LPs in closed form (:mod:`robodcn.path_timing.reachability`), discretised by the paper's
"interpolation" scheme (§V-B; :data:`INTERPOLATED`): each stage bounds the joint
acceleration at both of its ends, so samples between grid points keep the limits (the
collocation scheme, constraints at the stage start only, let them pass by up to ~1 %).

Jerk pass: the joint jerk along a path is q''' ṡ³ + 3 q'' ṡ s̈ + q' s⃛. The time-optimal law
s₀ (solved with the acceleration limits scaled by ``accel_share`` and a velocity cap that keeps
|q'''| ṡ³ within half the jerk limit) switches s̈ abruptly; a causal box filter of width w
turns each switch into a constant-jerk ramp (:mod:`robodcn.path_timing.law`, the same shape
as the jerk-limited double-integrator solutions of Kröger's and Berscheid & Kröger's Ruckig
line of work), a dwell of w at every stop keeps the filtered law at rest there, and the joint
velocity, acceleration and jerk of the filtered law are evaluated at the stream rate. From
rest, each piece between stops is timed on its own over a few acceleration shares and windows;
two rounds lower the speed only where a limit is over, and any residual excess is removed by
the uniform stretch λ = max(1, r_v, √r_a, ∛r_j) that divides velocity, acceleration and jerk
by λ, λ², λ³. A curvature corner of the path (a step of q'', as at the planner's C¹ blends) is
a step of joint acceleration Δq'' ṡ² within one stream period, so it is crossed slowly enough
that Δq'' ṡ² × rate stays within the jerk limit (``smooth=True`` skips this for a path known
to be C², as the planner's blends now are: the check reads any fast change of q'' as a
corner). From a moving start (ṡ₀, s̈₀) the filter's
history is chosen so the filtered law starts exactly there, and the limits are shrunk instead
of stretching (a stretch would change ṡ₀).

Known limits: the box filter's overhead is one window (≈ 2a/j) per piece where the
jerk-limited optimum needs about a/j, so the jerk-limited law is not time-optimal (a
third-order phase-plane pass — the jerk-limited TOPP-RA extension of Pham & Pham — is not
built); see the bench (bench/bench_path_timing.py) for the ratios. Through the planner
(C² paths, the configs' jerk 20 a) it beats the quintic ``auto`` under the same jerk limit on
every bench path.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.errors import InputError
from robodcn.path_timing import reachability
from robodcn.path_timing.law import PathTiming

#: stages of the reachability grid at most (the samples are subsampled evenly above this)
MAX_STAGES = 1000
#: TOPP-RA's "interpolation" discretisation (acceleration bounded at both ends of each stage)
INTERPOLATED = True
#: stream rate the jerk pass checks at when the caller gives none, Hz
CHECK_RATE_HZ = 1000.0
#: inner margin of the jerk pass: it aims for (1 - margin) × every limit
JERK_MARGIN = 0.005
_WINDOW_FRACTIONS = (1.0, 0.7, 0.5, 0.35, 0.25)


def _limits(name: str, value: ArrayLike | None, k: int, n: int | None = None
            ) -> NDArray[np.float64]:
    """(k,) per-joint limits, inf where None; with ``n``, (n, k) per-sample limits too."""
    if value is None:
        return np.full(k, np.inf)
    if n is not None and np.ndim(value) == 2:
        raw = np.asarray(value, dtype=np.float64)
        if raw.shape != (n, k):
            raise InputError(f"{name} per sample must have shape ({n}, {k}), got {raw.shape}",
                             field=name, value=raw.shape)
    else:
        raw = np.asarray([np.inf if v is None else v for v in np.atleast_1d(value).tolist()],
                         dtype=np.float64) if np.ndim(value) else np.full(k, float(value))
    if raw.shape != (k,) and not (n is not None and raw.shape == (n, k)):
        raise InputError(f"{name} must have one entry per joint ({k}), got shape {raw.shape}",
                         field=name, value=value)
    if np.isnan(raw).any() or (raw <= 0).any():
        raise InputError(f"{name} must be positive (None = unlimited), got {raw.tolist()}",
                         field=name, value=value)
    return raw


def _number(name: str, value: float, lo: float, hi: float, *, lo_open: bool = False) -> float:
    ok = isinstance(value, int | float | np.floating | np.integer) and math.isfinite(value)
    if ok:
        ok = (lo < value if lo_open else lo <= value) and value <= hi
    if not ok:
        raise InputError(f"{name} must be a number in {'(' if lo_open else '['}{lo:g}, {hi:g}], "
                         f"got {value!r}", field=name, value=value)
    return float(value)


def path_derivatives(q: NDArray[np.float64], s: NDArray[np.float64], cuts: Sequence[int],
                     order: int) -> list[NDArray[np.float64]]:
    """q', q'', … (``order`` of them) by second-order finite differences on the samples.

    The path is differentiated piece by piece between the sample indices ``cuts`` (stops,
    where q' may have a corner); a cut sample takes its outgoing piece's derivatives.
    """
    edges = [0, *sorted(set(int(c) for c in cuts if 0 < c < q.shape[0] - 1)), q.shape[0] - 1]
    out = [np.empty_like(q) for _ in range(order)]
    for a, b in itertools.pairwise(edges):
        f, x = q[a:b + 1], s[a:b + 1]
        for d in range(order):
            f = np.gradient(f, x, axis=0, edge_order=2 if f.shape[0] > 2 else 1)
            out[d][a:b + 1] = f
    return out


def _grid(n: int, stop_idx: NDArray[np.int64], max_stages: int) -> NDArray[np.int64]:
    if n - 1 <= max_stages:
        return np.arange(n)
    even = np.round(np.linspace(0, n - 1, max_stages + 1)).astype(np.int64)
    return np.union1d(even, stop_idx)


def _interpolated(sg: NDArray, dq: NDArray, ddq: NDArray, v: NDArray, a: NDArray
                  ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """The "interpolation" discretisation of TOPP-RA (Pham & Pham 2018, §V-B): stage i also
    bounds the acceleration at its end point, q'_{i+1} u + q''_{i+1} x_{i+1} with
    x_{i+1} = x + 2Δ_i u, i.e. a virtual joint with q' = q'_{i+1} + 2Δ_i q''_{i+1} and
    q'' = q''_{i+1} (no velocity bound of its own: stage i + 1 bounds it). So the law keeps the
    acceleration limits at both ends of every stage, not only at the grid points it starts
    from (collocation), and the stream's samples between grid points stay within them."""
    delta = np.diff(sg)
    nxt_dq = np.vstack([dq[1:], dq[-1:]])
    nxt_ddq = np.vstack([ddq[1:], ddq[-1:]])
    step = np.concatenate([delta, [0.0]])[:, None]
    dq2 = np.hstack([dq, nxt_dq + 2.0 * step * nxt_ddq])
    ddq2 = np.hstack([ddq, nxt_ddq])
    # per-stage limits (N, k) work alike: the virtual joint takes its own stage's limits (the
    # tighter ones where a blend-out window ends and the limits rise along the path)
    return (dq2, ddq2, np.concatenate([v, np.full(v.shape, np.inf)], axis=-1),
            np.concatenate([a, a], axis=-1))


def _solve(sg: NDArray, dq: NDArray, ddq: NDArray, v: NDArray, a: NDArray, extra_cap: NDArray,
           x_start: float, x_end: float) -> tuple[NDArray, NDArray]:
    """x (N + 1,), u (N,) of TOPP-RA on grid sg; raises when the start is not controllable."""
    if INTERPOLATED:
        dq, ddq, v, a = _interpolated(sg, dq, ddq, v, a)
    p_lo, p_hi, r, x_cap = reachability.stage_constraints(dq, ddq, v, a)
    x_cap = np.minimum(x_cap, extra_cap)
    delta = np.diff(sg)
    x_max = reachability.controllable(delta, p_lo, r, x_cap, x_end)
    if x_start > x_max[0] * (1 + 1e-9) + 1e-15:
        raise InputError(f"sd_start {math.sqrt(x_start):.6g} /s is faster than the path allows"
                         f" there: at most {math.sqrt(x_max[0]):.6g} /s can still keep every "
                         "joint within its limits and come to rest by the end",
                         field="sd_start", value=math.sqrt(x_start))
    return reachability.greedy_forward(delta, p_hi, r, x_max, min(x_start, x_max[0]))


def _stage_times(sg: NDArray, x: NDArray) -> NDArray[np.float64]:
    sd = np.sqrt(np.maximum(x, 0.0))
    speed = sd[:-1] + sd[1:]
    if (speed <= 0).any():
        i = int(np.argmax(speed <= 0))
        raise InputError(f"the path cannot move from s = {sg[i]:.6g}: every joint limit forbids"
                         " it (a stop next to a stop, or a zero limit)", field="stops",
                         value=float(sg[i]))
    return 2.0 * np.diff(sg) / speed


def time_optimal(q: ArrayLike, s: ArrayLike, v_max: ArrayLike, a_max: ArrayLike,
                 j_max: ArrayLike | None = None, *, sd_start: float = 0.0,
                 sdd_start: float = 0.0, sd_end: float = 0.0, stops: Sequence[float] = (),
                 rate_hz: float | None = None, scale: float = 1.0,
                 max_stages: int = MAX_STAGES, accel_share: float = 0.95,
                 smooth: bool = False, sd_cap: ArrayLike | None = None) -> PathTiming:
    """Least-duration time law s(t) along the joint path q(s) under per-joint limits.

    Parameters
    ----------
    q : (n, k) joint path samples, radians, at path parameters ``s``
    s : (n,) strictly increasing path parameters (any unit; the law's ṡ is in s per second)
    v_max, a_max : (k,) per-joint velocity (rad/s) and acceleration (rad/s²) limits; None
        entries (or None) = unlimited; without a jerk limit also (n, k), per sample of ``q``
        (a moving start's blend-out window keeps room for its correction there)
    j_max : (k,) per-joint jerk limits (rad/s³), None = no jerk limit (the law's s̈ may step)
    sd_start : path speed ṡ at t = 0 (retargeting from a moving state), ≥ 0
    sdd_start : path acceleration s̈ at t = 0; honoured when jerk is limited (without a jerk
        limit the acceleration may step at once, so it is not needed)
    sd_end : path speed at the end; 0 (to rest) unless jerk is unlimited
    stops : s-values (nearest sample taken) where the path must be at rest (non-blended vias)
    rate_hz : the stream rate the jerk pass checks limits at (default 1 kHz)
    scale : speed scaling k ∈ (0, 1]: limits v·k, a·k², j·k³
    max_stages : reachability grid size at most (samples are subsampled evenly above it)
    accel_share : share of a_max the jerk pass's optimal law may use before filtering
    smooth : the path is C² between stops (as the planner's blends are): the jerk pass then
        skips its curvature-corner caps, which otherwise read every fast change of q''
        between samples as a step (a C¹ corner) and slow the law there
    sd_cap : (n,) the largest ṡ allowed at each sample of ``q`` (a speed scale that must not
        make a slower plan faster: k × its own ṡ), None = none; it bounds the reachability
        sets' ṡ² like a velocity limit of the path itself

    Returns
    -------
    PathTiming
        ``duration``, ``sample(rate_hz)``, ``at(t)``, ``stretch(duration)``.

    Raises
    ------
    InputError
        Bad shapes or values (naming the argument), or a start state from which the path
        cannot be followed within the limits (``sd_start``).
    """
    q = np.asarray(q, dtype=np.float64)
    s = np.asarray(s, dtype=np.float64)
    if q.ndim != 2 or q.shape[0] < 2 or not np.isfinite(q).all():
        raise InputError(f"q must be finite joint samples of shape (n ≥ 2, k), got shape "
                         f"{q.shape}", field="q", value=q.shape)
    n, k = q.shape
    if s.shape != (n,) or not np.isfinite(s).all() or (np.diff(s) <= 0).any():
        raise InputError(f"s must be {n} strictly increasing finite path parameters, got shape "
                         f"{s.shape}", field="s", value=s.shape)
    scale = _number("scale", scale, 0.0, 1.0, lo_open=True)
    v = _limits("v_max", v_max, k, n) * scale
    a = _limits("a_max", a_max, k, n) * scale ** 2
    jerk = j_max is not None and np.isfinite(_limits("j_max", j_max, k)).any()
    if jerk and (v.ndim == 2 or a.ndim == 2):
        raise InputError("per-sample v_max/a_max are not supported with a jerk limit",
                         field="v_max", value=v.shape)
    j = _limits("j_max", j_max, k) * scale ** 3
    sd_start = _number("sd_start", sd_start, 0.0, math.inf)
    sdd_start = _number("sdd_start", sdd_start, -math.inf, math.inf)
    sd_end = _number("sd_end", sd_end, 0.0, math.inf)
    if jerk and sd_end != 0.0:
        raise InputError("sd_end must be 0 (to rest) when jerk is limited", field="sd_end",
                         value=sd_end)
    stop_s = np.atleast_1d(np.asarray(stops, dtype=np.float64))
    if stop_s.size and (not np.isfinite(stop_s).all()
                        or (stop_s <= s[0]).any() or (stop_s >= s[-1]).any()):
        raise InputError(f"stops must lie strictly inside s = {s[0]:g}..{s[-1]:g}, got "
                         f"{stop_s.tolist()}", field="stops", value=stop_s.tolist())
    stop_idx = np.unique(np.abs(s[None, :] - stop_s[:, None]).argmin(axis=1)
                         if stop_s.size else np.empty(0, np.int64))
    derivs = path_derivatives(q, s, stop_idx.tolist(), 3 if jerk else 2)
    grid = _grid(n, stop_idx, max(1, int(max_stages)))
    sg = s[grid]
    dq, ddq = derivs[0][grid], derivs[1][grid]
    cap = np.full(grid.shape[0], np.inf)
    if sd_cap is not None:
        sd_cap = np.asarray(sd_cap, dtype=np.float64)
        if sd_cap.shape != (n,) or np.isnan(sd_cap).any() or (sd_cap < 0).any():
            raise InputError(f"sd_cap must be {n} speeds ≥ 0, got shape {sd_cap.shape}",
                             field="sd_cap", value=sd_cap.shape)
        cap = np.minimum(cap, sd_cap[grid] ** 2)
    cap[np.searchsorted(grid, stop_idx)] = 0.0
    if not jerk:
        v, a = (lim[grid] if lim.ndim == 2 else lim for lim in (v, a))
        x, u = _solve(sg, dq, ddq, v, a, cap, sd_start ** 2, sd_end ** 2)
        dt = _stage_times(sg, x)
        tb = np.concatenate([[0.0], np.cumsum(dt)])
        return PathTiming(tb, sg, np.sqrt(x), u)
    from robodcn.path_timing.jerk import jerk_limited
    return jerk_limited(s, derivs, grid, cap, v, a, j, sd_start=sd_start, sdd_start=sdd_start,
                        stop_idx=stop_idx, rate_hz=rate_hz or CHECK_RATE_HZ,
                        accel_share=accel_share, solve=_solve, stage_times=_stage_times,
                        smooth=smooth)


def max_start_speed(q: ArrayLike, s: ArrayLike, v_max: ArrayLike, a_max: ArrayLike, *,
                    stops: Sequence[float] = (), scale: float = 1.0,
                    max_stages: int = MAX_STAGES) -> float:
    """The fastest ṡ at s[0] from which the path can still be followed within the velocity
    and acceleration limits and brought to rest by the end (or the first stop): √x_max,0 of
    the TOPP-RA controllable set. Without a jerk limit any ``sd_start`` up to it is accepted
    by :func:`time_optimal`; with one, the jerk pass needs room below it."""
    q = np.asarray(q, dtype=np.float64)
    s = np.asarray(s, dtype=np.float64)
    n, k = q.shape
    v = _limits("v_max", v_max, k, n) * scale
    a = _limits("a_max", a_max, k, n) * scale ** 2
    stop_s = np.atleast_1d(np.asarray(stops, dtype=np.float64))
    stop_idx = np.unique(np.abs(s[None, :] - stop_s[:, None]).argmin(axis=1)
                         if stop_s.size else np.empty(0, np.int64))
    dq, ddq = path_derivatives(q, s, stop_idx.tolist(), 2)
    grid = _grid(q.shape[0], stop_idx, max(1, int(max_stages)))
    dq, ddq = dq[grid], ddq[grid]
    v, a = (lim[grid] if lim.ndim == 2 else lim for lim in (v, a))
    if INTERPOLATED:  # the same discretisation as time_optimal's
        dq, ddq, v, a = _interpolated(s[grid], dq, ddq, v, a)
    p_lo, _, r, x_cap = reachability.stage_constraints(dq, ddq, v, a)
    x_cap[np.searchsorted(grid, stop_idx)] = 0.0
    x_max = reachability.controllable(np.diff(s[grid]), p_lo, r, x_cap, 0.0)
    return math.sqrt(float(x_max[0]))
