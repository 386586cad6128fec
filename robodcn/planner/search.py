"""Auto timing: the fewest sample periods per piece whose finite differences pass.

See the :mod:`robodcn.planner` docstring ("Duration"). Nothing here raises to steer the
search: the joins between pieces are checked by :func:`robodcn.planner.validate.check`,
whose :class:`~robodcn.errors.Violation` gives the ratio to slow down by.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from robodcn import timing
from robodcn.config import Arm
from robodcn.contract import MAX_SAMPLES, intervals
from robodcn.errors import TooLargeError
from robodcn.path_timing.limits import JointLimits
from robodcn.planner import arm_arrays
from robodcn.planner.path import COARSE, Piece

MAX_SEARCH_STEPS = 40


def fd_need(q: NDArray[np.float64], arm: Arm, lim: JointLimits | None = None) -> float:
    """Shortest duration (s) of the sampled joints q (the planner's own: finite) under the
    arm's limits (jerk included where a joint sets one; ``lim`` the arm's
    ``JointLimits.of(arm, torque=False)`` when the caller has them)."""
    if lim is None:
        lim = arm_arrays.limits_of(arm, torque=False)
    return timing.fd_min_duration_unchecked(q, lim.v, lim.a, j_max=lim.j)


def estimate(piece: Piece, arm: Arm, reference: NDArray | None,
             lim: JointLimits | None = None) -> tuple[float, NDArray | None]:
    """Shortest duration on a uniform grid of COARSE periods (≈ the closed form), seconds,
    and the piece's last joints; (1 s, None) if the path leaves the workspace (validation
    then names the sample)."""
    _, q, _ = piece.sample(COARSE, arm, reference)
    if q is None:
        return 1.0, None
    return fd_need(q, arm, lim), q[-1]


def search(piece: Piece, arm: Arm, reference: NDArray | None, rate: float,
           cache: dict[int, tuple] | None = None) -> int:
    """Smallest N (sample periods) whose samples pass the velocity/acceleration checks.

    Bracket, then bisect: from the estimate, grow N (to the finite-difference closed form's
    ⌈T_fd(N)·rate⌉, at least doubling) until it passes; then try the closed form's guess just
    below and bisect between the largest failing and the smallest passing N until they are
    neighbours. The result passes and N − 1 fails (or N = 1). Typically 2–3 evaluations,
    the estimate's N and N − 1 sampled in one pass.
    ``cache`` (a dict) keeps each evaluation's ``piece.sample(N, arm, reference)`` by N, so
    the caller need not sample the chosen N again.
    """

    lim = arm_arrays.limits_of(arm, torque=False)  # built once per arm
    if cache is None:
        cache = {}

    def need(n: int) -> float | None:
        sampled = cache.get(n)
        if sampled is None:
            sampled = cache[n] = piece.sample(n, arm, reference)
        q = sampled[1]
        # None: out of reach; validation reports it with the real sample index
        return None if q is None else fd_need(q, arm, lim)

    n = intervals(max(estimate(piece, arm, reference, lim)[0], 1e-12), rate)
    if 2 <= n < MAX_SAMPLES:
        # the estimate is usually exact: N and N − 1 are the two evaluations the search
        # then makes, so they are sampled together (Piece.sample_many: one pass)
        for m, sampled in zip((n - 1, n), piece.sample_many((n - 1, n), arm, reference),
                              strict=True):
            cache[m] = sampled
    fail, ok = 0, None  # largest N known to fail (0: none), smallest known to pass
    stepped_down = False
    for _ in range(MAX_SEARCH_STEPS):
        if ok is not None and ok - fail <= 1:
            return ok
        if n + 1 > MAX_SAMPLES:
            raise TooLargeError(f"the 'auto' duration needs more than {MAX_SAMPLES} samples at "
                             f"{rate:g} Hz: lower rate_hz or raise the joint limits",
                             field="duration", value="auto")
        t_need = need(n)
        if t_need is None:
            return ok or n
        guess = max(1, math.ceil(t_need * rate - 1e-9))
        if t_need <= n / rate:
            ok = n
            if fail < guess < ok:
                n = guess
            elif not stepped_down:
                n, stepped_down = ok - 1, True  # usually the estimate was exact: confirm
            else:
                n = (fail + ok) // 2
        else:
            fail = n
            if ok is None:
                n = max(guess, 2 * n)
            else:
                n = guess if fail < guess < ok else (fail + ok) // 2
    return ok if ok is not None else n


def split(total: int, weights: Sequence[float]) -> list[int]:
    """Split ``total`` periods over segments ∝ weights (largest remainder, each ≥ 1)."""
    w = np.maximum(np.asarray(weights, dtype=np.float64), 0.0)
    m = len(w)
    if w.sum() <= 0.0:
        w = np.ones(m)
    share = (total - m) * w / w.sum()
    base = np.floor(share).astype(int)
    rest = (total - m) - base.sum()
    order = np.argsort(-(share - base), kind="stable")
    base[order[:rest]] += 1
    return (base + 1).tolist()


