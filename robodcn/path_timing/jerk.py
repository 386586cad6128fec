"""The jerk pass of :func:`robodcn.path_timing.time_optimal` (module doc of ``optimal``)."""

from __future__ import annotations

import itertools
import math

import numpy as np
from numpy.typing import NDArray

from robodcn.errors import InputError
from robodcn.path_timing import reachability
from robodcn.path_timing.law import ChainTiming, PathTiming
from robodcn.path_timing.quintic_law import fastest_quintic
from robodcn.path_timing.topp import solve, stage_times
from robodcn.path_timing.torque import TorqueRows

# share of the jerk limit the term |q'''| ṡ³ may take; the rest is left to q' s⃛ + 3 q'' ṡ s̈
#: inner margin of the jerk pass: it aims for (1 - margin) × every limit
JERK_MARGIN = 0.005
#: share of every limit the uniform quintic is held to (checked at each stream sample; a
#: peak between two samples is higher by O((rate·T)⁻²), ~1e-6 at 1 kHz over a second)
QUINTIC_SHARE = 1.0 - 1e-5
_CURVATURE_SHARE = 0.5
_WINDOWS = (1.0, 0.75, 0.55, 0.4, 0.3)
_MOVING_ATTEMPTS = 8
_LOCAL_ROUNDS = 2
_QUICK_SAMPLES = 2500
#: samples either side whose median change of q'' is a smooth path's own (corner_jumps)
_CORNER_REACH = 8


def corner_jumps(ddq: NDArray) -> NDArray:
    """|Δq''| across three sample intervals around each sample (n, k).

    A step of q'' (a blend's curvature corner: the path is C¹ there) shows in the finite
    differences smeared over about three intervals; the servos see it whole, within one
    stream period, as a step of joint acceleration Δq'' ṡ²: a jerk Δq'' ṡ² × rate.
    """
    n = ddq.shape[0]
    i = np.arange(n)
    jumps = np.abs(ddq[np.minimum(i + 2, n - 1)] - ddq[np.maximum(i - 1, 0)])
    if n < 2 * _CORNER_REACH + 1:
        return jumps
    # A corner is a spike of the change, not its level: a smooth q'' changes by 3 Δs |q'''|
    # over the same three intervals everywhere (the q''' ṡ³ term covers it), and read as a
    # step it capped a smooth path's speed and counted its whole jerk as a step's (a cubic
    # path at jerk 15 a stretched 1.7×). Only the excess over 3 × the neighbourhood's median
    # counts, and not the rounding of a straight stretch's q'' = 0 (its median is 0 too).
    # The median is taken only where the change stands out of the window's mean (a spike
    # three samples wide over 3 × the median stands 1.68 × over the mean): O(n) elsewhere.
    noise = 1e-6 * float(np.abs(ddq).max())  # (of the whole path: a straight joint's own
    # q'' is rounding alone)
    width = 2 * _CORNER_REACH + 1
    padded = np.pad(jumps, ((_CORNER_REACH, _CORNER_REACH), (0, 0)), mode="edge")
    total = np.concatenate([np.zeros((1, jumps.shape[1])), np.cumsum(padded, axis=0)])
    mean = (total[width:] - total[:-width]) / width
    rows = np.flatnonzero((jumps > 1.5 * mean + noise).any(axis=1))
    out = np.zeros_like(jumps)
    if rows.size:
        window = np.lib.stride_tricks.sliding_window_view(padded, width, axis=0)[rows]
        level = np.median(window, axis=-1)
        out[rows] = np.maximum(jumps[rows] - 3.0 * level - noise, 0.0)
    return out


