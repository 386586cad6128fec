"""The worst holding torque of each joint over a joint-limit box (``check-config --payload``).

max over lower ≤ q ≤ upper of |g_i(q)| for each joint i, g the gravity torque with the
payload: a grid over the chain joints (about ``GRID_BUDGET`` poses, the box's corners and
edges included), then a pattern search (Hooke & Jeeves, "'Direct search' solution of
numerical and statistical problems", J. ACM 1961) from the best grid poses of each joint:
each step tries the 3^k neighbours at ± h (or the 2k axis neighbours for long chains),
moves to the best one inside the box, and halves h when none is better. All candidates
step together (one vectorised gravity call per step).

The yaw joint is held at the middle of its range: with vertical gravity (the only gravity a
yawed chain accepts) g does not depend on the yaw angle, and the yaw's own holding torque
is 0.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn.dynamics._chain import RigidChain
from robodcn.dynamics._rnea import payload_mass, rnea
from robodcn.errors import InputError

Array = NDArray[np.float64]

#: Grid poses evaluated before the refinement.
GRID_BUDGET = 20000
#: Best grid poses refined per joint.
CANDIDATES = 4
#: Refinement stops when every step is below this fraction of its joint's range.
STEP_TOLERANCE = 1e-9
#: At most this many refinement steps.
MAX_STEPS = 200


def _limits(chain: RigidChain, lower: ArrayLike, upper: ArrayLike) -> tuple[Array, Array]:
    lo = _checks.finite("lower", lower)
    hi = _checks.finite("upper", upper)
    for name, array in (("lower", lo), ("upper", hi)):
        if array.shape != (chain.dof,):
            raise InputError(f"{name} must have shape ({chain.dof},) (one limit per joint, "
                             f"yaw first), got {array.shape}", field=name, value=array)
    bad = np.flatnonzero(lo > hi)
    if bad.size:
        i = int(bad[0])
        raise InputError(f"joint {i}: lower limit {lo[i]!r} is above upper limit {hi[i]!r}",
                         field=f"lower[{i}]", value=float(lo[i]))
    return lo, hi


def holding_torque_box(chain: RigidChain, lower: ArrayLike, upper: ArrayLike,
                       payload_kg: float = 0.0) -> Array:
    """Per joint, the largest |gravity torque| (dof,), N·m, over the box lower ≤ q ≤ upper.

    Parameters
    ----------
    chain : RigidChain
    lower, upper : array_like (dof,)
        Joint limits, rad, yaw first.
    payload_kg : float
        Point mass at the tool point, kg.
    """
    lo, hi = _limits(chain, lower, upper)
    payload = payload_mass(payload_kg)
    first = chain.dof - len(chain.links)
    k = len(chain.links)
    span = hi[first:] - lo[first:]
    base = 0.5 * (lo + hi)

    def torques(chain_q: Array) -> Array:
        q = np.repeat(base[None, :], chain_q.shape[0], axis=0)
        q[:, first:] = chain_q
        zero = np.zeros_like(q)
        return np.abs(rnea(chain, q, zero, zero, payload))[:, first:]

    per_axis = max(3, int(GRID_BUDGET ** (1.0 / k)))
    axes = [np.linspace(lo[first + d], hi[first + d], per_axis) for d in range(k)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, k)
    values = torques(grid)
    best = values.max(axis=0)

    # Candidates: the CANDIDATES best grid poses of each joint, refined for that joint.
    count = min(CANDIDATES, grid.shape[0])
    order = np.argsort(-values, axis=0)[:count]              # (count, k)
    centre = grid[order.T.reshape(-1)]                      # (k·count, k)
    joint = np.repeat(np.arange(k), count)                  # the joint each one serves
    value = values[order.T.reshape(-1), joint]
    step = np.repeat((span / (per_axis - 1))[None, :], centre.shape[0], axis=0)
    if 3 ** k <= 81:
        moves = np.array([m for m in itertools.product((-1.0, 0.0, 1.0), repeat=k)
                          if any(m)])
    else:
        moves = np.concatenate([np.eye(k), -np.eye(k)])
    tiny = STEP_TOLERANCE * np.maximum(span, 1e-12)
    for _ in range(MAX_STEPS):
        if (step <= tiny).all():
            break
        trial = np.clip(centre[:, None, :] + moves[None, :, :] * step[:, None, :],
                        lo[first:], hi[first:])                 # (c, m, k)
        tried = torques(trial.reshape(-1, k)).reshape(trial.shape[0], trial.shape[1], k)
        mine = tried[np.arange(trial.shape[0]), :, joint]       # (c, m)
        pick = np.argmax(mine, axis=1)
        gain = mine[np.arange(trial.shape[0]), pick]
        better = gain > value
        centre = np.where(better[:, None], trial[np.arange(trial.shape[0]), pick], centre)
        value = np.where(better, gain, value)
        step = np.where(better[:, None], step, 0.5 * step)
    np.maximum.at(best, joint, value)
    out = np.zeros(chain.dof)
    out[first:] = best
    return out


__all__ = ["holding_torque_box"]
