"""The stage constraints of TOPP-RA's interpolated discretisation, one row per constraint.

:func:`robodcn.path_timing.topp.solve` on the planner's grids (~100 stages, 2–6 joints, every
joint moving, no torque rows) spends its time in numpy's per-call overhead, and most in
reductions over the short constraint axis of (N, m) arrays (a min over 6 entries a stage
takes ~5 µs on 100 stages, a min over 100 entries a constraint ~1 µs). Here the arrays are
(m, N): a row per constraint (the k joints, then the k virtual joints of the
"interpolation" scheme, Pham & Pham 2018 §V-B: :func:`robodcn.path_timing.topp.interpolated`),
a column per grid point, so every reduction runs along the grid, and the two passes read
the rows straight into the stage loop (:mod:`robodcn.path_timing._stageloop`).

Every value is the general path's bits (:func:`robodcn.path_timing.topp.interpolated`, then
:func:`robodcn.path_timing.reachability.stage_constraints`): the same elementwise operations
in the same order where all of that path's masks are true, and minima (exact) over the same
values; :func:`constraints` returns None where a mask would not be (a still joint, an
overflowing q''/q'), and the caller takes the general path.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from robodcn.path_timing import reachability
from robodcn.path_timing.reachability import _FLAT


def constraints(delta: NDArray[np.float64], dq: NDArray[np.float64],
                ddq: NDArray[np.float64], v_max: NDArray[np.float64],
                a_max: NDArray[np.float64]
                ) -> tuple[NDArray, NDArray, NDArray] | None:
    """(half, r, x_cap) of the interpolated stage constraints, or None (module doc).

    Parameters
    ----------
    delta : (N,) stage lengths Δ_i = s_{i+1} − s_i
    dq, ddq : (N + 1, k) q'(s_i), q''(s_i)
    v_max, a_max : (k,) limits, inf where unlimited

    Returns
    -------
    half, r : (2k, N + 1): the u-bounds L = −half + r x ≤ u ≤ half + r x of every joint and
        virtual joint (p_lo = −half, p_hi = half of ``stage_constraints``), r = −q''/q'
    x_cap : (N + 1,) the largest feasible x at each point: min_j (v_j / q'_j)² and the
        crossings (half_l + half_j) / |r_j − r_l| of every unordered pair with r_j ≠ r_l
        (the general formula's gap / |d|)
    """
    k = dq.shape[1]
    n = dq.shape[0]
    dq_t, ddq_t = dq.T, ddq.T
    # the virtual joint of point i: q' = q'_{i+1} + 2Δ_i q''_{i+1}, q'' = q''_{i+1} (the last
    # point's own, with Δ = 0): ``interpolated``'s nxt_dq + 2.0 * step * nxt_ddq
    d1 = np.empty((2 * k, n))
    d1[:k] = dq_t
    virtual = np.multiply(2.0 * delta, ddq_t[:, 1:], out=d1[k:, :-1])
    virtual += dq_t[:, 1:]  # q'_{i+1} + 2Δ_i q''_{i+1} (a sum: either order, the same bits)
    d1[k:, -1] = dq_t[:, -1] + 2.0 * 0.0 * ddq_t[:, -1]
    abs_d1 = np.abs(d1)
    if not np.logical_and.reduce(abs_d1 > _FLAT, axis=None):  # .all() without its wrapper
        return None
    # r = −q''/q' of each row, the virtual rows' q'' being the next point's (−q'')/q' as the
    # general −ddq / safe
    minus = -ddq_t
    r = np.empty((2 * k, n))
    np.divide(minus, d1[:k], out=r[:k])
    np.divide(minus[:, 1:], d1[k:, :-1], out=r[k:, :-1])
    np.divide(minus[:, -1], d1[k:, -1], out=r[k:, -1])
    if not np.logical_and.reduce(np.isfinite(r), axis=None):  # .all() without its wrapper
        return None
    a_col = a_max[:, None]
    half = np.empty((2 * k, n))
    np.divide(a_col, abs_d1[:k], out=half[:k])
    np.divide(a_col, abs_d1[k:], out=half[k:])
    # the virtual joints have no velocity limit ((inf / q')² = inf never binds the min);
    # d1[:k] is q' as a C-ordered copy: the min runs along memory
    x_cap = np.minimum.reduce((v_max[:, None] / d1[:k]) ** 2, axis=0)
    # each unordered pair once (l < j): |r_l − r_j| is the rise r_j − r_l of its order with
    # r_j > r_l, and half_l + half_j = half_j + half_l its gap p_hi,l − p_lo,j (exact
    # sign flips and sums: the same bits as over every ordered pair)
    il, jl = reachability._pairs(2 * k)
    rise = r[il]
    rise -= r[jl]
    np.abs(rise, out=rise)
    gap = half[il]
    gap += half[jl]
    rising = rise > 0
    if np.logical_and.reduce(rising, axis=None):  # no pair parallel (the usual case)
        cross = np.divide(gap, rise, out=gap)
    else:
        cross = np.empty(rise.shape)  # np.full without its wrapper
        cross.fill(np.inf)
        np.divide(gap, rise, out=cross, where=rising)
    return half, r, np.minimum(x_cap, np.minimum.reduce(cross, axis=0))


class Pieces(NamedTuple):
    """The affine pieces of both passes on N stages as the stage loop reads them
    (:func:`robodcn.path_timing._stageloop.capped_recurrence`): (2m + 1, N) blocks, one
    row per constraint, then the cap.

    ``forward``: slope 1 + 2Δ r and offset 2Δ·half, stages in order (the forward pass's
    pieces (1 + 2Δ r) x + 2Δ p_hi, :func:`~robodcn.path_timing.reachability.
    greedy_forward`), the cap row x_max,1 … x_max,N left for the caller (known after the
    backward pass). ``backward``: W = 1 / slope and Z = 2Δ·half·W, stages reversed (the
    backward pass's order; :func:`~robodcn.path_timing.reachability.backward_pieces`:
    Z = −2Δ p_lo W and −2Δ·(−half) = 2Δ·half exactly), the cap row x_cap,N−1 … x_cap,0."""

    forward: NDArray[np.float64]
    backward: NDArray[np.float64]
    m: int

    @property
    def slope(self) -> NDArray[np.float64]:
        return self.forward[:self.m]

    @property
    def offset(self) -> NDArray[np.float64]:
        return self.forward[self.m:2 * self.m]

    @property
    def w(self) -> NDArray[np.float64]:
        """W in stage order (a view)."""
        return self.backward[:self.m, ::-1]

    @property
    def z(self) -> NDArray[np.float64]:
        """Z in stage order (a view)."""
        return self.backward[self.m:2 * self.m, ::-1]


def pieces(delta: NDArray[np.float64], half: NDArray[np.float64], r: NDArray[np.float64],
           x_cap: NDArray[np.float64]) -> Pieces:
    """:class:`Pieces` of the first N = len(delta) points of :func:`constraints`, the
    backward caps from ``x_cap`` (N + 1,)."""
    n_stages = delta.shape[0]
    m = half.shape[0]
    two_d = 2.0 * delta
    half, r = half[:, :n_stages], r[:, :n_stages]
    forward = np.empty((2 * m + 1, n_stages))
    slope = np.multiply(two_d, r, out=forward[:m])
    slope += 1.0  # 1 + 2Δ r
    offset = np.multiply(two_d, half, out=forward[m:2 * m])
    backward = np.empty((2 * m + 1, n_stages))
    w, z = backward[:m], backward[m:2 * m]
    if not np.logical_and.reduce(np.isfinite(half), axis=None):  # (.all() without its wrapper)
        # an unlimited acceleration: backward_pieces' own rules
        w_s, z_s = reachability.backward_pieces(delta, -half, r)
        w[:] = w_s[:, ::-1]
        z[:] = z_s[:, ::-1]
    else:
        # backward_pieces' values: W = 1 / slope, Z = (−2Δ·p_lo)·W (−2Δ·(−half) is the
        # offset's bits) where the slope is positive, else (0, inf): no bound
        good = slope[:, ::-1] > 0
        if np.logical_and.reduce(good, axis=None):  # every slope positive (the usual case)
            np.divide(1.0, slope[:, ::-1], out=w)
            np.multiply(offset[:, ::-1], w, out=z)
        else:
            w[:] = 0.0
            np.divide(1.0, slope[:, ::-1], out=w, where=good)
            z[:] = np.inf
            np.multiply(offset[:, ::-1], w, out=z, where=good)
    backward[2 * m] = x_cap[n_stages - 1::-1] if n_stages else x_cap[:0]
    return Pieces(forward, backward, m)