def joint_ratios(law: PathTiming, s: NDArray, derivs: list[NDArray], v: NDArray, a: NDArray,
                 j: NDArray, rate_hz: float, per_sample: bool = False,
                 sample_hz: float | None = None) -> tuple:
    """max over the stream samples of |q̇|/v, |q̈|/a, |q⃛|/j and the corner-step jerk / j.

    q̇ = q' ṡ, q̈ = q'' ṡ² + q' s̈, q⃛ = q''' ṡ³ + 3 q'' ṡ s̈ + q' s⃛ with q', q'', q''' from
    the sample derivatives (``derivs[:3]``), linearly interpolated at s(t). With
    ``derivs[3]`` (:func:`corner_jumps`) the last figure is max(Δq'' ṡ² rate + |3 q'' ṡ s̈ +
    q' s⃛|)/j: a step's jerk falls as 1/λ² under a stretch λ, the smooth jerk as 1/λ³.
    With ``per_sample`` also s(t) and each sample's stretch factor (N,) are returned.
    ``sample_hz`` samples the law more coarsely than the stream (a quick look at candidates).
    """
    m = law.sample(sample_hz or rate_hz)
    sd, sdd, sddd = m.sd[:, None], m.sdd[:, None], m.sddd[:, None]
    d1, d2, d3 = (np.stack([np.interp(m.s, s, d[:, i]) for i in range(d.shape[1])], axis=1)
                  for d in derivs[:3])
    vel = d1 * sd
    acc = d2 * sd ** 2 + d1 * sdd
    rest = 3.0 * d2 * sd * sdd + d1 * sddd
    jrk = d3 * sd ** 3 + rest
    step = np.zeros_like(jrk)
    if len(derivs) > 3:
        jump = np.stack([np.interp(m.s, s, derivs[3][:, i]) for i in range(d1.shape[1])],
                        axis=1)
        step = np.where(jump > 0, jump * sd ** 2 * rate_hz + np.abs(rest), 0.0)
    rv, ra, rj, rs = np.abs(vel) / v, np.abs(acc) / a, np.abs(jrk) / j, step / j
    maxima = (float(rv.max()), float(ra.max()), float(rj.max()), float(rs.max()))
    if not per_sample:
        return maxima
    factor = np.maximum(np.maximum(rv, np.sqrt(ra)), np.maximum(np.cbrt(rj), np.sqrt(rs)))
    return maxima, m.s, factor.max(axis=1)


def _stretch_needed(rv: float, ra: float, rj: float, r_step: float) -> float:
    return max(1.0, rv, math.sqrt(ra), rj ** (1.0 / 3.0), math.sqrt(r_step)) * (1.0 + 1e-9)


def _corner_cap(s: NDArray, jumps: NDArray, dq: NDArray, ddq: NDArray, v: NDArray,
                a: NDArray, j: NDArray, rate_hz: float, sg: NDArray, cap: NDArray, w: float
                ) -> tuple[NDArray, NDArray]:
    """Lower the grid's speed cap around curvature corners: Δq'' ṡ² rate ≤ j/2, held over a
    window's travel either side so the box filter's average stays under it too.

    Returns the cap and the samples (n,) that are corners (where the step bound binds)."""
    with np.errstate(divide="ignore"):
        x_step = (0.5 * j / (jumps * rate_hz)).min(axis=1)
    x_mvc = reachability.stage_constraints(dq, ddq, v, a)[3]
    binding = x_step < x_mvc
    if not binding.any():
        return cap, binding
    cap = cap.copy()
    edges = np.flatnonzero(np.diff(np.concatenate([[0], binding.astype(np.int8), [0]])))
    for lo, hi in zip(edges[::2], edges[1::2], strict=True):
        xs = float(x_step[lo:hi].min())
        reach = math.sqrt(xs) * w
        g0 = int(np.searchsorted(sg, s[lo] - reach, side="left"))
        g1 = int(np.searchsorted(sg, s[hi - 1] + reach, side="right"))
        cap[g0:g1] = np.minimum(cap[g0:g1], xs)
    return cap, binding


