"""Planar serial-arm forward kinematics (conventions: :mod:`._planar`).

φ_i = q_1 + … + q_i; the tool point is Σ l_i·(cos φ_i, sin φ_i) and θ = φ_k (a 2-joint arm
reports θ = q_1 + q_2). Long arrays take cos φ and sin φ from t = tan(φ/2) (Weierstrass).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.kinematics._planar import _joints, _links

__all__ = ["FK_TAN_ROWS", "fk", "fk_unchecked"]


#: From this many rows on, :func:`fk` takes cos and sin from tan(φ/2) (more numpy calls, each
#: cheaper per row).
FK_TAN_ROWS = 256


def fk(links: Sequence[float], q: ArrayLike) -> NDArray[np.float64]:
    """Forward kinematics: poses (n, 3) = (Σ l_i cos φ_i, Σ l_i sin φ_i, φ_k) for q (n, k)."""
    links = _links(links)
    return fk_unchecked(links, _joints(q, len(links)))


def fk_unchecked(links: tuple[float, ...], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`fk` without the argument checks, for callers that validated them (the
    planner): ``links`` a tuple of 2 or 3 positive floats, ``q`` a finite float64 (n, k)
    array with k = len(links)."""
    n, k = q.shape
    if n < FK_TAN_ROWS:  # few rows: fewer numpy calls win
        phi = np.add.accumulate(q, axis=1)  # np.cumsum's own ufunc, without its wrappers
        out = np.empty((n, 3))
        lengths = np.asarray(links)
        out[:, 0] = np.cos(phi) @ lengths
        out[:, 1] = np.sin(phi) @ lengths
        out[:, 2] = phi[:, -1]
        return out
    phi = np.empty((k, n))  # joint rows: every step below is a contiguous 1-D ufunc
    np.cumsum(q.T, axis=0, out=phi)
    # cos φ and sin φ from t = tan(φ/2) (Weierstrass), as in _block: numpy's SIMD tan is
    # ~10× faster than cos + sin, and the rational forms are within a few ulp of them.
    t = np.multiply(phi, 0.5)
    np.tan(t, out=t)
    inv = t * t
    inv += 1.0
    np.reciprocal(inv, out=inv)
    c = 2.0 * inv  # (1 − t²)/(1 + t²) = 2/(1 + t²) − 1
    c -= 1.0
    t *= inv
    t *= 2.0  # sin φ = 2t/(1 + t²)
    out = np.empty((n, 3))
    # l_j·cos φ_j and l_j·sin φ_j in place, summed in joint order into row 0 (the same
    # products and sums: a long plan's fresh temporaries cost more than the arithmetic)
    c[0] *= links[0]
    t[0] *= links[0]
    x, y = c[0], t[0]
    for j in range(1, k):
        c[j] *= links[j]
        x += c[j]
        t[j] *= links[j]
        y += t[j]
    out[:, 0] = x
    out[:, 1] = y
    out[:, 2] = phi[-1]
    return out
