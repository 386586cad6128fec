"""Planar serial-arm kinematics: analytic IK (2R, 3R), workspace (FK: :mod:`._forward`, the
Jacobian: :mod:`._jacobian`).

Conventions (shared/design.md §4): joint i turns about the z axis; φ_i = q_1 + … + q_i is the
absolute angle of link i; the tool point is Σ l_i·(cos φ_i, sin φ_i) and, for a 3-joint arm,
the tool orientation is θ = q_1 + q_2 + q_3. A 2-joint arm reaches positions only: θ of a pose
is ignored by its IK and FK reports θ = q_1 + q_2.

IK (law of cosines, e.g. Lynch & Park, *Modern Robotics* §6.1): wrist w = p − l3·(cos θ,
sin θ) (w = p for 2R), cos q2 = (|w|² − l1² − l2²)/(2·l1·l2), q2 = ∓acos(·) and
q1 = atan2(w_y, w_x) − atan2(l2·sin q2, l1 + l2·cos q2), q3 = θ − q1 − q2.
Branch "up" has q2 ≤ 0 (for a target on the +x axis the elbow is above the shoulder–wrist
line), branch "down" q2 ≥ 0.

Every function takes arrays of shape (n, ...) and never loops over samples in Python.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn.errors import InputError, UnreachableError

#: Slack (metres) on the workspace annulus: wrist radii this far outside still count as
#: reachable and cos q2 is rounded into [−1, 1]. Covers float rounding only (1 nm).
REACH_TOLERANCE = 1e-9

ELBOWS = ("up", "down")
_TWO_PI = 2.0 * np.pi
#: ndarray.all without its Python wrapper (numpy's _methods._all): the IK asks it of every
#: path, ~0.4 µs a call on a small one
_all = np.logical_and.reduce


def _links(links: Sequence[float]) -> tuple[float, ...]:
    links = tuple(float(v) for v in links)
    if len(links) not in (2, 3) or not all(np.isfinite(v) and v > 0.0 for v in links):
        raise InputError(f"links must be 2 or 3 positive lengths, got {links!r}", field="links",
                         value=links)
    return links


def _poses(poses: ArrayLike) -> NDArray[np.float64]:
    poses = _checks.finite("poses", poses)
    if poses.ndim != 2 or poses.shape[1] != 3:
        raise InputError(f"poses must have shape (n, 3), got {poses.shape}", field="poses",
                         value=poses)
    return poses


def _joints(q: ArrayLike, k: int) -> NDArray[np.float64]:
    q = _checks.finite("q", q)
    if q.ndim != 2 or q.shape[1] != k:
        raise InputError(f"joint angles must have shape (n, {k}), got {q.shape}", field="q",
                         value=q)
    return q


def wrap(angle: ArrayLike) -> NDArray[np.float64]:
    """Angles wrapped into [−π, π] (a − 2π·rint(a/2π); ±π both possible at exact ties)."""
    a = np.asarray(angle, dtype=np.float64)
    return a - _TWO_PI * np.rint(a * (1.0 / _TWO_PI))


def workspace(links: Sequence[float]) -> tuple[float, float]:
    """The annulus (r_inner, r_outer) = (|l1 − l2|, l1 + l2) the wrist point can reach."""
    l1, l2 = _links(links)[:2]
    return abs(l1 - l2), l1 + l2


def wrist_points(links: Sequence[float], poses: ArrayLike) -> NDArray[np.float64]:
    """Wrist points (n, 2): p − l3·(cos θ, sin θ) for 3 links, p itself for 2."""
    links = _links(links)
    poses = _poses(poses)
    if len(links) == 2:
        return poses[:, :2].copy()
    return np.stack([poses[:, 0] - links[2] * np.cos(poses[:, 2]),
                     poses[:, 1] - links[2] * np.sin(poses[:, 2])], axis=1)


def wrist_radius(links: Sequence[float], poses: ArrayLike) -> NDArray[np.float64]:
    """Distance (n,) of each pose's wrist point from the base."""
    w = wrist_points(links, poses)
    return np.hypot(w[:, 0], w[:, 1])