def _rest_piece(s: NDArray, derivs: list[NDArray], sg: NDArray, dq: NDArray, ddq: NDArray,
                cap: NDArray, v: NDArray, a: NDArray, j: NDArray, accel_share: float,
                finite: NDArray, rate_hz: float, rows: TorqueRows | None = None,
                *, outer: tuple[NDArray, NDArray, NDArray], stops_at_end: bool = False,
                quintic: bool = True) -> PathTiming:
    """Rest to rest without stops: the shortest over acceleration shares and windows of the
    filtered optimum, each stretched just enough to keep every limit, or the fastest
    uniform quintic when that is faster. ``stops_at_end``: the piece's last sample is a stop
    inside the path, whose derivatives are the next piece's (:func:`own_end`); ``quintic``:
    whether the uniform quintic is a candidate (not under a caller's speed cap, which it does
    not follow); ``outer``: the limits themselves (v, a, j are the jerk pass's inner ones),
    which the quintic is held to: it is checked exactly at every stream sample, where the
    filtered law's margin is for its coarse looks and the filter's mixing."""
    best, choice = None, None
    for share in (accel_share, 0.8 * accel_share, 0.6 * accel_share):
        x, u = solve(sg, dq, ddq, v, a * share, cap, 0.0, 0.0, rows)
        dt = stage_times(sg, x)
        # the ramp from +a to -a of one joint at its jerk limit takes 2a/j
        w0 = float((2.0 * share * a[finite] / j[finite]).max())
        for f in _WINDOWS:
            law = _filtered(sg, x, u, dt, np.empty(0, np.int64), f * w0, (sg[0], 0.0, 0.0),
                            sg[0])
            lam = _stretch_needed(*joint_ratios(law, s, derivs, v, a, j, rate_hz,
                                                sample_hz=_quick_rate(law, rate_hz)))
            if best is None or lam * law.duration < best.duration:
                best = law.stretch(lam * law.duration) if lam > 1.0 else law
                choice = (share, f * w0, x)
    # then slow down only where a limit is over (the uniform stretch slows everything):
    # lower the speed cap there by the sample's own stretch factor and solve again
    share, w, x = choice
    local_cap = cap
    for _ in range(_LOCAL_ROUNDS):
        x, u = solve(sg, dq, ddq, v, a * share, local_cap, 0.0, 0.0, rows)
        law = _filtered(sg, x, u, stage_times(sg, x), np.empty(0, np.int64), w,
                        (sg[0], 0.0, 0.0), sg[0])
        maxima, s_t, factor = joint_ratios(law, s, derivs, v, a, j, rate_hz, per_sample=True,
                                           sample_hz=_quick_rate(law, rate_hz))
        lam = _stretch_needed(*maxima)
        if lam * law.duration < best.duration:
            best = law.stretch(lam * law.duration) if lam > 1.0 else law
        if lam <= 1.0:
            break
        local_cap = _tighten(local_cap, x, sg, s_t, factor, float(np.sqrt(x.max())) * w)
    # the candidates were looked at coarsely: the chosen one at the stream rate itself
    lam = _stretch_needed(*joint_ratios(best, s, derivs, v, a, j, rate_hz))
    best = best.stretch(lam * best.duration) if lam > 1.0 else best
    # the filter's overhead (a window a piece) can cost more than a uniform law saves
    # under a tight jerk limit: the fastest quintic within the same limits, when faster
    if not quintic:
        return best
    mine = own_end(derivs) if stops_at_end else derivs
    qv, qa, qj = outer
    uniform = fastest_quintic(
        float(sg[0]), float(sg[-1]),
        lambda law: joint_ratios(law, s, mine, qv, qa, qj, rate_hz), best.duration,
        None if rows is None else (sg, rows))
    return uniform if uniform is not None and uniform.duration < best.duration else best


def own_end(derivs: list[NDArray]) -> list[NDArray]:
    """The piece's derivatives with its last sample's q′, q″, q‴ carried on linearly from
    the two before it. At a stop the path has a corner, and the sample there holds the next
    piece's one-sided derivatives (``topp.derivatives`` writes each piece in turn); a law
    that reaches the stop with its full jerk (the quintic's s⃛ = 60 L/T³ at τ = 1) must be
    checked with this piece's own q′ there."""
    out = list(derivs)
    if derivs[0].shape[0] >= 3:
        for d in range(3):
            fixed = derivs[d].copy()
            fixed[-1] = 2.0 * fixed[-2] - fixed[-3]
            out[d] = fixed
    return out


def _quick_rate(law: PathTiming, rate_hz: float) -> float:
    """A check rate giving about _QUICK_SAMPLES samples over the law (at most the stream's)."""
    return min(rate_hz, max(100.0, _QUICK_SAMPLES / max(law.duration, 1e-9)))


