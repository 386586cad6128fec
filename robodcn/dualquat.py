"""Unit dual quaternions for rigid motions, with exp/log/power by functional calculus.

A dual quaternion is ζ = q_r + q_d·ε with quaternions in (w, x, y, z) order; arrays have
shape (..., 8) = (q_r | q_d) and every function is vectorised over the leading axes. A unit
dual quaternion has |q_r| = 1 and ⟨q_r, q_d⟩ = 0 and encodes the motion "rotate by q_r, then
translate by t" with q_d = ½·t·q_r (shared/design.md §3; kenwright eq. 1 prints the factors in
the other order, which contradicts its own eq. 2).

exp, log, power and the Cayley transform follow Montgomery-Smith, "Functional Calculus for
Dual Quaternions", Corollaries 5–8: for A + εB, split B = b0 + b1 + b2 with b1 ∥ a1 and
b2 ⊥ a1, treat A as the complex number a0 + i|a1| (i ↦ a1/|a1|), and B1 = b0 + b1 commutes
with A.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn._series import sin_ratio, sinc
from robodcn.dcn import COMPONENT_TIE, TURNS
from robodcn.errors import DegenerateError, InputError

DQArray = NDArray[np.float64]
"""Float array of shape (..., 8): (w, x, y, z | w, x, y, z), real part then dual part."""

_TIE = 1e-12


# -- quaternions (w, x, y, z) ------------------------------------------------------------------

def qmul(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Hamilton product of quaternions (..., 4) in (w, x, y, z) order."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ], axis=-1)


def qconj(q: ArrayLike) -> NDArray[np.float64]:
    """Quaternion conjugate q* = w − (x, y, z)."""
    q = np.array(q, dtype=np.float64)
    q[..., 1:] *= -1.0
    return q


def qinv(q: ArrayLike) -> NDArray[np.float64]:
    """Quaternion inverse q*/|q|²."""
    q = np.asarray(q, np.float64)
    return qconj(q) / np.sum(q * q, axis=-1, keepdims=True)


def _polar(a: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """A quaternion as a complex number a0 + i|a1|: returns (ρ, angle t ∈ [0, π], unit axis u).

    u is 0 where a1 = 0 (then A is real).
    """
    a0, a1 = a[..., 0], a[..., 1:]
    r = np.linalg.norm(a1, axis=-1)
    u = a1 / np.where(r > 0.0, r, 1.0)[..., None]
    return np.hypot(a0, r), np.arctan2(r, a0), u


def _complex_to_quat(re: NDArray[np.float64], im: NDArray[np.float64],
                     u: NDArray[np.float64]) -> NDArray[np.float64]:
    """The quaternion re + im·u for a unit axis u (Theorem 2: i ↦ u)."""
    return np.concatenate([np.asarray(re)[..., None], np.asarray(im)[..., None] * u], axis=-1)


def qpow(q: ArrayLike, alpha: ArrayLike) -> NDArray[np.float64]:
    """Principal power q^α of quaternions (Montgomery-Smith, Theorem 2): ρ^α(cos αt + sin αt·u)."""
    q = np.asarray(q, np.float64)
    alpha = np.asarray(alpha, np.float64)
    rho, t, u = _polar(q)
    scale = rho ** alpha
    return _complex_to_quat(scale * np.cos(alpha * t), scale * np.sin(alpha * t), u)


def qslerp(p: ArrayLike, q: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Spherical interpolation of unit quaternions p·(p*·q)^t, taking the shorter arc."""
    p, q = np.asarray(p, np.float64), np.asarray(q, np.float64)
    rel = qmul(qconj(p), q)
    rel = np.where(rel[..., :1] < 0.0, -rel, rel)
    return qmul(p, qpow(rel, t))


# -- dual quaternions ------------------------------------------------------------------------

