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
that Δq'' ṡ² × rate stays within the jerk limit; a corner is a change of q'' that stands
out of its neighbourhood's (:func:`~robodcn.path_timing.jerk.corner_jumps`), not a smooth
path's steady change (``smooth=True`` skips the search for a path known to be C², as the
planner's blends now are). From a moving start (ṡ₀, s̈₀) the filter's
history is chosen so the filtered law starts exactly there, and the limits are shrunk instead
of stretching (a stretch would change ṡ₀).

Known limits: the box filter's overhead is one window (≈ 2a/j) per piece where the
jerk-limited optimum needs about a/j, so the jerk-limited law is not time-optimal (a
third-order phase-plane pass — the jerk-limited TOPP-RA extension of Pham & Pham — is not
built); see the bench (bench/bench_path_timing.py) for the ratios. Under a tight jerk limit
that overhead outweighs what the optimum saves, so each rest-to-rest piece (without a
caller's ``sd_cap``) also tries the fastest uniform quintic in s within the same limits
(:mod:`robodcn.path_timing.quintic_law`) and keeps the faster. Through the planner (C²
paths, the configs' jerk 20 a) the filtered law beats the quintic ``auto`` under the same
jerk limit on every bench path.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.errors import InputError
from robodcn.path_timing import reachability
from robodcn.path_timing.jerk import jerk_limited
from robodcn.path_timing.law import PathTiming
from robodcn.path_timing.tool import ToolLimits
from robodcn.path_timing.topp import (
    INTERPOLATED,
    MAX_STAGES,
    check_limits,
    check_number,
    derivatives,
    grid_of,
    interpolated,
    interpolated_rows,
    path_derivatives,
    solve,
    timed_stages,
)
from robodcn.path_timing.torque import TorqueLimits, TorqueRows

#: stream rate the jerk pass checks at when the caller gives none, Hz
CHECK_RATE_HZ = 1000.0
#: no stops (read-only, shared)
_NO_STOPS = np.empty(0)
_NO_STOPS.setflags(write=False)
_NO_STOP_IDX = np.empty(0, np.int64)
_NO_STOP_IDX.setflags(write=False)


def time_optimal(q: ArrayLike, s: ArrayLike, v_max: ArrayLike, a_max: ArrayLike,
                 j_max: ArrayLike | None = None, *, sd_start: float = 0.0,
                 sdd_start: float = 0.0, sd_end: float = 0.0, stops: Sequence[float] = (),
                 rate_hz: float | None = None, scale: float = 1.0,
                 max_stages: int = MAX_STAGES, accel_share: float = 0.95,
                 smooth: bool = False, sd_cap: ArrayLike | None = None,
                 torque: TorqueLimits | None = None, tool: ToolLimits | None = None
                 ) -> PathTiming:
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
    torque : joint torque limits with the arm's dynamics and payload
        (:class:`~robodcn.path_timing.torque.TorqueLimits`): |τ(q, q̇, q̈)| ≤ τ_max on every
        joint as the linear rows of τ = a s̈ + b ṡ² + c (the scale applies to a s̈ + b ṡ²);
        None = no torque limit
    tool : the tool point's limits (:class:`~robodcn.path_timing.tool.ToolLimits`): its
        speed and orientation rate as caps on ṡ² (|p′| ṡ ≤ v_tool), its acceleration along
        the path as a row −a ≤ σ′ s̈ + σ″ ṡ² ≤ a beside the torque rows (the scale applies:
        k, k²); None = none. Tool derivatives are computed only when given

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
    # (.all() without its wrapper)
    if q.ndim != 2 or q.shape[0] < 2 or not np.logical_and.reduce(np.isfinite(q), axis=None):
        raise InputError(f"q must be finite joint samples of shape (n ≥ 2, k), got shape "
                         f"{q.shape}", field="q", value=q.shape)
    n, k = q.shape
    # finite ends and every step > 0 (NaN fails it): every entry finite and increasing
    if (s.shape != (n,) or not (math.isfinite(s[0]) and math.isfinite(s[-1]))
            or not np.logical_and.reduce(s[1:] > s[:-1])):
        raise InputError(f"s must be {n} strictly increasing finite path parameters, got shape "
                         f"{s.shape}", field="s", value=s.shape)
    scale = check_number("scale", scale, 0.0, 1.0, lo_open=True)
    v = check_limits("v_max", v_max, k, n)
    a = check_limits("a_max", a_max, k, n)
    if scale != 1.0:  # (fresh arrays either way: check_limits returns its own)
        v, a = v * scale, a * scale ** 2
    # checked once (None: unlimited, no jerk pass)
    j = check_limits("j_max", j_max, k) if j_max is not None else None
    jerk = j is not None and bool(np.isfinite(j).any())
    if jerk and (v.ndim == 2 or a.ndim == 2):
        raise InputError("per-sample v_max/a_max are not supported with a jerk limit",
                         field="v_max", value=v.shape)
    sd_start = check_number("sd_start", sd_start, 0.0, math.inf)
    sdd_start = check_number("sdd_start", sdd_start, -math.inf, math.inf)
    sd_end = check_number("sd_end", sd_end, 0.0, math.inf)
    if jerk and sd_end != 0.0:
        raise InputError("sd_end must be 0 (to rest) when jerk is limited", field="sd_end",
                         value=sd_end)
    # no stops (the planner's pieces): no arrays to build for them
    stop_s = (_NO_STOPS if isinstance(stops, tuple | list) and not stops
              else np.atleast_1d(np.asarray(stops, dtype=np.float64)))
    if stop_s.size and (not np.isfinite(stop_s).all()
                        or (stop_s <= s[0]).any() or (stop_s >= s[-1]).any()):
        raise InputError(f"stops must lie strictly inside s = {s[0]:g}..{s[-1]:g}, got "
                         f"{stop_s.tolist()}", field="stops", value=stop_s.tolist())
    stop_idx = (np.unique(np.abs(s[None, :] - stop_s[:, None]).argmin(axis=1))
                if stop_s.size else _NO_STOP_IDX)
    # s is checked strictly increasing: no dwells for the derivatives' own checks to find
    derivs = derivatives(q, s, stop_idx.tolist(), 3 if jerk else 2, repeated=False)
    grid = grid_of(n, stop_idx, max(1, int(max_stages)))
    every = grid.shape[0] == n  # the grid is every sample: s[grid] would only copy
    sg = s.copy() if every else s[grid]
    dq, ddq = (derivs[0], derivs[1]) if every else (derivs[0][grid], derivs[1][grid])
    cap = None  # the extra cap on x = ṡ², None: none (inf everywhere)
    if sd_cap is not None or stop_idx.size:
        cap = np.full(grid.shape[0], np.inf)
    if sd_cap is not None:
        sd_cap = np.asarray(sd_cap, dtype=np.float64)
        if sd_cap.shape != (n,) or np.isnan(sd_cap).any() or (sd_cap < 0).any():
            raise InputError(f"sd_cap must be {n} speeds ≥ 0, got shape {sd_cap.shape}",
                             field="sd_cap", value=sd_cap.shape)
        cap = np.minimum(cap, sd_cap[grid] ** 2)
    if stop_idx.size:
        cap[np.searchsorted(grid, stop_idx)] = 0.0
    rows = torque_rows(torque, q if every else q[grid], dq, ddq, scale)
    if tool is not None:
        cap, rows = tool_constraints(tool, q if every else q[grid], dq, ddq, scale, cap, rows)
    if not jerk:
        if not every:
            v, a = (lim[grid] if lim.ndim == 2 else lim for lim in (v, a))
        x, u = solve(sg, dq, ddq, v, a, cap, sd_start ** 2, sd_end ** 2, rows)
        # x = ṡ² ≥ 0; the stage solutions can land a rounding error below 0 at a stop
        # (seen as -1e-17): no NaN speeds into the law (the same √max(x, 0) as the times')
        dt, sd = timed_stages(sg, x)
        tb = np.empty(dt.shape[0] + 1)
        tb[0] = 0.0
        # np.concatenate([[0.0], np.cumsum(dt)]): cumsum's own ufunc, without its wrapper
        np.add.accumulate(dt, out=tb[1:])
        return PathTiming(tb, sg, sd, u)
    assert j is not None
    j = j * scale ** 3
    if cap is None:
        cap = np.full(grid.shape[0], np.inf)
    return jerk_limited(s, derivs, grid, cap, v, a, j, sd_start=sd_start, sdd_start=sdd_start,
                        stop_idx=stop_idx, rate_hz=rate_hz or CHECK_RATE_HZ,
                        accel_share=accel_share, smooth=smooth, rows=rows,
                        speed_capped=sd_cap is not None or tool is not None)


def torque_rows(torque: TorqueLimits | None, q: NDArray, dq: NDArray, ddq: NDArray,
                scale: float = 1.0) -> TorqueRows | None:
    """The torque rows on the grid (None without torque limits or without a finite one)."""
    if torque is None or not np.isfinite(torque.tau).any():
        return None
    if torque.tau.shape != (q.shape[1],):
        raise InputError(f"torque limits must have one entry per joint ({q.shape[1]}), got "
                         f"{torque.tau.shape}", field="torque", value=torque.tau.shape)
    return torque.rows(q, dq, ddq, scale)


def tool_constraints(tool: ToolLimits, q: NDArray, dq: NDArray, ddq: NDArray, scale: float,
                     cap: NDArray | None, rows: TorqueRows | None
                     ) -> tuple[NDArray | None, TorqueRows | None]:
    """The x cap and rows with the tool's (:meth:`ToolLimits.constraints`) added: the caps
    by the smaller, the rows side by side."""
    tool_cap, tool_rows = tool.constraints(q, dq, ddq, scale)
    if tool_cap is not None:
        cap = tool_cap if cap is None else np.minimum(cap, tool_cap)
    if tool_rows is not None:
        rows = tool_rows if rows is None else tuple(  # type: ignore[assignment]
            np.concatenate([m, t], axis=1) for m, t in zip(rows, tool_rows, strict=True))
    return cap, rows


def max_start_speed(q: ArrayLike, s: ArrayLike, v_max: ArrayLike, a_max: ArrayLike, *,
                    stops: Sequence[float] = (), scale: float = 1.0,
                    max_stages: int = MAX_STAGES, torque: TorqueLimits | None = None,
                    tool: ToolLimits | None = None) -> float:
    """The fastest ṡ at s[0] from which the path can still be followed within the velocity
    and acceleration limits (and ``torque``'s and ``tool``'s, as :func:`time_optimal` takes
    them) and brought to rest by the end (or the first stop): √x_max,0 of the TOPP-RA
    controllable set. Without a jerk limit any ``sd_start`` up to it is accepted
    by :func:`time_optimal`; with one, the jerk pass needs room below it."""
    q = np.asarray(q, dtype=np.float64)
    s = np.asarray(s, dtype=np.float64)
    n, k = q.shape
    v = check_limits("v_max", v_max, k, n) * scale
    a = check_limits("a_max", a_max, k, n) * scale ** 2
    stop_s = np.atleast_1d(np.asarray(stops, dtype=np.float64))
    stop_idx = np.unique(np.abs(s[None, :] - stop_s[:, None]).argmin(axis=1)
                         if stop_s.size else _NO_STOP_IDX)
    dq, ddq = path_derivatives(q, s, stop_idx.tolist(), 2)
    grid = grid_of(q.shape[0], stop_idx, max(1, int(max_stages)))
    dq, ddq = dq[grid], ddq[grid]
    rows = torque_rows(torque, q[grid], dq, ddq, scale)
    cap = None
    if tool is not None:
        cap, rows = tool_constraints(tool, q[grid], dq, ddq, scale, None, rows)
    v, a = (lim[grid] if lim.ndim == 2 else lim for lim in (v, a))
    if INTERPOLATED:  # the same discretisation as time_optimal's
        dq, ddq, v, a = interpolated(s[grid], dq, ddq, v, a)
        if rows is not None:
            rows = interpolated_rows(s[grid], rows)
    p_lo, _, r, x_cap = reachability.stage_constraints(dq, ddq, v, a, rows)
    if cap is not None:
        x_cap = np.minimum(x_cap, cap)
    x_cap[np.searchsorted(grid, stop_idx)] = 0.0
    x_max = reachability.controllable(np.diff(s[grid]), p_lo, r, x_cap, 0.0)
    return math.sqrt(float(x_max[0]))
