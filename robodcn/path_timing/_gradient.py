"""numpy.gradient along axis 0 with its coefficients computed once per grid.

The path's q′ and q″ (:func:`~robodcn.path_timing.topp.path_derivatives`) and the C²
interpolant's slopes (:class:`~robodcn.path_timing.arclength.Smooth`) differentiate several
arrays on one grid x; numpy.gradient recomputes its coefficients (and checks) every call.

Both differentiate the same data too: the planner times a piece's dense samples (q′, q″ for
TOPP-RA) and then samples their C² interpolant, whose slopes are those q′, q″. So the
repeated gradients f′, f″, … of the last few (x, f) are kept until asked for once more
(:func:`repeated`, keyed by their bytes: the same bits in, the same bits out): the second
computation becomes a lookup, and nothing is served across plans (a plan asked again
computes its gradients again, as a different plan would).
"""

from __future__ import annotations

import threading

import numpy as np
from numpy.typing import NDArray

__all__ = ["Gradient", "repeated"]

#: (x, f) pairs whose repeated gradients are kept (the pieces of a plan, timed then sampled)
KEEP = 4
#: Largest f (entries) whose gradients are kept (a 10 s plan's pieces fit; larger are rare)
KEEP_SIZE = 50_000

_kept: dict[tuple, list[NDArray[np.float64]]] = {}
_lock = threading.Lock()


def repeated(x: NDArray[np.float64], f: NDArray[np.float64], order: int
             ) -> list[NDArray[np.float64]]:
    """[f′, f″, …] (``order`` of them) on x, f′ = Gradient(x)(f) and each next the gradient
    of the one before, as fresh arrays: kept from the first ask (copies handed out) and
    handed over at the second (module doc).

    ``x`` (n ≥ 2,) and ``f`` (n, …) float64."""
    if f.size > KEEP_SIZE:
        return _repeated(x, f, order)
    key = (f.shape, x.tobytes(), f.tobytes())
    with _lock:
        got = _kept.pop(key, None)
    if got is not None and len(got) >= order:
        return got[:order]  # no longer kept: the caller's own
    got = _repeated(x, f, order)
    with _lock:
        if len(_kept) >= KEEP:
            del _kept[next(iter(_kept))]  # the oldest entry
        _kept[key] = got
    return [d.copy() for d in got]


def _repeated(x: NDArray[np.float64], f: NDArray[np.float64], order: int
              ) -> list[NDArray[np.float64]]:
    grad = Gradient(x)
    out = []
    for _ in range(order):
        f = grad(f)
        out.append(f)
    return out


class Gradient:
    """numpy.gradient(f, x, axis=0, edge_order=2 (1 for two samples)) with its coefficients
    computed once for every f on the same x (the same formulas and operation order as
    numpy's, so the same bits: second-order central differences inside, one-sided at the
    ends; the uniform-spacing case as numpy takes it).

    The scalar end coefficients are Python floats (the same IEEE double operations as
    numpy's float64 scalars, without their per-operation overhead), and the interior
    coefficients are kept as columns too, for f of shape (n, k)."""

    def __init__(self, x: NDArray[np.float64]) -> None:
        dx = x[1:] - x[:-1]  # np.diff
        self.n = x.shape[0]
        steps = dx.tolist()
        h = steps[0]
        self.uniform = steps.count(h) == len(steps)
        if self.uniform:
            self.h = h
            self.left = (-1.5 / h, 2.0 / h, -0.5 / h)
            self.right = (0.5 / h, -2.0 / h, 1.5 / h)
            return
        self.dx = dx
        self.first, self.last = h, steps[-1]
        if self.n > 2:
            dx1, dx2 = dx[:-1], dx[1:]
            both = dx1 + dx2  # numpy's formulas compute it twice: the same bits
            self.a = -dx2 / (dx1 * both)
            self.b = (dx2 - dx1) / (dx1 * dx2)
            self.c = dx1 / (dx2 * both)
            self.columns = (self.a[:, None], self.b[:, None], self.c[:, None])
            d1, d2 = steps[0], steps[1]
            self.left = (-(2.0 * d1 + d2) / (d1 * (d1 + d2)), (d1 + d2) / (d1 * d2),
                         -d1 / (d2 * (d1 + d2)))
            d1, d2 = steps[-2], steps[-1]
            self.right = (d2 / (d1 * (d1 + d2)), -(d2 + d1) / (d1 * d2),
                          (2.0 * d2 + d1) / (d2 * (d1 + d2)))

    def __call__(self, f: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.empty_like(f)
        if self.n == 2:  # numpy's edge_order=1
            h0 = self.h if self.uniform else self.first
            h1 = self.h if self.uniform else self.last
            out[0] = (f[1] - f[0]) / h0
            out[-1] = (f[-1] - f[-2]) / h1
            return out
        inner = out[1:-1]  # written in place: the same operations, no temporaries to copy
        if self.uniform:
            np.subtract(f[2:], f[:-2], out=inner)
            inner /= 2.0 * self.h
        else:
            if f.ndim == 1:
                a, b, c = self.a, self.b, self.c
            elif f.ndim == 2:
                a, b, c = self.columns
            else:
                a, b, c = (m.reshape((-1,) + (1,) * (f.ndim - 1))
                           for m in (self.a, self.b, self.c))
            np.multiply(a, f[:-2], out=inner)  # (a f_{i−1} + b f_i) + c f_{i+1}
            inner += b * f[1:-1]
            inner += c * f[2:]
        if f.ndim > 2:
            a, b, c = self.left
            out[0] = a * f[0] + b * f[1] + c * f[2]
            a, b, c = self.right
            out[-1] = a * f[-3] + b * f[-2] + c * f[-1]
            return out
        # the two end rows in Python floats (a few entries: numpy's per-call cost would be
        # most of the whole gradient); the same products and sums in the same order
        a, b, c = self.left
        f0, f1, f2 = f[:3].tolist()
        if f.ndim == 1:
            out[0] = a * f0 + b * f1 + c * f2
        else:
            out[0] = [a * x0 + b * x1 + c * x2 for x0, x1, x2 in zip(f0, f1, f2, strict=True)]
        a, b, c = self.right
        f0, f1, f2 = f[-3:].tolist()
        if f.ndim == 1:
            out[-1] = a * f0 + b * f1 + c * f2
        else:
            out[-1] = [a * x0 + b * x1 + c * x2 for x0, x1, x2 in zip(f0, f1, f2, strict=True)]
        return out
