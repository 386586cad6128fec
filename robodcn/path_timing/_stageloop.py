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
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable, Sequence

__all__ = ["recurrence"]

Loop = Callable[[float, Sequence[Iterable[float]]], list[float]]


@functools.cache
def _loop(m: int) -> Loop:
    """The unrolled stage loop for ``m`` pieces a stage (compiled once per m).

    Generated source, since Python has no other way to unroll a loop over a stage's pieces:
    an inner ``for`` over them costs about twice the unrolled body (measured on 100 stages ×
    7 pieces: 40 µs vs 20 µs)."""
    targets = ", ".join([*(f"w{j}" for j in range(m)), *(f"z{j}" for j in range(m)), "cap,"])
    body = "".join(f"        t = x * w{j} + z{j}\n        if t < m:\n            m = t\n"
                   for j in range(m))
    src = (f"def loop(x, columns):\n"
           f"    out = [x]\n"
           f"    append = out.append\n"
           f"    for {targets} in zip(*columns):\n"
           f"        m = inf\n"
           f"{body}"
           f"        t = x * 0.0 + cap\n"
           f"        if t < m:\n"
           f"            m = t\n"
           f"        x = m if m > 0.0 else 0.0\n"
           f"        append(x)\n"
           f"    return out\n")
    namespace: dict[str, object] = {"inf": float("inf")}
    exec(compile(src, f"<robodcn.path_timing._stageloop m={m}>", "exec"), namespace)
    return namespace["loop"]  # type: ignore[return-value]


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
    return _loop(m)(float(x0), columns)
