"""The public planar interpolation API: poses in, poses out.

``interpolate(start, end, s)`` evaluates ScLERP, KenLERP(β), SEP-LERP or a two-pose dual
linear blend between planar poses (x, y, θ) at an array of path parameters s, and
``blend(poses, weights)`` is the n-pose DLB. The DCN closed forms below are the fast path;
``backend="dq"`` evaluates the same motion with dual quaternions (:mod:`robodcn.dualquat`) and
``backend="matrix"`` with 3×3 matrices (:mod:`robodcn.se2`), for cross-checks and benchmarks.

Conventions: metres and radians; the output θ is unwrapped continuously from start's θ, so
θ(1) = θ_start + Δθ where Δθ is the signed turn chosen by ``turn``:

* "shortest": Δθ ∈ (−π, π]; an exact half turn goes counter-clockwise (+π).
* "ccw": Δθ ∈ [0, 2π); "cw": Δθ ∈ (−2π, 0].
"""

from __future__ import annotations

import cmath
import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks, dcn, dualquat, se2
from robodcn.errors import DegenerateError, InputError

METHODS = ("sclerp", "kenlerp", "seplerp", "dlb")
BACKENDS = ("dcn", "dq", "matrix")
Method = Literal["sclerp", "kenlerp", "seplerp", "dlb"]
Turn = Literal["shortest", "ccw", "cw"]

_TWO_PI = 2.0 * np.pi
_HALF_TURN_TOLERANCE = dcn.HALF_TURN_TOLERANCE   # the tie band of every path (dcn's notes)


def turn_angle(theta_start: float, theta_end: float, turn: str = "shortest") -> float:
    """The signed rotation Δθ from θ_start to θ_end that ``turn`` asks for.

    "shortest" → (−π, π] (an exact half turn within 1e-12 rad is +π); "ccw" → [0, 2π);
    "cw" → (−2π, 0]. Angles within 1e-12 rad of a whole turn count as no rotation.
    """
    _checks.one_of("turn", turn, dcn.TURNS)
    # [0, 2π): Python's float % is numpy.remainder's rule (fmod, moved into the divisor's
    # sign), the same bits without a ufunc call on a scalar
    delta = float(theta_end - theta_start) % _TWO_PI
    if delta < _HALF_TURN_TOLERANCE or delta > _TWO_PI - _HALF_TURN_TOLERANCE:
        delta = 0.0  # no rotation, also for "ccw"/"cw": never a spurious full turn
    if turn == "ccw":
        return delta
    if turn == "cw":
        return delta - _TWO_PI if delta > 0.0 else 0.0
    if abs(delta - np.pi) <= _HALF_TURN_TOLERANCE:
        return float(np.pi)
    return delta if delta < np.pi else delta - _TWO_PI


def _pose(name: str, value: ArrayLike) -> NDArray[np.float64]:
    pose = _checks.finite(name, value)
    if pose.shape != (3,):
        raise InputError(f"{name} must be a pose (x, y, θ) of shape (3,), got shape "
                                 f"{pose.shape}", field=name, value=value)
    return pose


def _pole_factor(chord: complex, phi: float) -> complex:
    """v = (c_q − c_p)·e^{−iφ} / sin φ of :func:`sclerp_positions`, on Python scalars
    (cmath, math): numpy's scalar transcendentals cost more than the rest of a short
    evaluation, and a planner samples one segment several times."""
    return chord * cmath.exp(-1j * phi) / math.sin(phi)


def sclerp_positions(c_start: complex, c_end: complex, delta: float, s: NDArray[np.float64],
                     out_x: NDArray[np.float64], out_y: NDArray[np.float64]) -> None:
    """Positions of planar ScLERP in closed form, written into ``out_x``, ``out_y``.

    With p, q the DCNs of the two poses and q aligned so that d = q·p⁻¹ = e^{iφ} + d1ε,
    φ = Δθ/2, SLERP is d^s·p with d^s = e^{isφ} + (sin sφ / sin φ)·d1ε (dcn-paper, Def. 5.3).
    Its translation 2·p0(s)·p1(s), with c_p, c_q the end positions, simplifies to

        c(s) = c_p + (sin sφ / sin φ)·e^{i(s−1)φ}·(c_q − c_p),

    an arc about the motion's pole, tending to the straight line c_p + s·(c_q − c_p) as
    φ → 0. Writing sin(sφ)·e^{isφ} = P + iQ with τ = tan(sφ), P = τ/(1 + τ²) = ½·sin 2sφ
    and Q = τ·P = sin² sφ — exact for every s (both sides are π-periodic in sφ) and one
    vectorised tan instead of a sin and a cos (numpy's float64 tan is SIMD, sin/cos are not).
    """
    chord = c_end - c_start
    phi = 0.5 * delta
    if abs(phi) < 1e-100:
        np.multiply(s, chord.real, out=out_x)
        np.multiply(s, chord.imag, out=out_y)
    else:
        v = _pole_factor(chord, phi)
        tau = np.multiply(s, phi)
        np.tan(tau, out=tau)
        p = np.multiply(tau, tau)
        p += 1.0
        np.divide(tau, p, out=p)  # P
        q = np.multiply(tau, p, out=tau)  # Q
        # (P + iQ)·v: x = P·v_re − Q·v_im, y = P·v_im + Q·v_re, the products written into
        # the buffers P and Q once each is read for the last time
        np.multiply(p, v.real, out=out_x)
        np.multiply(p, v.imag, out=out_y)
        out_x -= np.multiply(q, v.imag, out=p)
        out_y += np.multiply(q, v.real, out=q)
    out_x += c_start.real
    out_y += c_start.imag


