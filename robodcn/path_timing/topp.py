"""The jerk-free TOPP-RA solve on a grid, shared by :func:`~robodcn.path_timing.time_optimal`
and its jerk pass (:mod:`robodcn.path_timing.jerk`).

TOPP-RA: H. Pham and Q.-C. Pham, "A New Approach to Time-Optimal Path Parameterization Based
on Reachability Analysis", IEEE T-RO 34(3), 2018, with the per-stage LPs in closed form
(:mod:`robodcn.path_timing.reachability`) and the paper's "interpolation" discretisation
(§V-B; :data:`INTERPOLATED`). Also the argument checks of the public entry points and the
path derivatives (q′, q″, q‴) by finite differences.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.errors import InputError
from robodcn.path_timing import _columns, _gradient, reachability
from robodcn.path_timing._gradient import Gradient
from robodcn.path_timing.torque import TorqueRows

#: stages of the reachability grid at most (the samples are subsampled evenly above this)
MAX_STAGES = 1000
#: TOPP-RA's "interpolation" discretisation (acceleration bounded at both ends of each stage)
INTERPOLATED = True


def check_limits(name: str, value: ArrayLike | None, k: int, n: int | None = None
            ) -> NDArray[np.float64]:
    """(k,) per-joint limits, inf where None; with ``n``, (n, k) per-sample limits too."""
    if value is None:
        return np.full(k, np.inf)
    if type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (k,):
        # the callers' usual form (JointLimits' arrays): no None entries to map; a copy, as
        # the conversion below makes; NaN fails "> 0" like a limit ≤ 0
        if not np.logical_and.reduce(value > 0):  # (.all() without its wrapper)
            raise InputError(f"{name} must be positive (None = unlimited), got "
                             f"{value.tolist()}", field=name, value=value)
        return value.copy()
    if n is not None and np.ndim(value) == 2:
        raw = np.asarray(value, dtype=np.float64)
        if raw.shape != (n, k):
            raise InputError(f"{name} per sample must have shape ({n}, {k}), got {raw.shape}",
                             field=name, value=raw.shape)
    else:
        raw = np.asarray([np.inf if v is None else v for v in np.atleast_1d(value).tolist()],
                         dtype=np.float64) if np.ndim(value) else np.full(k, float(value))
    if raw.shape != (k,) and not (n is not None and raw.shape == (n, k)):
        raise InputError(f"{name} must have one entry per joint ({k}), got shape {raw.shape}",
                         field=name, value=value)
    if np.isnan(raw).any() or (raw <= 0).any():
        raise InputError(f"{name} must be positive (None = unlimited), got {raw.tolist()}",
                         field=name, value=value)
    return raw


def check_number(name: str, value: float, lo: float, hi: float, *, lo_open: bool = False) -> float:
    # a plain float (the callers' usual argument) without the four-way isinstance
    ok = ((type(value) is float or isinstance(value, int | float | np.floating | np.integer))
          and math.isfinite(value))
    if ok:
        ok = (lo < value if lo_open else lo <= value) and value <= hi
    if not ok:
        raise InputError(f"{name} must be a number in {'(' if lo_open else '['}{lo:g}, {hi:g}], "
                         f"got {value!r}", field=name, value=value)
    return float(value)


def path_derivatives(q: NDArray[np.float64], s: NDArray[np.float64], cuts: Sequence[int],
                     order: int) -> list[NDArray[np.float64]]:
    """q', q'', … (``order`` of them) by second-order finite differences on the samples.

    The path is differentiated piece by piece between the sample indices ``cuts`` (stops,
    where q' may have a corner); a cut sample takes its outgoing piece's derivatives.
    Repeated parameters (a dwell: the same s with the same q, e.g. a held sample) are one
    sample: they share its derivatives (numpy.gradient would divide by their zero spacing).

    Raises
    ------
    InputError
        ``s`` not finite or decreasing, or two different joint samples at one s (field "s").
    """
    s = np.asarray(s, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    step = s[1:] - s[:-1]  # np.diff
    if not np.isfinite(s).all() or (step < 0).any():
        raise InputError(f"s must be finite and non-decreasing, got {s.shape[0]} values with "
                         f"{int((step < 0).sum())} decreasing steps", field="s",
                         value=s.shape)
    return derivatives(q, s, cuts, order, repeated=not (step > 0).all())


def derivatives(q: NDArray[np.float64], s: NDArray[np.float64], cuts: Sequence[int],
                order: int, *, repeated: bool) -> list[NDArray[np.float64]]:
    """:func:`path_derivatives` for float arrays with s already checked finite and
    non-decreasing; ``repeated``: whether s repeats a value (the dwell rule)."""
    cut = sorted(set(int(c) for c in cuts if 0 < c < q.shape[0] - 1)) if len(cuts) else []
    if not cut and not repeated and q.shape[0] >= 2:
        # one piece without dwells (the planner's dense paths): the derivatives are the
        # gradients themselves, no per-piece copies (kept: the planner's interpolant of the
        # same samples asks for them again)
        return _gradient.repeated(s, q, order)
    edges = [0, *cut, q.shape[0] - 1]
    out = [np.empty_like(q) for _ in range(order)]
    for a, b in itertools.pairwise(edges):
        f, x = q[a:b + 1], s[a:b + 1]
        index = None
        if repeated:
            keep = np.concatenate([[True], np.diff(x) > 0])
            if not keep.all():
                index = np.cumsum(keep) - 1
                if np.abs(f - f[keep][index]).max() > 1e-12:
                    raise InputError("s repeats a parameter with different joint samples (a "
                                     "jump of the path)", field="s", value=s.shape)
                f, x = f[keep], x[keep]
        grad = Gradient(x) if f.shape[0] >= 2 else None
        for d in range(order):
            f = np.zeros_like(f) if grad is None else grad(f)  # one sample: nothing moves
            out[d][a:b + 1] = f if index is None else f[index]
    return out


def grid_of(n: int, stop_idx: NDArray[np.int64], max_stages: int) -> NDArray[np.int64]:
    if n - 1 <= max_stages:
        return np.arange(n)
    even = np.round(np.linspace(0, n - 1, max_stages + 1)).astype(np.int64)
    return np.union1d(even, stop_idx)


def interpolated(sg: NDArray, dq: NDArray, ddq: NDArray, v: NDArray, a: NDArray
                  ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """The "interpolation" discretisation of TOPP-RA (Pham & Pham 2018, §V-B): stage i also
    bounds the acceleration at its end point, q'_{i+1} u + q''_{i+1} x_{i+1} with
    x_{i+1} = x + 2Δ_i u, i.e. a virtual joint with q' = q'_{i+1} + 2Δ_i q''_{i+1} and
    q'' = q''_{i+1} (no velocity bound of its own: stage i + 1 bounds it). So the law keeps the
    acceleration limits at both ends of every stage, not only at the grid points it starts
    from (collocation), and the stream's samples between grid points stay within them."""
    delta = np.diff(sg)
    nxt_dq = np.concatenate([dq[1:], dq[-1:]])
    nxt_ddq = np.concatenate([ddq[1:], ddq[-1:]])
    step = np.concatenate([delta, [0.0]])[:, None]
    dq2 = np.concatenate([dq, nxt_dq + 2.0 * step * nxt_ddq], axis=1)
    ddq2 = np.concatenate([ddq, nxt_ddq], axis=1)
    # per-stage limits (N, k) work alike: the virtual joint takes its own stage's limits (the
    # tighter ones where a blend-out window ends and the limits rise along the path)
    return (dq2, ddq2, np.concatenate([v, np.full(v.shape, np.inf)], axis=-1),
            np.concatenate([a, a], axis=-1))


def interpolated_rows(sg: NDArray, rows: TorqueRows) -> TorqueRows:
    """Further rows (A, B, lo, hi) in the "interpolation" discretisation (as
    :func:`interpolated`): stage i also bounds A_{i+1} u + B_{i+1} x_{i+1}, i.e. the row
    (A_{i+1} + 2Δ_i B_{i+1}) u + B_{i+1} x within [lo_{i+1}, hi_{i+1}]."""
    a, b, lo, hi = rows
    step = np.concatenate([np.diff(sg), [0.0]])[:, None]
    nxt = [np.concatenate([m[1:], m[-1:]]) for m in rows]
    return (np.concatenate([a, nxt[0] + 2.0 * step * nxt[1]], axis=1),
            np.concatenate([b, nxt[1]], axis=1), np.concatenate([lo, nxt[2]], axis=1),
            np.concatenate([hi, nxt[3]], axis=1))


def solve(sg: NDArray, dq: NDArray, ddq: NDArray, v: NDArray, a: NDArray,
          extra_cap: NDArray | None, x_start: float, x_end: float,
          rows: TorqueRows | None = None) -> tuple[NDArray, NDArray]:
    """x (N + 1,), u (N,) of TOPP-RA on grid sg; raises when the start is not controllable.
    ``extra_cap``: (N + 1,) a further bound on x at each point, None: none (min(x, inf) is
    x); ``rows``: further linear constraints (torque: :mod:`robodcn.path_timing.torque`).

    On up to :data:`~robodcn.path_timing.reachability.LOOP_STAGES` stages without rows and
    with per-joint limits the constraints are built one row per constraint
    (:func:`robodcn.path_timing._columns.constraints`, the same values) and both passes run
    as plain stage loops, skipping the stages where the cap binds
    (:func:`robodcn.path_timing._stageloop.capped_recurrence`, the same values)."""
    delta = sg[1:] - sg[:-1]  # np.diff
    n_stages = delta.shape[0]
    fast = (INTERPOLATED and rows is None and v.ndim == 1 and a.ndim == 1
            and n_stages <= reachability.LOOP_STAGES)
    columns = _columns.constraints(delta, dq, ddq, v, a) if fast else None
    if columns is not None:
        half, r, x_cap = columns
        if extra_cap is not None:
            x_cap = np.minimum(x_cap, extra_cap)
        pieces = _columns.pieces(delta, half, r, x_cap)
        x_max = reachability.backward_block(min(float(x_end), float(x_cap[n_stages])),
                                            pieces.backward, pieces.m)
        x_max_0 = float(x_max[0])
    else:
        if INTERPOLATED:
            dq, ddq, v, a = interpolated(sg, dq, ddq, v, a)
            if rows is not None:
                rows = interpolated_rows(sg, rows)
        p_lo, p_hi, r_rows, x_cap = reachability.stage_constraints(dq, ddq, v, a, rows)
        if extra_cap is not None:
            x_cap = np.minimum(x_cap, extra_cap)
        x_max_arr = reachability.controllable(delta, p_lo, r_rows, x_cap, x_end)
        x_max_0 = float(x_max_arr[0])
    if x_start > x_max_0 * (1 + 1e-9) + 1e-15:
        raise InputError(f"sd_start {math.sqrt(x_start):.6g} /s is faster than the path allows"
                         f" there: at most {math.sqrt(x_max_0):.6g} /s can still keep every "
                         "joint within its limits and come to rest by the end",
                         field="sd_start", value=math.sqrt(x_start))
    x0 = min(x_start, x_max_0)
    if columns is not None:
        forward = pieces.forward
        forward[2 * pieces.m] = x_max[1:]  # the caps x_max,1 … x_max,N
        return reachability.forward_block(delta, forward, pieces.m, x0)
    return reachability.greedy_forward(delta, p_hi, r_rows, x_max_arr, x0)


def stage_times(sg: NDArray, x: NDArray) -> NDArray[np.float64]:
    """Stage durations 2Δ_i / (ṡ_i + ṡ_{i+1}) (constant s̈ on each stage) of x = ṡ² on sg."""
    return timed_stages(sg, x)[0]


def timed_stages(sg: NDArray, x: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(:func:`stage_times`, ṡ = √max(x, 0)): the durations and the speeds they are read off.

    Raises
    ------
    InputError
        A stage at rest at both ends (field "stops").
    """
    sd = np.sqrt(np.maximum(x, 0.0))
    speed = sd[:-1] + sd[1:]
    if np.logical_or.reduce(speed <= 0):  # (.any() without its wrapper)
        i = int(np.argmax(speed <= 0))
        raise InputError(f"the path cannot move from s = {sg[i]:.6g}: every joint limit forbids"
                         " it (a stop next to a stop, or a zero limit)", field="stops",
                         value=float(sg[i]))
    return 2.0 * (sg[1:] - sg[:-1]) / speed, sd  # np.diff's operation
