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

import functools

import numpy as np
from numpy.typing import NDArray

from robodcn.path_timing import _scan

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
        p_lo = np.concatenate([p_lo, lo_t], axis=1)
        p_hi = np.concatenate([p_hi, hi_t], axis=1)
        r = np.concatenate([r, r_t], axis=1)
        still = np.minimum(still, still_t)
    x_cap = np.minimum(x_vel, still)
    m = r.shape[1]
    if m > 1:
        # U_l(x) ≥ L_j(x) for every pair: (p_hi,l − p_lo,j) + (r_l − r_j) x ≥ 0 bounds x
        # where r_l < r_j; of each unordered pair at most one order does
        il, jl = _pairs(m)
        d = r[:, il] - r[:, jl]
        gap = np.where(d < 0, p_hi[:, il] - p_lo[:, jl], p_hi[:, jl] - p_lo[:, il])
        with np.errstate(divide="ignore", invalid="ignore"):
            cross = np.where(d != 0, gap / np.abs(d), np.inf)
        x_cap = np.minimum(x_cap, cross.min(axis=1))
    return p_lo, p_hi, r, x_cap


@functools.cache
def _pairs(m: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    return np.triu_indices(m, 1)


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
    x (1 + 2Δ r_j) + 2Δ p_lo,j = c is c·W_j + Z_j; slopes ≤ 0 give no upper bound. So
    x_max,i = max(0, min(x_cap,i, min_j (W_ij x_max,i+1 + Z_ij))), solved over all stages
    at once (:func:`robodcn.path_timing._scan.min_affine`; the stage loop as fallback).
    """
    n_stages = delta.shape[0]
    slope = 1.0 + 2.0 * delta[:, None] * r[:n_stages]
    good = (slope > 0) & np.isfinite(p_lo[:n_stages])
    w = np.where(good, 1.0 / np.where(good, slope, 1.0), 0.0)
    z = np.where(good, -2.0 * delta[:, None] * np.where(good, p_lo[:n_stages], 0.0) * w,
                 np.inf)
    c = min(float(x_end), float(x_cap[n_stages]))
    # stages in reverse order, the cap as one more piece (slope 0)
    pieces_w = np.concatenate([w, np.zeros((n_stages, 1))], axis=1)[::-1]
    pieces_z = np.concatenate([z, x_cap[:n_stages, None]], axis=1)[::-1]

    def sequential(c0: float, first: int) -> NDArray[np.float64]:
        return _backward(c0, pieces_w[first:], pieces_z[first:])

    return _scan.min_affine(c, pieces_w, pieces_z, sequential)[::-1].copy()


def _backward(c: float, w: NDArray, z: NDArray) -> NDArray[np.float64]:
    """The plain loop of :func:`controllable` (stages in reverse order, the cap the last
    piece): c and every later value."""
    out = [c]
    append = out.append
    for ws, zs in zip(w.tolist(), z.tolist(), strict=True):
        m = np.inf
        for wj, zj in zip(ws, zs, strict=True):
            root = c * wj + zj
            if root < m:
                m = root
        c = m if m > 0.0 else 0.0
        append(c)
    return np.asarray(out)


def greedy_forward(delta: NDArray[np.float64], p_hi: NDArray, r: NDArray,
                   x_max: NDArray[np.float64], x_start: float
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Forward pass: the greedy u_i = max feasible u keeping x_{i+1} in K_{i+1} (paper §III).

    x_{i+1} = x_i + 2Δ_i u_i with u_i = min(min_j U_ij(x_i), (x_max,i+1 − x_i) / 2Δ_i), at
    rest (0) where rounding would land below: x_{i+1} = max(0, min(x_max,i+1,
    min_j ((1 + 2Δ_i r_ij) x_i + 2Δ_i p_hi,ij))), solved over all stages at once
    (:func:`robodcn.path_timing._scan.min_affine`; the stage loop as fallback).
    Returns x (N + 1,) and u (N,).
    """
    n_stages = delta.shape[0]
    two_d = 2.0 * delta[:, None]
    with np.errstate(invalid="ignore"):
        pieces_w = np.concatenate([1.0 + two_d * r[:n_stages], np.zeros((n_stages, 1))],
                                  axis=1)
        pieces_z = np.concatenate([two_d * p_hi[:n_stages], x_max[1:, None]], axis=1)

    def sequential(x0: float, first: int) -> NDArray[np.float64]:
        return _forward(x0, pieces_w[first:], pieces_z[first:])

    x = _scan.min_affine(float(x_start), pieces_w, pieces_z, sequential)
    return x, np.diff(x) / (2.0 * delta)


def _forward(x: float, w: NDArray, z: NDArray) -> NDArray[np.float64]:
    """The plain loop of :func:`greedy_forward` (the cap x_max,i+1 the last piece)."""
    out = [x]
    append = out.append
    for ws, zs in zip(w.tolist(), z.tolist(), strict=True):
        m = np.inf
        for wj, zj in zip(ws, zs, strict=True):
            v = x * wj + zj
            if v < m:
                m = v
        x = m if m > 0.0 else 0.0
        append(x)
    return np.asarray(out)