def _tighten(cap: NDArray, x: NDArray, sg: NDArray, s_t: NDArray, factor: NDArray,
             reach: float) -> NDArray:
    """Lower the speed cap to x / f² around every run of stream samples over a limit (f the
    run's largest stretch factor), ``reach`` (in s) either side: the filter mixes the law
    over its window."""
    over = factor > 1.0
    cap = cap.copy()
    edges = np.flatnonzero(np.diff(np.concatenate([[0], over.astype(np.int8), [0]])))
    for lo, hi in zip(edges[::2], edges[1::2], strict=True):
        f = float(factor[lo:hi].max()) * 1.01
        g0 = int(np.searchsorted(sg, s_t[lo] - reach, side="left"))
        g1 = int(np.searchsorted(sg, s_t[hi - 1] + reach, side="right"))
        cap[g0:g1] = np.minimum(cap[g0:g1], x[g0:g1] / (f * f))
    return cap


def _filtered(sg: NDArray, x: NDArray, u: NDArray, dt: NDArray, stop_breaks: NDArray,
              w: float, history: tuple[float, float, float], s_start: float) -> PathTiming:
    s_b, v_b = sg, np.sqrt(np.maximum(x, 0.0))
    # a dwell of w at every stop: the window then covers exactly the dwell when the filtered
    # law passes the stop, so it is at rest there
    s_b = np.insert(s_b, stop_breaks, s_b[stop_breaks])
    v_b = np.insert(v_b, stop_breaks, 0.0)
    u = np.insert(u, stop_breaks, 0.0)
    dt = np.insert(dt, stop_breaks, w)
    s_h, v_h, u_h = history
    s_b = np.concatenate([[s_h], s_b])
    v_b = np.concatenate([[v_h], v_b])
    u = np.concatenate([[u_h], u])
    tb = -w + np.concatenate([[0.0], np.cumsum(np.concatenate([[w], dt]))])
    return PathTiming(tb, s_b, v_b, u, window=w, s_start=s_start)


