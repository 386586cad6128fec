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

from robodcn.path_timing import _scan, _stageloop

# |q'| below this (rad per unit s) counts as "this joint does not move along the path here":
# its acceleration bound then limits x only, through |q''| x ≤ a.
_FLAT = 1e-9
#: stages up to which the passes run the plain stage loop (:mod:`robodcn.path_timing.
#: _stageloop`); above it the vectorised policy iteration (:mod:`robodcn.path_timing._scan`)
LOOP_STAGES = 1000


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
    x_max,i = max(0, min(x_cap,i, min_j (W_ij x_max,i+1 + Z_ij))): on up to
    :data:`LOOP_STAGES` stages the plain stage loop (:mod:`robodcn.path_timing._stageloop`),
    above it solved over all stages at once (:func:`controllable_scan`).
    """
    n_stages = delta.shape[0]
    if n_stages > LOOP_STAGES:
        return controllable_scan(delta, p_lo, r, x_cap, x_end)
    w, z = backward_pieces(delta, p_lo[:n_stages].T, r[:n_stages].T)
    c = min(float(x_end), float(x_cap[n_stages]))
    return np.array(backward_loop(c, w, z, x_cap[:n_stages]))


def backward_pieces(delta: NDArray[np.float64], p_lo: NDArray, r: NDArray
                    ) -> tuple[NDArray, NDArray]:
    """(W, Z) (m, N) of :func:`controllable` from p_lo, r (m, N), one row per constraint:
    W = 1 / (1 + 2Δ r), Z = −2Δ p_lo W where the slope is positive and p_lo finite, else
    (0, inf) (no bound)."""
    slope = 1.0 + 2.0 * delta * r
    good = (slope > 0) & np.isfinite(p_lo)
    if good.all():  # the common case: what the np.where below pick
        w = 1.0 / slope
        return w, -2.0 * delta * p_lo * w
    w = np.where(good, 1.0 / np.where(good, slope, 1.0), 0.0)
    return w, np.where(good, -2.0 * delta * np.where(good, p_lo, 0.0) * w, np.inf)


def backward_loop(c: float, w: NDArray, z: NDArray, cap: NDArray) -> NDArray[np.float64]:
    """x_max,0 … x_max,N of :func:`controllable` by the stage loop from x_max,N = c, the
    pieces (W, Z) (m, N) and the caps (N,)."""
    m = w.shape[0]
    block = np.empty((2 * m + 1, w.shape[1]))
    block[:m] = w[:, ::-1]
    block[m:2 * m] = z[:, ::-1]
    block[2 * m] = cap[::-1]
    return backward_block(c, block, m)


def backward_block(c: float, block: NDArray, m: int) -> NDArray[np.float64]:
    """x_max,0 … x_max,N of :func:`controllable` by the stage loop from x_max,N = c and the
    (2m + 1, N) block of W, Z and the caps, stages reversed (where the cap binds, without
    the loop: :func:`~robodcn.path_timing._stageloop.capped_recurrence`); a reversed view."""
    return _stageloop.capped_recurrence(c, block, m)[::-1]


def controllable_scan(delta: NDArray[np.float64], p_lo: NDArray, r: NDArray,
                      x_cap: NDArray, x_end: float) -> NDArray[np.float64]:
    """:func:`controllable` over all stages at once (:func:`robodcn.path_timing._scan.
    min_affine`, the stage loop as its fallback): equal to the stage loop to rounding
    (relative 1e-12 a stage), faster on large grids that its policy iteration solves in a
    few rounds."""
    n_stages = delta.shape[0]
    w, z = backward_pieces(delta[:, None], p_lo[:n_stages], r[:n_stages])
    c = min(float(x_end), float(x_cap[n_stages]))
    # stages in reverse order, the cap as one more piece (slope 0)
    pieces_w = np.concatenate([w, np.zeros((n_stages, 1))], axis=1)[::-1]
    pieces_z = np.concatenate([z, x_cap[:n_stages, None]], axis=1)[::-1]

    def sequential(c0: float, first: int) -> NDArray[np.float64]:
        return _sequential(c0, pieces_w[first:], pieces_z[first:])

    return _scan.min_affine(c, pieces_w, pieces_z, sequential)[::-1].copy()


def _sequential(x: float, w: NDArray, z: NDArray) -> NDArray[np.float64]:
    """The stage loop on pieces (N, m + 1) whose last is the cap (slope 0): x and every
    later value (the scans' fallback)."""
    m = w.shape[1] - 1
    columns = [*w[:, :m].T.tolist(), *z.T.tolist()]
    return np.array(_stageloop.recurrence(x, columns, m))



def greedy_forward(delta: NDArray[np.float64], p_hi: NDArray, r: NDArray,
                   x_max: NDArray[np.float64], x_start: float
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Forward pass: the greedy u_i = max feasible u keeping x_{i+1} in K_{i+1} (paper §III).

    x_{i+1} = x_i + 2Δ_i u_i with u_i = min(min_j U_ij(x_i), (x_max,i+1 − x_i) / 2Δ_i), at
    rest (0) where rounding would land below: x_{i+1} = max(0, min(x_max,i+1,
    min_j ((1 + 2Δ_i r_ij) x_i + 2Δ_i p_hi,ij))): on up to :data:`LOOP_STAGES` stages the
    plain stage loop (:mod:`robodcn.path_timing._stageloop`), above it solved over all
    stages at once (:func:`greedy_scan`). Returns x (N + 1,) and u (N,).
    """
    n_stages = delta.shape[0]
    if n_stages > LOOP_STAGES:
        return greedy_scan(delta, p_hi, r, x_max, x_start)
    return forward_loop(delta, p_hi[:n_stages].T, r[:n_stages].T, x_max[1:], x_start)


def forward_loop(delta: NDArray[np.float64], p_hi: NDArray, r: NDArray,
                 caps: NDArray[np.float64], x_start: float
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """x, u of :func:`greedy_forward` by the stage loop from p_hi, r (m, N), one row per
    constraint, and the caps x_max,1 … x_max,N."""
    two_d = 2.0 * delta
    with np.errstate(invalid="ignore"):
        w = 1.0 + two_d * r
        z = two_d * p_hi
    return forward_recurrence(delta, w, z, caps, x_start)


def forward_recurrence(delta: NDArray[np.float64], slope: NDArray, offset: NDArray,
                       caps: NDArray[np.float64], x_start: float
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """x, u of :func:`greedy_forward` by the stage loop from its pieces (m, N), slope
    1 + 2Δ r and offset 2Δ p_hi, one row per constraint, and the caps x_max,1 … x_max,N
    (N,)."""
    m = slope.shape[0]
    block = np.empty((2 * m + 1, slope.shape[1]))
    block[:m] = slope
    block[m:2 * m] = offset
    block[2 * m] = caps
    return forward_block(delta, block, m, x_start)


def forward_block(delta: NDArray[np.float64], block: NDArray, m: int, x_start: float
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """x, u of :func:`greedy_forward` by the stage loop from the (2m + 1, N) block of its
    slopes, offsets and caps (where the cap binds, without the loop:
    :func:`~robodcn.path_timing._stageloop.capped_recurrence`)."""
    x = _stageloop.capped_recurrence(x_start, block, m)
    return x, (x[1:] - x[:-1]) / (2.0 * delta)  # np.diff(x) / (2.0 * delta)


def greedy_scan(delta: NDArray[np.float64], p_hi: NDArray, r: NDArray,
                x_max: NDArray[np.float64], x_start: float
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`greedy_forward` over all stages at once (:func:`robodcn.path_timing._scan.
    min_affine`, the stage loop as its fallback): equal to the stage loop to rounding
    (relative 1e-12 a stage), faster on large grids that its policy iteration solves in a
    few rounds."""
    n_stages = delta.shape[0]
    two_d = 2.0 * delta[:, None]
    with np.errstate(invalid="ignore"):
        pieces_w = np.concatenate([1.0 + two_d * r[:n_stages], np.zeros((n_stages, 1))],
                                  axis=1)
        pieces_z = np.concatenate([two_d * p_hi[:n_stages], x_max[1:, None]], axis=1)

    def sequential(x0: float, first: int) -> NDArray[np.float64]:
        return _sequential(x0, pieces_w[first:], pieces_z[first:])

    x = _scan.min_affine(float(x_start), pieces_w, pieces_z, sequential)
    return x, np.diff(x) / (2.0 * delta)