def _interpolate_dcn(start: NDArray[np.float64], end: NDArray[np.float64], delta: float,
                     s: NDArray[np.float64], method: str, beta: float) -> NDArray[np.float64]:
    out = np.empty((s.shape[0], 3))
    c_p = complex(start[0], start[1])
    c_q = complex(end[0], end[1])
    if method == "dlb":
        p = dcn.from_pose(start)
        q = dcn.from_pose([end[0], end[1], start[2] + delta])
        blended = (1.0 - s)[:, None] * p + s[:, None] * q
        size = np.hypot(blended[:, 0], blended[:, 1])
        if (size < 1e-12).any():
            bad = int(np.argmax(size < 1e-12))
            raise DegenerateError(f"dual linear blend is undefined at s[{bad}] = {s[bad]!r}: "
                                  "the blended rotation vanishes", field="s", value=s[bad])
        blended /= size[:, None]
        p0 = blended[:, 0] + 1j * blended[:, 1]
        c = 2.0 * p0 * (blended[:, 2] + 1j * blended[:, 3])
        out[:, 0], out[:, 1] = c.real, c.imag
        # The blend's half-angle relative to the start lies between 0 and Δθ/2, inside
        # (−π, π), so np.angle needs no unwrapping here.
        out[:, 2] = start[2] + 2.0 * np.angle(p0 * np.exp(-0.5j * start[2]))
        return out
    np.multiply(s, delta, out=out[:, 2])
    out[:, 2] += start[2]
    if method == "seplerp":
        out[:, 0] = c_p.real + s * (c_q.real - c_p.real)
        out[:, 1] = c_p.imag + s * (c_q.imag - c_p.imag)
        return out
    sclerp_positions(c_p, c_q, delta, s, out[:, 0], out[:, 1])
    if method == "kenlerp" and beta != 1.0:
        # KenLERP: lerp(v_sep, v_sc; β); in the plane both rotations are equal.
        chord = c_q - c_p
        for axis, c0, dc in ((0, c_p.real, chord.real), (1, c_p.imag, chord.imag)):
            out[:, axis] *= beta
            out[:, axis] += (1.0 - beta) * (c0 + s * dc)
    return out


def _interpolate_dq(start, end, delta, s, method, beta):
    a = dcn.to_dualquat(dcn.from_pose(start))
    b = dcn.to_dualquat(dcn.from_pose(end))
    turn = "ccw" if delta > 0.0 else "cw"
    if method == "sclerp" or (method == "kenlerp" and beta == 1.0):
        z = dualquat.sclerp(a, b, s, turn=turn)
    elif method == "seplerp":
        z = dualquat.seplerp(a, b, s, turn=turn)
    elif method == "kenlerp":
        z = dualquat.kenlerp(a, b, s, beta, turn=turn)
    else:
        b = dualquat.mul(a, dualquat.align(dualquat.mul(dualquat.conj(a), b), turn))
        z = dualquat.normalize((1.0 - s)[:, None] * a + s[:, None] * b)
        poses = dcn.to_pose(dcn.from_dualquat(z))
        # θ from the blend's rotation relative to the start (half-angle inside (−π, π)).
        rel = dualquat.qmul(z[:, :4], dualquat.qconj(a[:4]))
        poses[:, 2] = start[2] + 2.0 * np.arctan2(rel[:, 3], rel[:, 0])
        return poses
    poses = dcn.to_pose(dcn.from_dualquat(z))
    poses[:, 2] = start[2] + s * delta  # the turn is exact; rebuild it unwrapped
    return poses