def jerk_limited(s: NDArray, derivs: list[NDArray], grid: NDArray, cap: NDArray, v: NDArray,
                 a: NDArray, j: NDArray, *, sd_start: float, sdd_start: float,
                 stop_idx: NDArray, rate_hz: float, accel_share: float,
                 smooth: bool = False, rows: TorqueRows | None = None,
                 speed_capped: bool = False) -> PathTiming:
    """Filtered time-optimal law within v, a, j (module doc of ``optimal``); ``rows``: the
    torque rows on the grid, kept by the filtered law's optimum (the filter mixes it over
    its window: the planner's validation checks the samples); ``speed_capped``: the caller
    capped ṡ (``sd_cap``), which only the filtered law follows (no quintic fallback)."""
    inner = 1.0 - JERK_MARGIN
    lim_v, lim_a, lim_j = v * inner, a * inner, j * inner
    finite = np.isfinite(j)
    # the ramp from +a to -a of one joint at its jerk limit takes 2a/j
    w0 = float((2.0 * accel_share * a[finite] / j[finite]).max())
    sg = s[grid]
    dq, ddq, dddq = (d[grid] for d in derivs)
    with np.errstate(divide="ignore"):
        jcap = ((_CURVATURE_SHARE * lim_j / np.abs(dddq)) ** (2.0 / 3.0)).min(axis=1)
    cap = np.minimum(cap, jcap)
    if smooth:  # the caller's path is C² within its pieces: no curvature corners to cross
        jumps = np.zeros_like(derivs[1])
        corners = np.zeros(jumps.shape[0], dtype=bool)
    else:
        jumps = corner_jumps(derivs[1])
        for i in stop_idx.tolist():  # at rest there: the derivatives' corner is the stop's
            jumps[max(0, i - 2):i + 3] = 0.0
        cap, corners = _corner_cap(s, jumps, derivs[0], derivs[1], lim_v, lim_a, lim_j,
                                   rate_hz, sg, cap, w0)
    jumps[~corners] = 0.0  # smooth stretches: the analytic q''' ṡ³ term covers them
    derivs = [*derivs[:3], jumps]
    stop_breaks = np.searchsorted(grid, stop_idx)
    moving = sd_start > 0.0 or sdd_start != 0.0
    if not moving:
        # at rest at every stop, so each piece between stops is timed on its own: its own
        # acceleration share and window (a short piece wants a smaller swing)
        cuts = [0, *stop_breaks.tolist(), sg.shape[0] - 1]
        pieces = []
        for g0, g1 in itertools.pairwise(cuts):
            lo, hi = int(grid[g0]), int(grid[g1])
            sl = slice(g0, g1 + 1)
            pieces.append(_rest_piece(s[lo:hi + 1], [d[lo:hi + 1] for d in derivs], sg[sl],
                                      dq[sl], ddq[sl], cap[sl], lim_v, lim_a, lim_j,
                                      accel_share, finite, rate_hz,
                                      None if rows is None else tuple(m[sl] for m in rows),
                                      stops_at_end=g1 != cuts[-1],
                                      quintic=not speed_capped,
                                      outer=(v * QUINTIC_SHARE, a * QUINTIC_SHARE,
                                             j * QUINTIC_SHARE)))
        return pieces[0] if len(pieces) == 1 else ChainTiming(pieces)

    # A moving start cannot be stretched (ṡ(0) would change): shrink the limits instead.
    share_v, share_a = 1.0, accel_share
    w = w0
    for _ in range(_MOVING_ATTEMPTS):
        sd0 = sd_start + sdd_start * w / 2.0  # the optimal law's speed at t = 0
        if sd0 < 0.0:
            raise InputError(f"sdd_start {sdd_start:.6g} /s² brakes too hard for sd_start "
                             f"{sd_start:.6g} /s under the jerk limits", field="sdd_start",
                             value=sdd_start)
        s00 = sg[0] + sd0 * w / 2.0 - sdd_start * w * w / 6.0
        keep = sg > s00
        if s00 >= sg[-1] or (stop_idx.size and s00 >= s[stop_idx[0]]):
            raise InputError(f"from sd_start {sd_start:.6g} /s the path ends (or stops) before "
                             "the jerk limits allow a stop", field="sd_start", value=sd_start)
        sg2 = np.concatenate([[s00], sg[keep]])
        at = [np.stack([np.interp(s00, s, d[:, i]) for i in range(d.shape[1])])
              for d in derivs[:2]]
        dq2 = np.vstack([at[0], dq[keep]])
        ddq2 = np.vstack([at[1], ddq[keep]])
        cap2 = np.concatenate([[np.inf], cap[keep]])
        # the torque row at s00: the grid point's before it
        rows2 = None if rows is None else tuple(
            np.vstack([m[max(0, int(np.argmax(keep)) - 1)][None], m[keep]]) for m in rows)
        x, u = solve(sg2, dq2, ddq2, lim_v * share_v, lim_a * share_a, cap2, sd0 ** 2, 0.0,
                     rows2)
        dt = stage_times(sg2, x)
        breaks = np.searchsorted(sg2, s[stop_idx])
        history = (s00 - sd0 * w + sdd_start * w * w / 2.0, sd0 - sdd_start * w, sdd_start)
        law = _filtered(sg2, x, u, dt, breaks, w, history, sg[0])
        rv, ra, rj, r_step = joint_ratios(law, s, derivs, v, a, j, rate_hz)
        rj = max(rj, r_step)
        if max(rv, ra, rj) <= 1.0:
            return law
        # a moving start cannot be stretched: slow the law itself where the jerk is over
        # (velocity ~ share_v, the jerk terms in ṡ² s̈ and ṡ³ ~ share_v³) and widen the window
        # (the filter's share of the jerk goes as 1/w)
        share_v /= max(1.0, rv * 1.002, rj ** (1.0 / 3.0) * 1.002)
        share_a /= max(1.0, ra * 1.002, math.sqrt(rj) * 1.002)
        if rj > 1.0:
            w *= rj * 1.05
    raise InputError(f"from sd_start {sd_start:.6g} /s, sdd_start {sdd_start:.6g} /s² no law "
                     f"found within the limits (velocity ×{rv:.3g}, acceleration ×{ra:.3g}, "
                     f"jerk ×{rj:.3g} of the limit)", field="sd_start", value=sd_start)
