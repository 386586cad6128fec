"""The recurrence x_{i+1} = max(0, min(min_j(w_ij x_i + z_ij), 0·x_i + cap_i)) in plain floats.

TOPP-RA's two passes (:mod:`robodcn.path_timing.reachability`) are this recurrence: each stage
takes the least of a few affine functions of the neighbouring stage's value (one per
constraint row) and a cap, floored at 0. On a grid of ~100 stages with 2–6 joints numpy's
per-call overhead (~1 µs) dominates every vectorised formulation (the policy iteration of
:mod:`robodcn.path_timing._scan` needs ~50 calls a round), so here the stage loop runs in
plain Python floats, unrolled over the pieces: one generated function per piece count, whose
body is ``t = x * w_j + z_j; if t < m: m = t`` for every piece (no inner loop, no numpy
scalar). Its operations and their order are those of the sequential reference loops
(``reachability._sequential``), so the values are the same bits: the running
minimum starts at +inf and takes a piece only when strictly less (a NaN piece never binds),
the cap is the piece 0·x + cap, and m ≤ 0 (or NaN) gives 0.

Where the cap binds (TOPP-RA's passes follow the velocity cap or the controllable set's
edge over most of a plan) a stage's value does not depend on the value before it, so
:func:`capped_recurrence` runs the loop only where it must (module doc there).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable, Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["capped_recurrence", "recurrence"]

Loop = Callable[[float, Sequence[Iterable[float]], list[float]], bool]
#: Touches that hold no stage before the loop stops looking for touches
MISSES = 2


def recurrence(x0: float, columns: Sequence[Iterable[float]], m: int) -> list[float]:
    """[x_0, x_1, …, x_N] with x_0 = ``x0`` and, stage by stage,

        x_{i+1} = max(0, min(min_j (w_ij x_i + z_ij), 0·x_i + cap_i))

    Parameters
    ----------
    x0 : the first value
    columns : 2m + 1 per-stage sequences of Python floats, read in step: w_0 … w_{m−1},
        z_0 … z_{m−1}, cap (e.g. ``ndarray.tolist()`` of an (m, N) array's rows, which numpy
        converts faster than an (N, m) array's; reversed for a backward pass); an infinite
        offset never binds; the loop stops at the shortest
    m : pieces a stage besides the cap (≥ 0)
    """
    if len(columns) != 2 * m + 1:
        raise ValueError(f"{2 * m + 1} columns expected for {m} pieces, got {len(columns)}")
    out = [float(x0)]
    _loop(m, False)(out[0], columns, out)
    return out


@functools.cache
def _loop(m: int, exits: bool) -> Loop:
    """The unrolled stage loop for ``m`` pieces a stage (compiled once per m), appending
    each value to ``out``; with ``exits``, it returns True right after a stage whose value
    equals its cap (a touch: :func:`capped_recurrence`), else False at the end.

    Generated source, since Python has no other way to unroll a loop over a stage's pieces:
    an inner ``for`` over them costs about twice the unrolled body (measured on 100 stages ×
    7 pieces: 40 µs vs 20 µs)."""
    targets = ", ".join([*(f"w{j}" for j in range(m)), *(f"z{j}" for j in range(m)), "cap,"])
    body = "".join(f"        t = x * w{j} + z{j}\n        if t < m:\n            m = t\n"
                   for j in range(m))
    touch = "        if x == cap:\n            return True\n" if exits else ""
    src = (f"def loop(x, columns, out):\n"
           f"    append = out.append\n"
           f"    for {targets} in zip(*columns):\n"
           f"        m = inf\n"
           f"{body}"
           f"        t = x * 0.0 + cap\n"
           f"        if t < m:\n"
           f"            m = t\n"
           f"        x = m if m > 0.0 else 0.0\n"
           f"        append(x)\n"
           f"{touch}"
           f"    return False\n")
    namespace: dict[str, object] = {"inf": float("inf")}
    exec(compile(src, f"<robodcn.path_timing._stageloop m={m} exits={exits}>", "exec"),
         namespace)
    return namespace["loop"]  # type: ignore[return-value]


def capped_recurrence(x0: float, block: NDArray[np.float64], m: int) -> NDArray[np.float64]:
    """:func:`recurrence` (the same values, bit for bit, as an (N + 1,) array) of the
    pieces in ``block``,
    running the loop only where a stage's value can depend on the one before.

    A stage yields its *fill* f_i = cap_i if cap_i > 0 else 0 when its cap binds. When
    the loop's value equals the cap (a touch: x_{i+1} ≥ 0 is floored, so it equals cap_i
    only where that is its fill, x_{i+1} = f_i bit for bit), the next stages are
    checked at once: stage j is *held* when, entered with τ_j = f_{j−1} (finite), no
    piece lies below its cap, fl(τ_j w_j + z_j) ≥ cap_j for each piece (the loop's own
    float operations on the same x; a NaN piece fails), so the loop's minimum is the
    cap's value and x_{j+1} = f_j = τ_{j+1} (the signs of a zero x or cap change no
    comparison and no floored value). The held run's fills are copied, and the loop
    resumes at the first stage that is not held. The loop reads the block's rows through
    a memoryview, which yields each entry as a Python float when the loop reaches its
    stage (a ``tolist`` would convert stages the loop never runs: ~10 ns an entry); after
    :data:`MISSES` touches that hold nothing it runs to the end without touch exits.

    Parameters
    ----------
    x0 : x_0
    block : (2m + 1, N) rows w_0 … w_{m−1}, z_0 … z_{m−1}, cap, one column per stage in
        loop order (C-contiguous, else copied once)
    m : pieces a stage besides the cap
    """
    n = block.shape[1]
    if n == 0:  # (a memoryview cannot be cast with a zero in its shape)
        return np.array([float(x0)])
    caps = block[2 * m]
    fills: NDArray[np.float64] | None = None
    res = np.empty(n + 1)
    # the loop's values since res[start] (a held run's fills go into res as they are: no
    # list of them to convert back)
    out, start = [float(x0)], 0
    # the block's entries in row order (C order: ascontiguousarray copies nothing then); a
    # row's slice from stage i on yields its entries as Python floats, the same doubles
    flat = memoryview(np.ascontiguousarray(block)).cast("B").cast("d")
    rows = range(2 * m + 1)
    x, i, misses = out[0], 0, 0
    while i < n:
        columns = [flat[r * n + i:(r + 1) * n] for r in rows]
        touched = _loop(m, misses < MISSES)(x, columns, out)
        i = start + len(out) - 1
        x = out[-1]
        if not touched or i == n:
            continue
        if fills is None:
            fills = np.where(caps > 0.0, caps, 0.0)
        tau = fills[i - 1:n - 1]  # τ_i = f_{i−1} = x (the touch), τ_{j+1} = f_j
        if m:
            with np.errstate(invalid="ignore", over="ignore"):
                t = block[:m, i:] * tau  # the loop's x * w
                t += block[m:2 * m, i:]
            # every piece at or above the cap ((…).all(axis=0) without its wrapper; a NaN
            # cap fails too)
            held = np.logical_and.reduce(t >= caps[i:], axis=0)
        else:
            held = caps[i:] == caps[i:]  # the cap alone: held unless NaN (never binds)
        held &= np.isfinite(tau)  # x · 0.0 + cap is the cap for a finite x only
        k = int(held.argmin())  # the first stage not held
        if held[k]:
            k = n - i  # held to the end
        if k == 0:
            misses += 1
            continue
        res[start:i + 1] = out
        res[i + 1:i + 1 + k] = fills[i:i + k]
        i += k
        x = float(fills[i - 1])
        out, start = [x], i
    res[start:] = out
    return res