def reachable(links: Sequence[float], poses: ArrayLike) -> NDArray[np.bool_]:
    """Whether each pose's wrist point lies in the workspace annulus (± REACH_TOLERANCE)."""
    inner, outer = workspace(links)
    r = wrist_radius(links, poses)
    return (r >= inner - REACH_TOLERANCE) & (r <= outer + REACH_TOLERANCE)


def _columns(links: tuple[float, ...], poses: NDArray[np.float64], want: str = "both"
             ) -> tuple[list[NDArray], list[NDArray], NDArray[np.bool_]]:
    """Both IK branches as per-joint 1-D columns (rows of :func:`_block`), angles not
    wrapped; NaN where out of reach; ``want`` "up" or "down" computes that branch alone."""
    block, ok = _block(links, poses, want)
    if want == "up":
        return list(block[0]), [], ok
    if want == "down":
        return [], list(block[0]), ok
    return list(block[0]), list(block[1]), ok


def _block(links: tuple[float, ...], poses: NDArray[np.float64], want: str = "both"
           ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """:func:`_block_reach` with ``ok`` always an array."""
    block, ok = _block_reach(links, poses, want)
    return block, (np.ones(poses.shape[0], dtype=bool) if ok is None else ok)


def _block_reach(links: tuple[float, ...], poses: NDArray[np.float64], want: str = "both"
                 ) -> tuple[NDArray[np.float64], NDArray[np.bool_] | None]:
    """Both IK branches as one array (2, k, n): [0] the elbow-up, [1] the elbow-down joint
    rows (contiguous, so every step is a fast 1-D ufunc), angles not wrapped; NaN where out
    of reach. With ``want`` "up" or "down", (1, k, n): that branch alone. ``ok``: whether
    each pose is within reach, None when all are (told from the extremes of |w|², the
    per-pose test only when one is outside or NaN).

    q2 = ∓atan2(√(1 − c²), c) with c = cos q2; q1 = atan2(w) ∓ atan2(l2·sin|q2|, l1 + l2·c)
    is evaluated as one atan2 of the complex product w·conj(l1 + l2c ± i·l2·sin|q2|).
    """
    l1, l2 = links[:2]
    k = len(links)
    x = poses[:, 0]
    y = poses[:, 1]
    # each step is the plain expression's IEEE operation on the same operands (a + b and
    # a·b commute exactly), written into temporaries already made: a long path's fresh
    # temporaries cost more than the arithmetic
    if k == 3:
        th = poses[:, 2]
        # cos θ and sin θ from t = tan(θ/2) (Weierstrass): numpy's SIMD tan is ~15× faster
        # than cos + sin here, and the rational forms lose at most a few ulp.
        t = np.multiply(th, 0.5)
        np.tan(t, out=t)
        tt = t * t
        inv = tt + 1.0
        np.divide(links[2], inv, out=inv)  # l3 / (1 + t²)
        wx = np.subtract(1.0, tt, out=tt)
        wx *= inv
        np.subtract(x, wx, out=wx)  # x − (1 − t²)·inv
        wy = np.multiply(t, 2.0, out=t)
        wy *= inv
        np.subtract(y, wy, out=wy)  # y − 2t·inv
        r2 = inv  # free from here
        np.multiply(wx, wx, out=r2)
    else:
        wx, wy = np.ascontiguousarray(x), np.ascontiguousarray(y)
        r2 = wx * wx
    b = wy * wy
    r2 += b
    inner, outer = abs(l1 - l2), l1 + l2
    r2_lo, r2_hi = max(inner - REACH_TOLERANCE, 0.0) ** 2, (outer + REACH_TOLERANCE) ** 2
    ok = None
    if not r2_lo <= float(np.minimum.reduce(r2)) or not float(np.maximum.reduce(r2)) <= r2_hi:
        ok = (r2 >= r2_lo) & (r2 <= r2_hi)
    c = np.subtract(r2, l1 * l1 + l2 * l2, out=r2)
    c *= 1.0 / (2.0 * l1 * l2)  # (r² − l1² − l2²)/(2·l1·l2)
    np.minimum(np.maximum(c, -1.0, out=c), 1.0, out=c)  # np.clip, without its wrapper
    s = np.multiply(c, c, out=b)
    np.subtract(1.0, s, out=s)
    np.sqrt(s, out=s)  # √(1 − c²)
    if ok is not None and not _all(ok):
        s[~ok] = np.nan
    q2 = np.arctan2(s, c)
    a = np.multiply(c, l2, out=c)
    a += l1  # l1 + l2·c
    b = np.multiply(s, l2, out=s)  # l2·s
    # q1 = arg(w) − arg(a ± ib): branch "up" has q2 = −|q2|, so subtracts arg(a − ib).
    re_ab = wx * a
    im_ab = np.multiply(wy, a, out=a)
    re_bb = wy * b
    im_bb = np.multiply(wx, b, out=b)
    block = np.empty((1 if want != "both" else 2, k, poses.shape[0]))
    if want != "down":
        up = block[0]
        np.arctan2(im_ab + im_bb, re_ab - re_bb, out=up[0])
        np.negative(q2, out=up[1])
        if k == 3:
            np.subtract(th, up[0], out=up[2])
            up[2] += q2
    if want != "up":
        down = block[-1]
        np.arctan2(im_ab - im_bb, re_ab + re_bb, out=down[0])
        down[1] = q2
        if k == 3:
            np.subtract(th, down[0], out=down[2])
            down[2] -= q2
    return block, ok


def _stack(columns: list[NDArray]) -> NDArray[np.float64]:
    out = np.empty((columns[0].shape[0], len(columns)))
    for j, column in enumerate(columns):
        out[:, j] = column
    return out


def ik_branches(links: Sequence[float], poses: ArrayLike
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Both analytic IK solutions of every pose.

    Returns
    -------
    up, down : (n, k) joint angles in [−π, π] of the elbow-up (q2 ≤ 0) and elbow-down
        (q2 ≥ 0) branches; NaN rows where the pose is out of reach.
    ok : (n,) bool, the pose is reachable (:func:`reachable`).
    """
    links = _links(links)
    poses = _poses(poses)
    up, down, ok = _columns(links, poses)
    return wrap(_stack(up)), wrap(_stack(down)), ok


def ik(links: Sequence[float], poses: ArrayLike, elbow: str = "up") -> NDArray[np.float64]:
    """One IK branch, angles in [−π, π]; raises UnreachableError at the first pose out of reach.

    Parameters
    ----------
    links : 2 or 3 link lengths (metres).
    poses : (n, 3) poses (x, y, θ); θ is ignored by a 2-link arm.
    elbow : "up" (q2 ≤ 0) or "down" (q2 ≥ 0).
    """
    links = _links(links)
    poses = _poses(poses)
    _checks.one_of("elbow", elbow, ELBOWS)
    up, down, ok = _columns(links, poses, elbow)
    _raise_unreachable(links, poses, ok)
    columns = up if elbow == "up" else down
    if len(links) == 3:
        columns[2] = wrap(columns[2])  # q1, q2 are atan2 outputs already
    return _stack(columns)


def _raise_unreachable(links: Sequence[float], poses: ArrayLike, ok: NDArray[np.bool_]) -> None:
    if _all(ok):
        return
    i = int(np.argmin(ok))
    poses = np.asarray(poses, dtype=np.float64)
    inner, outer = workspace(links)
    r = float(wrist_radius(links, poses[i:i + 1])[0])
    x, y, th = poses[i]
    raise UnreachableError(f"sample {i} (x={x:.4f} m, y={y:.4f} m, θ={np.degrees(th):.1f}°) "
                           f"is out of reach: the wrist point is {r:.4f} m from the base, the "
                           f"arm reaches {inner:.4f}..{outer:.4f} m", field="poses",
                           value=poses[i].tolist(), sample=i, pose=poses[i].tolist())


def _wrap_in_place(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`wrap` of ``a`` written into ``a`` (the same operations, no temporaries)."""
    t = a * (1.0 / _TWO_PI)
    np.rint(t, out=t)
    t *= _TWO_PI
    a -= t
    return a


def _sq_sum(d: NDArray[np.float64]) -> NDArray[np.float64]:
    """Σ_j d[..., j, :]² over the joint axis (second to last), summed in joint order."""
    d *= d
    total = d[..., 0, :] + d[..., 1, :]
    for j in range(2, d.shape[-2]):
        total += d[..., j, :]
    return total


#: Joint distance (rad) under which the two IK branches count as one (a stretched-out or
#: folded arm, q2 = 0 or ±π): there "nearest" cannot tell them apart and the branch is kept.
SINGULAR_TOLERANCE = 1e-6


#: Paths up to this many samples are compared as whole blocks (fewer numpy calls); longer
#: ones a joint row at a time (each row stays in cache). Both compute the same numbers.
BLOCK_SAMPLES = 2048


def _step_distances(block: NDArray[np.float64]) -> NDArray[np.float64]:
    """Squared wrapped joint distances (5, n − 1) between samples i and i − 1 of a (2, k, n)
    block: up→up, down→down, up→down (down now − up before), down→up (up now − down
    before), and up − down at sample i − 1 (:func:`wrap`; joints summed in order)."""
    k, n = block.shape[1:]
    now = block[:, :, 1:]
    before = block[:, :, :-1]
    if n <= BLOCK_SAMPLES:
        d = np.empty((5, k, n - 1))
        np.subtract(now, before, out=d[0:2])
        np.subtract(now[::-1], before, out=d[2:4])
        np.subtract(before[0], before[1], out=d[4])
        return _sq_sum(_wrap_in_place(d))
    sq = np.empty((5, n - 1))
    pairs = ((now[0], before[0]), (now[1], before[1]), (now[1], before[0]),
             (now[0], before[1]), (before[0], before[1]))
    for p, (a, b) in enumerate(pairs):
        d = _wrap_in_place(a[0] - b[0])
        np.multiply(d, d, out=sq[p])
        for j in range(1, k):
            d = _wrap_in_place(a[j] - b[j])
            d *= d
            sq[p] += d
    return sq


def _choose(block: NDArray[np.float64], first_down: bool) -> NDArray[np.bool_]:
    """:func:`choose_branches` of a (2, k, n) block (up, down joint rows)."""
    n = block.shape[2]
    stay_up = np.ones(n, dtype=bool)
    stay_down = np.ones(n, dtype=bool)
    if n > 1:
        sq = _step_distances(block)
        stay_up[1:] = sq[0] <= sq[2]
        stay_down[1:] = sq[1] <= sq[3]
        # Leaving a singular sample both branches are equally near: keep the branch (the
        # preferred one at a singular start) instead of letting rounding pick.
        singular = sq[4] <= SINGULAR_TOLERANCE ** 2
        stay_up[1:] |= singular
        stay_down[1:] |= singular
    reset = stay_up != stay_down
    reset[0] = True
    reset_value = ~stay_up  # after a reset: down unless "up" was the branch to stay on
    reset_value[0] = first_down
    flips = np.cumsum(~stay_up & ~stay_down)
    last = np.maximum.accumulate(np.where(reset, np.arange(n), 0))
    parity = (flips - flips[last]) % 2 == 1
    return reset_value[last] ^ parity


def choose_branches(up: ArrayLike, down: ArrayLike, first_down: bool) -> NDArray[np.bool_]:
    """Per sample, whether the branch-continuous path is on "down" (vectorised, no loop).

    up, down : (n, k) the two IK branches along a path. The path stays on its branch while
    that branch's next sample is at least as near (wrapped joint distance) as the other
    branch's, and switches otherwise. With stay_A[i] / stay_B[i] the "keep the branch" tests
    when coming from up / down, the state machine s_i = f(s_{i−1}) is: both true → keep,
    both false → flip, exactly one true → reset to that branch. So s_i is the value at the
    last reset XOR the parity of flips since then: a cumulative maximum and a cumulative sum.
    """
    up = np.asarray(up, dtype=np.float64)
    down = np.asarray(down, dtype=np.float64)
    return _choose(np.stack([up.T, down.T]), bool(first_down))


def _unwrap(column: NDArray[np.float64]) -> NDArray[np.float64]:
    """np.unwrap of one column: steps wrapped into [−π, π], then summed."""
    return _unwrap_rows(column[None, :])[0]


def _unwrap_rows(rows: NDArray[np.float64]) -> NDArray[np.float64]:
    """np.unwrap of each row of (k, n): steps wrapped into [−π, π], then summed."""
    out = np.empty_like(rows)
    out[:, 0] = rows[:, 0]
    steps = _wrap_in_place(rows[:, 1:] - rows[:, :-1])
    np.cumsum(steps, axis=1, out=out[:, 1:])
    out[:, 1:] += rows[:, :1]
    return out


def ik_path(links: Sequence[float], poses: ArrayLike, *, reference: ArrayLike | None = None,
            elbow: str = "up", limits: ArrayLike | None = None) -> NDArray[np.float64]:
    """Branch-continuous, unwrapped IK along a sampled path.

    The first sample takes the branch nearest ``reference`` (the arm's present joints; the
    ``elbow`` preference when None or at a tie, e.g. a stretched-out reference), every later
    sample the branch nearest the previous one (:func:`choose_branches`; leaving a singular
    sample the branch is kept); the angles are unwrapped along the path and each joint
    shifted by a multiple of 2π so the first sample is nearest ``reference`` — or, without a
    reference, nearest the middle of ``limits`` ((k, 2) rows (min, max); 0 when None).

    Raises
    ------
    UnreachableError
        At the first pose out of reach (sample index and pose named).
    """
    q, bad = try_ik_path(links, poses, reference=reference, elbow=elbow, limits=limits)
    if q is None:
        _raise_unreachable(links, _poses(poses), np.arange(len(poses)) != bad)
    return q


def try_ik_path(links: Sequence[float], poses: ArrayLike, *,
                reference: ArrayLike | None = None, elbow: str = "up",
                limits: ArrayLike | None = None) -> tuple[NDArray[np.float64] | None, int | None]:
    """:func:`ik_path` as data: (joints, None), or (None, index of the first pose out of
    reach) — for searches that try many paths and must not steer by exceptions."""
    links = _links(links)
    poses = _poses(poses)
    _checks.one_of("elbow", elbow, ELBOWS)
    k = len(links)
    if reference is not None:
        reference = _checks.finite("reference", reference)
        if reference.shape != (k,):
            raise InputError(f"reference joints must have shape ({k},), got {reference.shape}",
                             field="start_joints", value=reference)
    return ik_path_unchecked(links, poses, reference, elbow, limits)


def ik_path_unchecked(links: tuple[float, ...], poses: NDArray[np.float64],
                      reference: NDArray[np.float64] | None = None, elbow: str = "up",
                      limits: ArrayLike | None = None
                      ) -> tuple[NDArray[np.float64] | None, int | None]:
    """:func:`try_ik_path` without the argument checks, for callers that validated them:
    ``links`` a tuple of 2 or 3 positive floats, ``poses`` a finite (n, 3) float array,
    ``reference`` None or a finite (k,) float array, ``elbow`` "up" or "down".

    The first sample's branch is chosen first; the path's samples are then solved on that
    branch alone, and both branches (:func:`choose_branches`) only when the path comes near
    enough to a stretched or folded arm that the other branch could be the nearer one
    (:func:`_one_branch_holds`): the result is the same either way.
    """
    k = len(links)
    n = poses.shape[0]
    if n == 0:
        return np.empty((0, k)), None
    if reference is None:  # _first_down's answer without its array
        down = elbow == "down"
    else:
        first_down = _first_down(links, poses[:1], reference, elbow)
        if first_down is None:
            return None, 0
        down = bool(first_down[0])
    one, ok = _block_reach(links, poses, "down" if down else "up")
    if ok is not None and not _all(ok):
        return None, int(np.argmin(ok))
    rows = one[0]
    steps = _wrap_in_place(rows[:, 1:] - rows[:, :-1])
    if not _one_branch_holds(rows[1], steps):
        block, _ = _block(links, poses)
        rows = np.where(_choose(block, down), block[1], block[0])
        steps = _wrap_in_place(rows[:, 1:] - rows[:, :-1])
    return _unwrapped(rows, steps, _target(k, reference, limits)), None


def ik_paths_unchecked(links: tuple[float, ...], poses: NDArray[np.float64],
                       counts: Sequence[int], reference: NDArray[np.float64] | None = None,
                       elbow: str = "up", limits: ArrayLike | None = None
                       ) -> list[tuple[NDArray[np.float64] | None, int | None]]:
    """:func:`ik_path_unchecked` of several paths stacked in ``poses`` (``counts`` rows each,
    in order), each exactly as that path alone gives it; in one pass over all of them where
    they start on one branch and stay clear of singularities (a search's candidate
    samplings of one path), else path by path."""
    # plain ints (numpy's cumsum of a list goes through its slow wrapper), an array where
    # they index
    bounds = [0, *itertools.accumulate(counts)]
    alone = list(itertools.pairwise(bounds))

    def each() -> list[tuple[NDArray[np.float64] | None, int | None]]:
        return [ik_path_unchecked(links, poses[a:b], reference, elbow, limits)
                for a, b in alone]

    if len(alone) < 2 or min(counts) < 2 or bounds[-1] != poses.shape[0]:
        return each()
    if reference is None:  # every path starts on elbow: _first_down without its array
        down = elbow == "down"
    else:
        first_down = _first_down(links, poses[bounds[:-1]], reference, elbow)
        if first_down is None or first_down.any() != first_down.all():
            return each()
        down = bool(first_down[0])
    one, ok = _block_reach(links, poses, "down" if down else "up")
    if ok is not None and not _all(ok):
        return each()
    rows = one[0]
    steps = _wrap_in_place(rows[:, 1:] - rows[:, :-1])
    # the step from one path's end to the next one's start is no step of a path
    if not _one_branch_holds(rows[1], steps, skip=[b - 1 for b in bounds[1:-1]]):
        return each()  # each path alone holds or not: its own result either way
    target = _target(len(links), reference, limits)
    return [(_unwrapped(rows[:, a:b], steps[:, a:b - 1], target), None) for a, b in alone]


def _first_down(links: tuple[float, ...], firsts: NDArray[np.float64],
                reference: NDArray[np.float64] | None, elbow: str) -> NDArray[np.bool_] | None:
    """Per first pose (m, 3) whether its path starts on "down": the branch nearest
    ``reference`` (a tie — a singular pose or a reference midway — to ``elbow``), or
    ``elbow`` without one; None when a first pose is out of reach."""
    if reference is None:
        return np.full(firsts.shape[0], elbow == "down")
    block, ok = _block(links, firsts)
    if not _all(ok):
        return None
    d_up, d_dn = _sq_sum(_wrap_in_place(block - reference[:, None]))
    return np.where(np.abs(d_dn - d_up) > SINGULAR_TOLERANCE ** 2, d_dn < d_up,
                    elbow == "down")


def _target(k: int, reference: NDArray[np.float64] | None, limits: ArrayLike | None
            ) -> NDArray[np.float64]:
    """The joints the first sample is turned nearest to: the reference, else the middle of
    the limits, else 0."""
    if reference is not None:
        return reference
    if isinstance(limits, tuple):  # hashable: its middle found once
        return _middle(limits)
    if limits is not None:
        middle = np.asarray(limits, dtype=np.float64)
        return (middle[:, 0] + middle[:, 1]) * 0.5  # the rows' mean, as (a + b)/2 is
    return np.zeros(k)


@functools.lru_cache(maxsize=64)
def _middle(limits: tuple[tuple[float, float], ...]) -> NDArray[np.float64]:
    """:func:`_target`'s middle of a tuple of (min, max) limits (the same operations),
    read-only."""
    middle = np.asarray(limits, dtype=np.float64)
    out = (middle[:, 0] + middle[:, 1]) * 0.5
    out.setflags(write=False)
    return out


def _unwrapped(rows: NDArray[np.float64], steps: NDArray[np.float64],
               target: NDArray[np.float64]) -> NDArray[np.float64]:
    """Joints (n, k) of joint rows (k, n) with wrapped steps (k, n − 1): the steps summed
    from the first sample, each joint turned by whole turns nearest ``target``."""
    out = np.empty_like(rows)
    out[:, 0] = rows[:, 0]
    # the ufunc methods themselves: np.cumsum / np.round go through numpy's Python wrappers
    np.add.accumulate(steps, axis=1, out=out[:, 1:])
    out[:, 1:] += rows[:, :1]
    out += (_TWO_PI * np.rint((target - out[:, 0]) / _TWO_PI))[:, None]
    return out.T.copy()  # (n, k), C order


def _one_branch_holds(q2: NDArray[np.float64], steps: NDArray[np.float64],
                      skip: Sequence[int] = ()) -> bool:
    """Whether the nearest-branch rule keeps the path on the branch of ``q2`` (n,) (atan2
    outputs in [−π, π]) with wrapped joint steps ``steps`` (k, n − 1) along it.

    The two branches of a pose differ by 2·wrap(q2) in the elbow alone, so they are at least
    2m apart (torus metric) with m = min(|q2|, π − |q2|) over the path; the other branch's
    next sample is then at least 2m − δ from the path's sample, δ the largest step, which
    is farther than the own branch's next sample (≤ δ) whenever δ < m. Half of m is asked
    for, so rounding never decides; SINGULAR_TOLERANCE is far below any such m.
    ``skip``: steps (columns) left out of δ, the joins of stacked paths.
    """
    if steps.shape[1] == 0:
        return True
    # min(|q2|, π − |q2|) over the path is min(min |q2|, π − max |q2|) (π − x falls as x
    # rises, rounding too); |q2| is q2 or −q2 along a one-signed path (one branch's),
    # whose extremes are then q2's own (the ufuncs' reduce: no numpy wrappers)
    lo, hi = float(np.minimum.reduce(q2)), float(np.maximum.reduce(q2))
    if lo >= 0.0:
        a_lo, a_hi = lo, hi
    elif hi <= 0.0:
        a_lo, a_hi = -hi, -lo
    else:
        a = np.abs(q2)
        a_lo, a_hi = float(np.minimum.reduce(a)), float(np.maximum.reduce(a))
    margin = min(a_lo, math.pi - a_hi)
    sq = steps * steps
    total = np.add.reduce(sq, axis=0)
    if len(skip):  # sums of squares are ≥ 0: a skipped step set to 0 leaves the others' max
        total[skip] = 0.0
    step2 = float(np.maximum.reduce(total))
    return margin > 2.0 * SINGULAR_TOLERANCE and step2 <= 0.25 * margin * margin
