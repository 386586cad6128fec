"""TOPP-RA: time-optimal path parameterisation by reachability analysis.

Follows H. Pham and Q.-C. Pham, "A New Approach to Time-Optimal Path Parameterization Based
on Reachability Analysis", IEEE Transactions on Robotics 34(3), 2018. On a grid
s_0 < … < s_N with x = ṡ² and u = s̈ constant on each stage (x_{i+1} = x_i + 2Δ_i u_i), every
joint j gives box constraints at stage i

    q'_ij² x ≤ v_j²                      (velocity)
    -a_j ≤ q'_ij u + q''_ij x ≤ a_j        (acceleration)

so u lies between L_ij(x) = -a_j/|q'_ij| - (q''_ij/q'_ij) x and U_ij(x) = a_j/|q'_ij| -
(q''_ij/q'_ij) x. The per-stage linear programs of the paper are solved in closed form:
the feasible x at a stage is [0, x_cap] with x_cap from the pairwise crossings U_l = L_j
(vectorised over stages), the backward controllable-set step is the largest x with
x + 2Δ max_j L_j(x) ≤ x_max,i+1 (a minimum of k affine roots), and the forward greedy step
takes u = min(min_j U_j(x_i), (x_max,i+1 - x_i) / 2Δ_i).

Further linear rows lo ≤ A u + B x ≤ hi (joint torque τ = a s̈ + b ṡ² + c:
:mod:`robodcn.path_timing.torque`) join as more (L, U) pairs with their own lower and upper
offsets (p_lo, p_hi no longer ∓ the same half-width); the crossings, the backward step and
the greedy step read them like the acceleration rows.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

# |q'| below this (rad per unit s) counts as "this joint does not move along the path here":
# its acceleration bound then limits x only, through |q''| x ≤ a.
_FLAT = 1e-9


def stage_constraints(dq: NDArray[np.float64], ddq: NDArray[np.float64],
                      v_max: NDArray[np.float64], a_max: NDArray[np.float64],
                      rows: tuple[NDArray, NDArray, NDArray, NDArray] | None = None
                      ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Per stage and constraint row: (p_lo, p_hi, r, x_cap) with L = p_lo + r x, U = p_hi + r x.

    Parameters
    ----------
    dq, ddq : (N, k) q'(s_i), q''(s_i)
    v_max, a_max : (k,) or (N, k) limits, inf where unlimited
    rows : optional further linear rows (A, B, lo, hi), each (N, m): lo ≤ A u + B x ≤ hi
        (the torque rows of :mod:`robodcn.path_timing.torque`; lo ≤ 0 ≤ hi, so rest is
        feasible)

    Returns
    -------
    p_lo, p_hi, r : (N, k [+ m]); x_cap : (N,) the largest feasible x at each stage
        (velocity limits, and the maximum velocity curve of every row pair).
    """
    moving = np.abs(dq) > _FLAT
    safe = np.where(moving, dq, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        half = np.where(moving, a_max / np.abs(safe), np.inf)
        r = np.where(moving, -ddq / safe, 0.0)
        x_vel = np.where(moving, (v_max / safe) ** 2, np.inf).min(axis=1)
        # a joint that does not move still feels q'' x: |q''| x ≤ a
        still = np.where(~moving & (np.abs(ddq) > 0), a_max / np.abs(ddq), np.inf).min(axis=1)
    p_lo, p_hi = -half, half
    if rows is not None:
        lo_t, hi_t, r_t, still_t = _rows(*rows)
        p_lo = np.hstack([p_lo, lo_t])
        p_hi = np.hstack([p_hi, hi_t])
        r = np.hstack([r, r_t])
        still = np.minimum(still, still_t)
    with np.errstate(divide="ignore", invalid="ignore"):
        # U_l(x) ≥ L_j(x) for every pair: (p_hi,l − p_lo,j) + (r_l − r_j) x ≥ 0
        gap = p_hi[:, :, None] - p_lo[:, None, :]
        slope = r[:, :, None] - r[:, None, :]
        cross = np.where(slope < 0, gap / -np.where(slope < 0, slope, -1.0), np.inf)
    x_cap = np.minimum(np.minimum(x_vel, still), cross.min(axis=(1, 2)))
    return p_lo, p_hi, r, x_cap


def _rows(a: NDArray, b: NDArray, lo: NDArray, hi: NDArray
          ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """General rows lo ≤ a u + b x ≤ hi as u-bounds p_lo + r x ≤ u ≤ p_hi + r x, and the
    x-bound of the rows with a = 0 (b x within [lo, hi])."""
    moving = np.abs(a) > _FLAT
    safe = np.where(moving, a, 1.0)
    up = safe > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        p_lo = np.where(moving, np.where(up, lo, hi) / safe, -np.inf)
        p_hi = np.where(moving, np.where(up, hi, lo) / safe, np.inf)
        r = np.where(moving, -b / safe, 0.0)
        bound = np.where(b > 0, hi / np.where(b > 0, b, 1.0),
                         np.where(b < 0, lo / np.where(b < 0, b, -1.0), np.inf))
    still = np.where(moving, np.inf, bound).min(axis=1)
    # rows without a bound (unlimited, or off): no slope either, so no crossing
    return p_lo, p_hi, r, still


def controllable(delta: NDArray[np.float64], p_lo: NDArray, r: NDArray, x_cap: NDArray,
                 x_end: float) -> NDArray[np.float64]:
    """Backward pass: x_max,i of the controllable sets K_i = [0, x_max,i] (paper §III).

    K_N = [0, x_end] (x_end = ṡ_end²); x_max,i is the largest x ≤ x_cap,i from which the
    strongest deceleration of stage i lands in K_{i+1}. Each root of
    x (1 + 2Δ r_j) + 2Δ p_lo,j = c is c·W_j + Z_j; slopes ≤ 0 give no upper bound.
    """
    n_stages = delta.shape[0]
    slope = 1.0 + 2.0 * delta[:, None] * r[:n_stages]
    good = (slope > 0) & np.isfinite(p_lo[:n_stages])
    w = np.where(good, 1.0 / np.where(good, slope, 1.0), 0.0)
    z = np.where(good, -2.0 * delta[:, None] * np.where(good, p_lo[:n_stages], 0.0) * w,
                 np.inf)
    c = min(float(x_end), float(x_cap[n_stages]))
    if w.shape[1] <= 3:
        # pad to three joints with roots that never bind (W = 0, Z = ∞) and unroll
        pad = 3 - w.shape[1]
        w = np.hstack([w, np.zeros((n_stages, pad))])
        z = np.hstack([z, np.full((n_stages, pad), np.inf)])
        out = _backward3(c, x_cap[n_stages - 1::-1].tolist(), *(col[::-1].tolist() for pair in
                         zip(w.T, z.T, strict=True) for col in pair))
        return np.concatenate([out[::-1], [c]])
    x_max = np.empty(n_stages + 1)
    x_max[n_stages] = c
    caps = x_cap[:n_stages].tolist()
    ws = w.tolist()
    zs = z.tolist()
    # inherently sequential: a few scalar operations per stage on precomputed lists
    for i in range(n_stages - 1, -1, -1):
        m = caps[i]
        for wj, zj in zip(ws[i], zs[i], strict=True):
            root = c * wj + zj
            if root < m:
                m = root
        c = m if m > 0.0 else 0.0
        x_max[i] = c
    return x_max


def _backward3(c: float, caps: list, w0: list, z0: list, w1: list, z1: list, w2: list,
               z2: list) -> NDArray[np.float64]:
    """The backward recursion unrolled for up to three joints (stages in reverse order)."""
    out = []
    append = out.append
    for m, a0, b0, a1, b1, a2, b2 in zip(caps, w0, z0, w1, z1, w2, z2, strict=True):
        r = c * a0 + b0
        if r < m:
            m = r
        r = c * a1 + b1
        if r < m:
            m = r
        r = c * a2 + b2
        if r < m:
            m = r
        c = m if m > 0.0 else 0.0
        append(c)
    return np.asarray(out)


def greedy_forward(delta: NDArray[np.float64], p_hi: NDArray, r: NDArray,
                   x_max: NDArray[np.float64], x_start: float
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Forward pass: the greedy u_i = max feasible u keeping x_{i+1} in K_{i+1} (paper §III).

    Returns x (N + 1,) and u (N,).
    """
    n_stages = delta.shape[0]
    two_d = (2.0 * delta).tolist()
    ph = p_hi[:n_stages].tolist()
    rs = r[:n_stages].tolist()
    xm = x_max.tolist()
    if p_hi.shape[1] <= 3:
        pad = 3 - p_hi.shape[1]
        ph3 = np.hstack([p_hi[:n_stages], np.full((n_stages, pad), np.inf)])
        r3 = np.hstack([r[:n_stages], np.zeros((n_stages, pad))])
        return _forward3(float(x_start), two_d, xm[1:], *(col.tolist() for pair in
                         zip(ph3.T, r3.T, strict=True) for col in pair))
    x = [0.0] * (n_stages + 1)
    u = [0.0] * n_stages
    xi = float(x_start)
    x[0] = xi
    for i in range(n_stages):
        d2 = two_d[i]
        ui = (xm[i + 1] - xi) / d2
        for pj, rj in zip(ph[i], rs[i], strict=True):
            bound = pj + rj * xi
            if bound < ui:
                ui = bound
        xn = xi + d2 * ui
        if xn < 0.0:  # rounding at a stop: land exactly at rest
            xn = 0.0
            ui = -xi / d2
        u[i] = ui
        x[i + 1] = xn
        xi = xn
    return np.asarray(x), np.asarray(u)


def _forward3(xi: float, two_d: list, x_next: list, p0: list, r0: list, p1: list, r1: list,
              p2: list, r2: list) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The forward recursion unrolled for up to three joints."""
    xs = [xi]
    us = []
    for d2, xm, a0, b0, a1, b1, a2, b2 in zip(two_d, x_next, p0, r0, p1, r1, p2, r2,
                                               strict=True):
        ui = (xm - xi) / d2
        bound = a0 + b0 * xi
        if bound < ui:
            ui = bound
        bound = a1 + b1 * xi
        if bound < ui:
            ui = bound
        bound = a2 + b2 * xi
        if bound < ui:
            ui = bound
        xi = xi + d2 * ui
        if xi < 0.0:  # rounding at a stop: land exactly at rest
            ui = -xs[-1] / d2
            xi = 0.0
        us.append(ui)
        xs.append(xi)
    return np.asarray(xs), np.asarray(us)