def _parts(z: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    return z[..., :4], z[..., 4:]


def _join(real: ArrayLike, dual: ArrayLike) -> DQArray:
    real, dual = np.broadcast_arrays(np.asarray(real, np.float64), np.asarray(dual, np.float64))
    return np.concatenate([real, dual], axis=-1)


def identity(shape: tuple[int, ...] = ()) -> DQArray:
    """The identity motion 1 + 0ε."""
    out = np.zeros((*shape, 8))
    out[..., 0] = 1.0
    return out


def check_unit(z: ArrayLike, name: str = "z") -> DQArray:
    """Validate unit dual quaternions (..., 8): finite, |q_r| = 1 and ⟨q_r, q_d⟩ = 0 within 1e-9.

    Within the tolerance the input is renormalised (q_r/|q_r|, then q_d made orthogonal to
    q_r); beyond it InputError names ``name`` and the offending norm.
    """
    z = _checks.last_axis(name, z, 8)
    real, dual = _parts(z)
    scale = _checks.unit_scale(name, np.linalg.norm(real, axis=-1))[..., None]
    real, dual = real * scale, dual * scale
    inner = np.sum(real * dual, axis=-1)
    _checks.unit_scale(f"{name} (⟨q_r, q_d⟩ + 1)", inner + 1.0)
    return _join(real, dual - inner[..., None] * real)


def mul(a: ArrayLike, b: ArrayLike) -> DQArray:
    """Dual quaternion product (a_r + a_dε)(b_r + b_dε) = a_r·b_r + (a_r·b_d + a_d·b_r)ε.

    a·b applies b first, then a.
    """
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    ar, ad = _parts(a)
    br, bd = _parts(b)
    return _join(qmul(ar, br), qmul(ar, bd) + qmul(ad, br))


CONJUGATES = ("quaternion", "dual", "combined")


def conj(z: ArrayLike, kind: str = "quaternion") -> DQArray:
    """The three conjugates of a dual quaternion (dual-quaternions-notes; design.md §3).

    kind = "quaternion": q_r* + q_d*ε (the inverse of a unit dual quaternion);
    "dual": q_r − q_dε; "combined": q_r* − q_d*ε (used by the point sandwich ζ·p·ζ̄).
    """
    _checks.one_of("kind", kind, CONJUGATES)
    z = np.asarray(z, np.float64)
    real, dual = _parts(z)
    if kind == "quaternion":
        return _join(qconj(real), qconj(dual))
    if kind == "dual":
        return _join(real, -dual)
    return _join(qconj(real), -qconj(dual))


def norm(z: ArrayLike) -> NDArray[np.float64]:
    """Dual-number norm |A + εB| = |A| + ε·Re(A·B̄)/|A| (Montgomery-Smith, Cor. 4): (..., 2)."""
    z = np.asarray(z, np.float64)
    real, dual = _parts(z)
    size = np.linalg.norm(real, axis=-1)
    return np.stack([size, np.sum(real * dual, axis=-1) / size], axis=-1)


def inv(z: ArrayLike) -> DQArray:
    """Inverse of a unit dual quaternion: its quaternion conjugate q_r* + q_d*ε."""
    return conj(check_unit(z, "z"), "quaternion")


def from_rt(rotation: ArrayLike, translation: ArrayLike) -> DQArray:
    """Unit dual quaternion of "rotate by q, then translate by t": q + ½·t·q·ε.

    rotation : (..., 4) unit quaternions (w, x, y, z); translation : (..., 3).
    """
    q = _checks.last_axis("rotation", rotation, 4)
    q = q * _checks.unit_scale("rotation", np.linalg.norm(q, axis=-1))[..., None]
    t = _checks.last_axis("translation", translation, 3)
    tq = np.concatenate([np.zeros((*t.shape[:-1], 1)), t], axis=-1)
    return _join(q, 0.5 * qmul(tq, q))


def to_rt(z: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(rotation (..., 4), translation (..., 3)) of unit dual quaternions: t = 2·q_d·q_r*."""
    z = check_unit(z, "z")
    real, dual = _parts(z)
    return real, 2.0 * qmul(dual, qconj(real))[..., 1:]


def transform(z: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
    """Transform points by the sandwich p' = ζ·(1 + εv)·ζ̄ (ζ̄ the combined conjugate;
    kenwright eq. 7).

    z : (..., 8) unit dual quaternions; points : (..., 3), broadcast together.
    """
    z = check_unit(z, "z")
    v = _checks.last_axis("points", points, 3)
    p = np.zeros((*v.shape[:-1], 8))
    p[..., 0] = 1.0
    p[..., 5:] = v
    return mul(mul(z, p), conj(z, "combined"))[..., 5:]


def _split_dual(a: NDArray[np.float64], b: NDArray[np.float64]):
    """B = b0 + b1 + b2 with b1 ∥ a1 and b2 ⊥ a1 (Theorem 3); returns (ρ, t, u, B1, b2).

    Where a1 = 0 every vector counts as parallel, so b1 = b_vec and b2 = 0, which is the
    choice the paper makes for the a1 = 0 cases of Corollaries 6 and 7.
    """
    rho, t, u = _polar(a)
    bv = b[..., 1:]
    along = np.sum(bv * u, axis=-1, keepdims=True) * u
    real_a = (np.linalg.norm(a[..., 1:], axis=-1) == 0.0)[..., None]
    b1 = np.where(real_a, bv, along)
    b2 = bv - b1
    big_b1 = np.concatenate([b[..., :1], b1], axis=-1)
    return rho, t, u, big_b1, b2


def _vec(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """A 3-vector as a pure quaternion."""
    return np.concatenate([np.zeros((*v.shape[:-1], 1)), v], axis=-1)


def exp(x: ArrayLike) -> DQArray:
    """Exponential by Montgomery-Smith Cor. 5.

    exp(A + εB) = e^{a0}((cos|a1| + (sin|a1|/|a1|)·a1)(1 + εB1) + ε(sin|a1|/|a1|)·b2),
    with sin|a1|/|a1| = 1 at a1 = 0. exp(½(ω + εv)) is the unit dual quaternion of the
    se(3) twist (ω, v) (the matrix exponential of [[ω×, v], [0, 0]]).
    """
    x = _checks.last_axis("x", x, 8)
    a, b = _parts(x)
    _, _, _, big_b1, b2 = _split_dual(a, b)
    r = np.linalg.norm(a[..., 1:], axis=-1)
    k = sinc(r)
    scale = np.exp(a[..., 0])[..., None]
    ea = np.concatenate([np.cos(r)[..., None], k[..., None] * a[..., 1:]], axis=-1)
    real = scale * ea
    dual = scale * (qmul(ea, big_b1) + k[..., None] * _vec(b2))
    return _join(real, dual)


def log(z: ArrayLike) -> DQArray:
    """Logarithm by Montgomery-Smith Cor. 6 (a right inverse of :func:`exp`).

    log(A + εB) = log|A| + (t/|a1|)(a1 + εb2) + ε·Ā·B1/|A|², t the polar angle of
    (a0, |a1|), and t/|a1| → 1/|A| as a1 → 0 (a0 > 0). For a1 = 0 and a0 < 0 (a
    full turn) the paper's choice (17) is taken with p = 0: log|a0| + π·b1/|b1| + ε·B1/a0,
    the axis being z when b1 = 0.

    Raises
    ------
    DegenerateError
        When A = 0.
    """
    z = _checks.last_axis("z", z, 8)
    a, b = _parts(z)
    rho, t, _, big_b1, b2 = _split_dual(a, b)
    if (rho == 0.0).any():
        raise DegenerateError("log is undefined when the real part is 0", field="z", value=z)
    # t/|a1| divides two accurate numbers; only a1 = 0 needs the limit 1/|A| (a0 > 0).
    r = np.linalg.norm(a[..., 1:], axis=-1)
    k = np.where(r > 0.0, t / np.where(r > 0.0, r, 1.0), 1.0 / rho)[..., None]
    real = np.concatenate([np.log(rho)[..., None], k * a[..., 1:]], axis=-1)
    dual = k * _vec(b2) + qmul(qconj(a), big_b1) / (rho * rho)[..., None]
    full_turn = (r == 0.0) & (a[..., 0] < 0.0)
    if full_turn.any():
        b1 = big_b1[..., 1:]
        size = np.linalg.norm(b1, axis=-1, keepdims=True)
        axis = np.where(size > 0.0, b1 / np.where(size > 0.0, size, 1.0), [0.0, 0.0, 1.0])
        turn_real = np.concatenate([np.log(rho)[..., None], np.pi * axis], axis=-1)
        real = np.where(full_turn[..., None], turn_real, real)
        dual = np.where(full_turn[..., None], big_b1 / a[..., :1], dual)
    return _join(real, dual)


def power(z: ArrayLike, alpha: ArrayLike) -> DQArray:
    """Real power by Montgomery-Smith Cor. 7, for A ∉ (−∞, 0].

    (A + εB)^α = A^α + ε·α·A^{α−1}·B1 + ε·(Im A^α / Im A)·b2, where Im A^α / Im A =
    ρ^{α−1}·sin(αt)/sin(t) → α·ρ^{α−1} as a1 → 0 (a series below t = 1e-4).
    z and alpha broadcast over leading axes.

    Raises
    ------
    DegenerateError
        When the real part A is a non-positive real number.
    """
    z = _checks.last_axis("z", z, 8)
    alpha = _checks.finite("alpha", alpha)
    a, b = _parts(z)
    rho, t, _, big_b1, b2 = _split_dual(a, b)
    if ((rho == 0.0) | (np.pi - t < _TIE)).any():
        raise DegenerateError("power is undefined when the real part lies on (-inf, 0]",
                              field="z", value=z)
    a_alpha = qpow(a, alpha)
    # Im(A^α)/Im(A) = ρ^(α−1)·sin(αt)/sin(t): both sines from the same t, so that near a
    # full turn their rounding cancels as it does in the planar DCN closed form.
    ratio = rho ** (alpha - 1.0) * sin_ratio(alpha, t)
    dual = alpha[..., None] * qmul(qpow(a, alpha - 1.0), big_b1) + ratio[..., None] * _vec(b2)
    return _join(a_alpha, dual)


def cayley(z: ArrayLike) -> DQArray:
    """Cayley transform (1 + ζ)/(1 − ζ) by Montgomery-Smith Cor. 8 (Selig's formula).

    = (1 + A)(1 − A)⁻¹ + 2ε·(1 − A)⁻¹·B·(1 − A)⁻¹.

    Raises
    ------
    DegenerateError
        When A = 1.
    """
    z = _checks.last_axis("z", z, 8)
    a, b = _parts(z)
    one = np.zeros_like(a)
    one[..., 0] = 1.0
    denom = one - a
    if (np.linalg.norm(denom, axis=-1) < _TIE).any():
        raise DegenerateError("the Cayley transform is undefined at A = 1", field="z", value=z)
    d_inv = qinv(denom)
    return _join(qmul(one + a, d_inv), 2.0 * qmul(qmul(d_inv, b), d_inv))


# -- interpolation ---------------------------------------------------------------------------

def _turn_key(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """The vector component deciding an exact half turn: z, else x, else y."""
    x, y, zc = v[..., 0], v[..., 1], v[..., 2]
    return np.where(np.abs(zc) > _TIE, zc, np.where(np.abs(x) > _TIE, x, y))


def _flip(d: NDArray[np.float64], turn: str) -> NDArray[np.bool_]:
    """Where the quaternion d must be negated for d^t to turn the way ``turn`` asks."""
    w, v = d[..., 0], d[..., 1:4]
    # w = cos(Δ/2), z = sin(Δ/2) for a rotation Δ about z: the tie band is the DCN one.
    if turn == "shortest":
        return np.where(np.abs(w) <= COMPONENT_TIE, _turn_key(v) < 0.0, w < 0.0)
    zc = v[..., 2]
    no_turn = np.abs(zc) <= COMPONENT_TIE * np.maximum(1.0, np.abs(w))
    return np.where(no_turn, w < 0.0, zc < 0.0 if turn == "ccw" else zc > 0.0)


def align(d: ArrayLike, turn: str = "shortest") -> DQArray:
    """Choose the sign of a relative motion d so that d^t turns the way ``turn`` asks.

    "shortest": w ≥ 0 (rotation ≤ π; an exact half turn goes positively about z, else x, else
    y). "ccw"/"cw": positive/negative rotation about the world z axis (the plane's normal), so
    planar motions match :func:`robodcn.dcn.align`; a zero rotation keeps w > 0.
    """
    _checks.one_of("turn", turn, TURNS)
    d = np.asarray(d, np.float64)
    return np.where(_flip(d, turn)[..., None], -d, d)


def sclerp(a: ArrayLike, b: ArrayLike, t: ArrayLike, *, turn: str = "shortest") -> DQArray:
    """Screw linear interpolation ζA·(ζA⁻¹·ζB)^t (kenwright eq. 5, corrected; design.md §3).

    a, b : (..., 8) unit dual quaternions; t broadcasts against their leading axes.
    The relative motion's sign is chosen by :func:`align`.
    """
    a = check_unit(a, "a")
    b = check_unit(b, "b")
    t = _checks.finite("t", t)
    rel = align(mul(conj(a, "quaternion"), b), turn)
    return mul(a, power(rel, t))


def normalize(z: ArrayLike) -> DQArray:
    """Project onto unit dual quaternions: q_r/|q_r|, q_d/|q_r| minus its component along q_r."""
    z = np.asarray(z, np.float64)
    real, dual = _parts(z)
    size = np.linalg.norm(real, axis=-1, keepdims=True)
    if (size < _TIE).any():
        raise DegenerateError("cannot normalise a dual quaternion whose real part vanishes",
                              field="z", value=z)
    real, dual = real / size, dual / size
    return _join(real, dual - np.sum(real * dual, axis=-1, keepdims=True) * real)


def dlb(zs: ArrayLike, weights: ArrayLike) -> DQArray:
    """Dual quaternion linear blending Σwᵢζᵢ / ‖Σwᵢζᵢ‖ (Kavan et al.; kenwright §DLB).

    zs : (n, ..., 8), blended along the first axis after bringing every ζᵢ into the hemisphere
    of ζ₁ (the sign making q_r,1*·q_r,i the shortest rotation, ties broken as in
    :func:`align`), so the blend is left-invariant. weights : (n,).

    Raises
    ------
    DegenerateError
        When the blended real part vanishes.
    """
    zs = check_unit(zs, "zs")
    if zs.ndim < 2:
        raise InputError(f"zs must have shape (n, ..., 8), got {zs.shape}", field="zs", value=zs)
    w = _checks.finite("weights", weights)
    if w.ndim != 1 or w.shape[0] != zs.shape[0]:
        raise InputError(f"weights must have shape ({zs.shape[0]},), got {w.shape}",
                         field="weights", value=weights)
    sign = np.where(_flip(qmul(qconj(zs[:1, ..., :4]), zs[..., :4]), "shortest"), -1.0, 1.0)
    w = w.reshape(w.shape + (1,) * (zs.ndim - 2))
    blend = np.sum((w * sign)[..., None] * zs, axis=0)
    size = np.linalg.norm(blend[..., :4], axis=-1)
    if (size < _TIE).any():
        raise DegenerateError("dual quaternion blend is undefined: the weighted real parts "
                              "cancel", field="weights", value=weights)
    return normalize(blend)


def seplerp(a: ArrayLike, b: ArrayLike, t: ArrayLike, *, turn: str = "shortest") -> DQArray:
    """Separate interpolation (kenwright SEP-LERP): lerp the translations, slerp the rotations.

    The rotation path follows ``turn`` like :func:`sclerp`.
    """
    a = check_unit(a, "a")
    b = check_unit(b, "b")
    t = _checks.finite("t", t)
    qa, ta = to_rt(a)
    qb, tb = to_rt(b)
    rel = align(_join(qmul(qconj(qa), qb), np.zeros_like(qa)), turn)[..., :4]
    q = qmul(qa, qpow(rel, t))
    tt = np.asarray(t)[..., None]
    return from_rt(q, ta + tt * (tb - ta))


def kenlerp(a: ArrayLike, b: ArrayLike, t: ArrayLike, beta: float = 1.0, *,
            turn: str = "shortest") -> DQArray:
    """Kenwright's hybrid KenLERP(β) (kenwright eq. 6, with the argument order of its prose).

    With ScLERP(t) = (v_sc, q_sc) and SEP-LERP(t) = (v_sep, q_sep), returns
    (lerp(v_sep, v_sc; β), slerp(q_sep, q_sc; β)): β = 0 is SEP-LERP (decoupled), β = 1 is
    ScLERP (coupled), β > 1 extrapolates past ScLERP ("amplification").
    """
    beta = float(_checks.finite("beta", beta))
    q_sc, v_sc = to_rt(sclerp(a, b, t, turn=turn))
    q_sep, v_sep = to_rt(seplerp(a, b, t, turn=turn))
    return from_rt(qslerp(q_sep, q_sc, beta), v_sep + beta * (v_sc - v_sep))
