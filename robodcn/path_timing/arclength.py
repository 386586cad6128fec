"""Joint-space arc length as the path parameter: bounded derivatives at singular ends.

Near a boundary singularity (a stretched or folded arm) a pose path that moves at a finite
rate makes the joints move like q ≈ c·√(u − u₀): q′(u) grows without bound and a grid that
is uniform in u puts almost all of the joint motion into its first stage, where a constant
s̈ gives q ∝ t (a velocity step the stream's finite differences see as an unbounded
acceleration). Parameterised by its joint-space arc length σ (|dq/dσ| = 1 between
samples), the same path is q ≈ c′·σ there: smooth, with bounded q′, q″, q‴, so TOPP-RA's
stage constraints hold between the grid points too.

* :func:`arc_length` — σ (n,) of joint samples (n, k), normalised to [0, 1]: the arc
  length of the graph (q(u), L u), joint-space arc length where the joints race, ∝ u where
  they turn back.
* :class:`Monotone` — the monotone cubic (Fritsch–Carlson PCHIP: F. N. Fritsch and
  R. E. Carlson, "Monotone Piecewise Cubic Interpolation", SIAM J. Numer. Anal. 17(2), 1980)
  through increasing data, C¹, exact on quadratics near an end (the three-point end
  slope), used both ways: σ(u) and u(σ).
* :class:`Smooth` — the C² quintic Hermite through the data with slopes and second
  derivatives by second-order finite differences (those the law is timed with): the
  joints q(σ) the stream samples between the dense samples, and the map u(σ) to the
  path's own parameter (a C¹ interpolant's jumps of q″ at the samples would be jumps of
  joint acceleration the law does not know about).
* :func:`arc_grid` — samples of q uniform in σ, by inverse interpolation u(σ) and a few
  rounds of re-evaluating the joints at the new u (``joints_at``: u → q, e.g. the planner's
  IK), only while the spacing is uneven.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.path_timing import _gradient
from robodcn.path_timing._gradient import Gradient

__all__ = ["UNEVEN", "Monotone", "Smooth", "arc_grid", "arc_length"]

#: Largest step of σ over its mean that counts as even (no resampling needed).
UNEVEN = 1.5
#: Weight of the original parameter in σ (module doc of :func:`arc_length`).
PARAM_SHARE = 1.0
#: Rounds of resampling at most.
ROUNDS = 4


def arc_length(q: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
    """σ_i ∝ Σ_{m ≤ i} √(‖q_m − q_{m−1}‖² + (ε L Δu_m / (u_n − u_0))²), σ ∈ [0, 1]: the arc
    length of the graph (q(u), ε L u) with ε = :data:`PARAM_SHARE` and L the joint-space
    length (1 when no joint moves). Where |q′(u)| ≫ ε L (a singular end) that is the
    joints' arc length; where the joints turn back (|q′(u)| → 0, a cusp of the joint path,
    which in pure arc length would be a corner) it is ∝ u, smooth."""
    d = q[1:] - q[:-1]  # np.diff, and the row norms as numpy.linalg.norm takes them
    d *= d
    step = np.sqrt(np.add.reduce(d, axis=1))
    length = float(np.add.reduce(step))  # step.sum() without its wrapper
    span = float(u[-1] - u[0])
    step = np.hypot(step, PARAM_SHARE * (length if length > 0 else 1.0) * (u[1:] - u[:-1])
                    / span)
    sigma = np.empty(u.shape[0])
    sigma[0] = 0.0
    np.add.accumulate(step, out=sigma[1:])
    sigma /= sigma[-1]
    sigma[-1] = 1.0
    return sigma


#: Queries per data point from which :func:`_right_index` counts instead of searching
MERGE_SHARE = 8


def _right_index(x: NDArray[np.float64], xq: NDArray[np.float64]) -> NDArray[np.int64]:
    """np.searchsorted(x, xq, side="right"): the count of points x_j ≤ each query. For many
    sorted queries (a stream's samples on a dense grid) by one search of x's points among
    the queries instead: x_j ≤ xq_q ⟺ q ≥ p_j, p_j = searchsorted(xq, x_j, "left"), so
    the count is the running sum of how many p_j fall on each query (the same integers;
    unsorted or NaN queries search as numpy does)."""
    n = xq.shape[0] if xq.ndim == 1 else 0
    if n > MERGE_SHARE * x.shape[0] and (xq[1:] >= xq[:-1]).all():
        hits = np.bincount(xq.searchsorted(x, side="left"), minlength=n + 1)
        return np.cumsum(hits[:n])
    return x.searchsorted(xq, side="right")  # (the method: np.searchsorted's wrapper skipped)


def _locate(x: NDArray[np.float64], h: NDArray[np.float64], xq: ArrayLike
            ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64],
                       NDArray[np.float64]]:
    """Queries clipped to [x_0, x_n], each one's interval i, its width h_i and the local
    t = (x_q − x_i) / h_i ∈ [0, 1] (np.clip spelled out without its wrapper: the same
    values)."""
    xq = np.minimum(np.maximum(np.asarray(xq, dtype=np.float64), x[0]), x[-1])
    # clip(searchsorted(x, xq, "right") − 1, 0, intervals − 1) is the count of inner
    # points x_1..x_{n−1} at or below the query (x_0 counts for every query not clipped up
    # to 0, x_n for none not clipped down to the last interval): no clipping
    i = _right_index(x[1:-1], xq)
    hi = h[i]
    return xq, i, hi, (xq - x[i]) / hi


class Monotone:
    """y(x) through (x_i, y_i), x and y strictly increasing: Fritsch–Carlson PCHIP (module
    doc). ``__call__`` takes any array of x (clipped to the data's range)."""

    def __init__(self, x: ArrayLike, y: ArrayLike) -> None:
        self.x = np.asarray(x, dtype=np.float64)
        self.y = np.asarray(y, dtype=np.float64)
        h = np.diff(self.x)
        delta = np.diff(self.y) / h
        d = np.zeros_like(self.x)
        if self.x.shape[0] == 2:
            d[:] = delta[0]
        else:
            # interior: weighted harmonic mean of the neighbouring slopes (Fritsch & Butland)
            w1, w2 = 2 * h[1:] + h[:-1], h[1:] + 2 * h[:-1]
            with np.errstate(divide="ignore", invalid="ignore"):
                inner = (w1 + w2) / (w1 / delta[:-1] + w2 / delta[1:])
            d[1:-1] = np.where((delta[:-1] > 0) & (delta[1:] > 0), inner, 0.0)
            d[0] = self._end(h[0], h[1], delta[0], delta[1])
            d[-1] = self._end(h[-1], h[-2], delta[-1], delta[-2])
        self.h, self.delta, self.d = h, delta, d

    @staticmethod
    def _end(h0: float, h1: float, m0: float, m1: float) -> float:
        """The three-point end slope, kept within [0, 3 m0] (shape preserving)."""
        d = ((2 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
        if d <= 0.0:
            return 0.0
        return min(d, 3.0 * m0)

    def __call__(self, xq: ArrayLike) -> NDArray[np.float64]:
        xq, i, h, t = _locate(self.x, self.h, xq)
        t2, t3 = t * t, t * t * t
        return ((2 * t3 - 3 * t2 + 1) * self.y[i] + (t3 - 2 * t2 + t) * h * self.d[i]
                + (-2 * t3 + 3 * t2) * self.y[i + 1] + (t3 - t2) * h * self.d[i + 1])


#: The quintic Hermite basis (y₀, h y₀′, h² y₀″/2, y₁, h y₁′, h² y₁″/2) in powers t⁰ … t⁵
_POWERS = np.array([[1.0, 0.0, 0.0, -10.0, 15.0, -6.0],
                    [0.0, 1.0, 0.0, -6.0, 8.0, -3.0],
                    [0.0, 0.0, 1.0, -3.0, 3.0, -1.0],
                    [0.0, 0.0, 0.0, 10.0, -15.0, 6.0],
                    [0.0, 0.0, 0.0, -4.0, 7.0, -3.0],
                    [0.0, 0.0, 0.0, 1.0, -2.0, 1.0]])


#: The Hermite basis' coefficients of t³, t⁴, t⁵ per basis function (:meth:`Smooth._hermite`)
_T3, _T4, _T5 = (_POWERS[:, p, None] for p in (3, 4, 5))


class Smooth:
    """y(x) through (x_i, y_i), x strictly increasing, y (n,) or (n, k): on each interval the
    quintic Hermite matching y, y′ and y″ at both ends, y′ and y″ by ``numpy.gradient``
    (second order, also at the ends: the q′, q″ :func:`~robodcn.path_timing.path_derivatives`
    gives the law), so y is C² and exact on quadratics.

    ``monotone``: the data are non-decreasing (n,): slopes below 0 are raised to 0 and the
    result is non-decreasing within [y_0, y_n] (a running maximum removes rounding dips).
    """

    def __init__(self, x: ArrayLike, y: ArrayLike, *, monotone: bool = False) -> None:
        self.x = np.asarray(x, dtype=np.float64)
        self.y = np.asarray(y, dtype=np.float64)
        self.monotone = monotone
        # numpy.gradient, edge order 2 (1 for two samples)
        if monotone:
            grad = Gradient(self.x)
            self.d1 = np.maximum(grad(self.y), 0.0)
            self.d2 = grad(self.d1)
        else:
            # the q′, q″ the law was timed with (path_derivatives), kept from its timing
            self.d1, self.d2 = _gradient.repeated(self.x, self.y, 2)
        self.h = self.x[1:] - self.x[:-1]  # np.diff
        self._table: NDArray[np.float64] | None = None
        self._ends: NDArray[np.float64] | None = None

    def __call__(self, xq: ArrayLike) -> NDArray[np.float64]:
        xq, i, h, t = _locate(self.x, self.h, xq)
        if xq.ndim == 1 and xq.shape[0] > 2 * self.h.shape[0]:
            out = self._horner(i, t)  # many queries per interval: per-interval polynomials
        elif xq.ndim == 1:
            out = self._hermite(i, t, h)
        else:
            out = self._hermite_any(i, t, h)
        if not self.monotone:
            return out
        if xq.ndim == 1 and xq.shape[0] > 1 and (xq[1:] >= xq[:-1]).all():
            out = np.maximum.accumulate(out)
        return np.minimum(np.maximum(out, self.y[0]), self.y[-1])

    def _horner(self, i: NDArray[np.int64], t: NDArray[np.float64]) -> NDArray[np.float64]:
        """The same quintic from its power-basis coefficients in t (one table per Smooth),
        by Horner's rule. For y (n, k) the table is (6, k, intervals): each power's gather
        and every product run along the queries (with t broadcast along a short k axis
        numpy's inner loops would be k long), and the result is copied back to (m, k)."""
        if self._table is None:
            h = self.h[:, None] if self.y.ndim == 2 else self.h
            hh = 0.5 * h * h
            data = np.stack([self.y[:-1], self.d1[:-1] * h, self.d2[:-1] * hh, self.y[1:],
                             self.d1[1:] * h, self.d2[1:] * hh], axis=1)
            powers = np.einsum("mp,im...->ip...", _POWERS, data)  # (intervals, 6[, k])
            # powers first, then joints, intervals last: each gather below is contiguous
            self._table = np.ascontiguousarray(np.moveaxis(powers, 0, -1))
        c = np.take(self._table, i, axis=-1)
        out = c[5] * t
        for p in (4, 3, 2, 1):
            out += c[p]
            out *= t
        out += c[0]
        return np.ascontiguousarray(out.T) if out.ndim == 2 else out

    def _hermite(self, i: NDArray[np.int64], t: NDArray[np.float64], h: NDArray[np.float64]
                 ) -> NDArray[np.float64]:
        """The quintic Hermite basis times the end data of each query's interval, the six
        basis functions as the rows of one array (:meth:`_hermite_any`'s operations in its
        order, so the same bits in far fewer numpy calls): b_m = ((c_m + A_m t³) + B_m t⁴)
        + C_m t⁵ with c = (1, t, t², 0, 0, 0), then b₁, b₄ times h and b₂, b₅ times ½ h²."""
        t2 = t * t
        t3 = t2 * t
        t4, t5 = t3 * t, t3 * t2
        b = _T3 * t3
        b[0] += 1.0
        b[1] += t
        b[2] += t2
        b += _T4 * t4
        b += _T5 * t5
        pair = b.reshape(2, 3, t.shape[0])  # (y, h y′, ½ h² y″) at the interval's two ends
        pair[:, 2] *= 0.5
        pair[:, 1:] *= h
        pair[:, 2] *= h
        if self._ends is None:
            ends = self._ends = np.empty((6, *self.y[1:].shape))  # np.stack, unwrapped
            for m, data in enumerate((self.y, self.d1, self.d2)):
                ends[m] = data[:-1]
                ends[m + 3] = data[1:]
        data = self._ends.take(i, axis=1)  # np.take without its wrapper
        data *= b[:, :, None] if self.y.ndim == 2 else b
        # the sum over the six rows in order (a reduction over the outer axis adds row by
        # row, as the explicit sum does)
        return np.add.reduce(data, axis=0)

    def _hermite_any(self, i: NDArray[np.int64], t: NDArray[np.float64],
                     h: NDArray[np.float64]) -> NDArray[np.float64]:
        """The quintic Hermite basis times the end data of each query's interval (any shape
        of queries)."""
        t2 = t * t
        t3 = t2 * t
        t4, t5 = t3 * t, t3 * t2
        basis = (1 - 10 * t3 + 15 * t4 - 6 * t5, (t - 6 * t3 + 8 * t4 - 3 * t5) * h,
                 0.5 * (t2 - 3 * t3 + 3 * t4 - t5) * h * h, 10 * t3 - 15 * t4 + 6 * t5,
                 (-4 * t3 + 7 * t4 - 3 * t5) * h, 0.5 * (t3 - 2 * t4 + t5) * h * h)
        if self.y.ndim == 2:
            basis = tuple(b[..., None] for b in basis)
        y, d1, d2 = self.y, self.d1, self.d2
        return (basis[0] * y[i] + basis[1] * d1[i] + basis[2] * d2[i]
                + basis[3] * y[i + 1] + basis[4] * d1[i + 1] + basis[5] * d2[i + 1])


def uneven(sigma: NDArray[np.float64]) -> float:
    """Largest step of σ over the mean step."""
    step = sigma[1:] - sigma[:-1]
    # step.max() without its wrapper
    return float(np.maximum.reduce(step) * step.shape[0] / (sigma[-1] - sigma[0]))


def arc_grid(u: NDArray[np.float64], q: NDArray[np.float64],
             joints_at: Callable[[NDArray[np.float64]], NDArray[np.float64] | None],
             keep: ArrayLike = ()) -> tuple[NDArray, NDArray, NDArray]:
    """(u, q, σ): samples of the path about evenly spaced in its arc length σ.

    Parameters
    ----------
    u : (n,) increasing path parameters of the samples ``q`` (n, k)
    joints_at : u (m,) → q (m, k) the path's joints there, or None when it cannot (the
        samples so far are then kept)
    keep : parameters that stay in the grid (e.g. knots)

    Returns the same number of samples (plus ``keep``) when the spacing was uneven
    (:data:`UNEVEN`), else the input with its σ.
    """
    sigma = arc_length(q, u)
    keep = np.asarray(keep, dtype=np.float64)
    n = u.shape[0]
    for _ in range(ROUNDS):
        if uneven(sigma) <= UNEVEN:
            break
        target = np.linspace(0.0, 1.0, n)
        u_new = Monotone(sigma, u)(target)
        u_new = np.unique(np.concatenate([u_new, keep, u[:1], u[-1:]]))
        q_new = joints_at(u_new)
        if q_new is None:
            break
        u, q = u_new, q_new
        sigma = arc_length(q, u)
    return u, q, sigma
