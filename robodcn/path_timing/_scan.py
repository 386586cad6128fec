"""Recurrences x_{i+1} = F_i(x_i), F_i = min over affine pieces, without a Python stage loop.

TOPP-RA's two passes (:mod:`robodcn.path_timing.reachability`) are such recurrences: each
stage takes the least of a few affine functions of the neighbouring stage's value (one per
constraint row, and a cap), floored at 0. Given which piece is least at every stage (a
*policy*), the recurrence is affine, x_{i+1} = W_i x_i + Z_i, and its prefix compositions
come from a Hillis–Steele scan in ⌈log₂ N⌉ vectorised steps ((W, Z) ∘ (W', Z') =
(W W', W Z' + Z)). Policy iteration: the policy is read off the latest values, the affine
recurrence solved again, until the values satisfy x_{i+1} = F_i(x_i) at every stage (to
rounding). The stages up to the first one that does not are exact, so every round makes
progress; after a few rounds (or a non-finite scan) the rest is the plain sequential loop.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

#: Policy-iteration rounds before the sequential loop takes over
ROUNDS = 8
#: Relative residual |x_{i+1} − F_i(x_i)| accepted as rounding
TOLERANCE = 1e-12


def _prefix(w: NDArray, z: NDArray) -> tuple[NDArray, NDArray]:
    """(A_i, B_i) with f_i ∘ … ∘ f_0 = A_i x + B_i for f_i = w_i x + z_i."""
    a, b = w.copy(), z.copy()
    n = a.shape[0]
    shift = 1
    while shift < n:
        b[shift:] = a[shift:] * b[:-shift] + b[shift:]
        a[shift:] = a[shift:] * a[:-shift]
        shift *= 2
    return a, b


def _evaluate(slope: NDArray, offset: NDArray, x: NDArray) -> tuple[NDArray, NDArray]:
    """min over pieces of slope·x + offset, floored at 0, and the least piece (−1: the
    floor); pieces with an infinite offset never bind."""
    vals = slope * x[:, None] + offset  # x finite: an infinite offset stays infinite
    best = np.argmin(vals, axis=1)
    out = vals[np.arange(vals.shape[0]), best]
    floor = out < 0.0
    return np.where(floor, 0.0, out), np.where(floor, -1, best)


def min_affine(x0: float, slope: NDArray, offset: NDArray,
               sequential: Callable[[float, int], NDArray[np.float64]]
               ) -> NDArray[np.float64]:
    """x (N + 1,) with x_0 = x0 and x_{i+1} = max(0, min_j(slope_ij x_i + offset_ij)).

    ``slope``, ``offset`` (N, m): the pieces of each stage (offset inf: none);
    ``sequential(x_start, first)`` the plain loop from stage ``first`` with x_first =
    x_start, returning x_first.. x_N (the fallback, module doc).

    The first policy is read at x0 on every stage: from rest (x0 = 0) that is the
    strongest acceleration (forward) or deceleration (backward), right until the first
    cap binds; each round then corrects the policy past the first stage it got wrong.
    """
    n = slope.shape[0]
    x = np.empty(n + 1)
    x[0] = x0
    if n == 0:
        return x
    rows = np.arange(n)
    _, policy = _evaluate(slope, offset, np.full(n, x0))
    start = 0
    for _ in range(ROUNDS):
        safe = np.where(policy >= 0, policy, 0)
        w = np.where(policy >= 0, slope[rows, safe], 0.0)[start:]
        z = np.where(policy >= 0, offset[rows, safe], 0.0)[start:]
        with np.errstate(over="ignore", invalid="ignore"):
            a, b = _prefix(w, z)
            x[start + 1:] = a * x[start] + b
        if not np.isfinite(x[start + 1:]).all():
            break
        got, policy_new = _evaluate(slope[start:], offset[start:], x[start:-1])
        bad = np.abs(x[start + 1:] - got) > TOLERANCE * (1.0 + np.abs(got))
        if not bad.any():
            # exact to rounding: take the direct evaluation, stage by stage consistent
            return x
        first = int(np.argmax(bad))
        # stages before ``first`` are right: x[start + first + 1] is F of a right value
        x[start + first + 1] = got[first]
        policy[start:] = policy_new
        start += first + 1
        if start >= n:
            return x
    x[start:] = sequential(float(x[start]), start)
    return x