def _interpolate_matrix(start, end, delta, s, method, beta):
    if method not in ("sclerp", "kenlerp") or (method == "kenlerp" and beta != 1.0):
        raise InputError(f"backend 'matrix' implements ScLERP only, not method={method!r}",
                         field="backend", value="matrix")
    m = se2.sclerp(se2.from_pose(start), se2.from_pose(end), s, omega=delta)
    return se2.to_pose(m)


def interpolate(start: ArrayLike, end: ArrayLike, s: ArrayLike, *, method: Method = "sclerp",
                beta: float = 1.0, turn: Turn = "shortest",
                backend: Literal["dcn", "dq", "matrix"] = "dcn") -> NDArray[np.float64]:
    """Interpolate a planar rigid motion between two poses.

    Parameters
    ----------
    start, end : (3,) array-like
        Poses (x, y, θ) in metres and radians.
    s : (n,) array-like
        Path parameters; 0 gives start, 1 gives end, other values extrapolate (any order).
    method : "sclerp" | "kenlerp" | "seplerp" | "dlb"
        ScLERP (screw motion: points move on arcs about the pole, constant speed);
        KenLERP(β) (β = 0 is SEP-LERP, 1 is ScLERP, > 1 amplifies the screw's bend);
        SEP-LERP (straight-line translation, rotation interpolated separately);
        DLB (the normalised linear blend of the two DCNs).
    beta : float
        KenLERP bias; ignored by the other methods.
    turn : "shortest" | "ccw" | "cw"
        Which way θ goes round (module docstring).
    backend : "dcn" | "dq" | "matrix"
        The algebra that evaluates it; all agree to ~1e-12. "dcn" is the fast path.

    Returns
    -------
    (n, 3) ndarray of poses, θ continuous from start's θ.

    Raises
    ------
    InputError
        Non-finite numbers, wrong shapes, unknown method, turn or backend.
    DegenerateError
        DLB through a vanishing blend (a turn of 2π by "ccw"/"cw").
    """
    start = _pose("start", start)
    end = _pose("end", end)
    s = _checks.samples("s", s)
    _checks.one_of("method", method, METHODS)
    _checks.one_of("turn", turn, dcn.TURNS)
    _checks.one_of("backend", backend, BACKENDS)
    beta = float(_checks.finite("beta", beta)) if method == "kenlerp" else 1.0
    if backend == "dcn":
        return interpolate_unchecked(start, end, s, method, beta, turn)
    delta = turn_angle(start[2], end[2], turn)
    if backend == "dq":
        return _interpolate_dq(start, end, delta, s, method, beta)
    poses = _interpolate_matrix(start, end, delta, s, method, beta)
    poses[:, 2] = start[2] + s * delta
    return poses


def interpolate_unchecked(start: NDArray[np.float64], end: NDArray[np.float64],
                          s: NDArray[np.float64], method: str = "sclerp", beta: float = 1.0,
                          turn: str = "shortest") -> NDArray[np.float64]:
    """:func:`interpolate` by the DCN closed forms without the argument checks, for callers
    that validated them (the planner): ``start``, ``end`` finite float64 (3,) poses, ``s`` a
    finite float64 (n,) array, ``method`` and ``turn`` valid names, ``beta`` a float."""
    beta = float(beta) if method == "kenlerp" else 1.0
    delta = turn_angle(start[2], end[2], turn)
    return _interpolate_dcn(start, end, delta, s, method, beta)


def blend(poses: ArrayLike, weights: ArrayLike) -> NDArray[np.float64]:
    """Dual linear blend of n planar poses: DLB(p₁..pₙ; w₁..wₙ) as a pose (x, y, θ).

    Parameters
    ----------
    poses : (n, 3) poses (x, y, θ), metres and radians.
    weights : (n,) weights (any real values; they need not sum to 1).

    Returns
    -------
    (3,) pose with θ ∈ (−π, π].

    Raises
    ------
    InputError
        Wrong shapes or non-finite values.
    DegenerateError
        When the weighted sum of rotations vanishes.
    """
    poses = _checks.finite("poses", poses)
    if poses.ndim != 2 or poses.shape[1] != 3 or poses.shape[0] == 0:
        raise InputError(f"poses must have shape (n, 3) with n ≥ 1, got {poses.shape}",
                                 field="poses", value=poses)
    weights = _checks.finite("weights", weights)
    if weights.shape != (poses.shape[0],):
        raise InputError(f"weights must have shape ({poses.shape[0]},), got "
                                 f"{weights.shape}", field="weights", value=weights)
    return dcn.to_pose(dcn.dlb(dcn.from_pose(poses), weights))
