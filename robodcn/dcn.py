"""Anti-commutative dual complex numbers (DCN) for planar rigid motions.

A DCN is p = p0 + p1·ε with p0, p1 complex (Matsuda, Kaji & Ochiai, "Anti-commutative Dual
Complex Numbers and 2D Rigid Transformation"; shared/design.md §2). Arrays of DCNs are float
arrays of shape (..., 4) holding (Re p0, Im p0, Re p1, Im p1); every function here is
vectorised over the leading axes and broadcasts like numpy.

Conventions
-----------
* Product: (p0 + p1ε)(q0 + q1ε) = p0·q0 + (p1·conj(q0) + p0·q1)ε.
* Composition order: p·q applies q first, then p (like matrices acting on columns).
* A unit DCN (|p0| = 1) acts on a point v ∈ ℂ by v ↦ p0²·v + 2·p0·p1: a rotation by
  2·arg p0 followed by the translation 2·p0·p1. p and −p are the same motion.
* Pose (x, y, θ) ↔ DCN: p0 = e^{iθ/2}, p1 = (x + iy) / (2·p0).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn._series import sin_ratio, sinc
from robodcn.errors import DegenerateError, InputError

DCNArray = NDArray[np.float64]
"""Float array of shape (..., 4): (Re p0, Im p0, Re p1, Im p1)."""

TURNS = ("shortest", "ccw", "cw")

#: A rotation within this many radians of a half turn counts as an exact half turn, whose
#: direction "shortest" fixes to ccw (and within it of a whole turn, as no rotation). One
#: tolerance for every path: :func:`robodcn.interpolate.turn_angle` applies it to Δθ, the
#: sign choices here (and :mod:`robodcn.dualquat`'s) to d0 = e^{iΔθ/2}.
HALF_TURN_TOLERANCE = 1e-12
#: The same band on a component of a unit d0 = cos(Δθ/2) + i·sin(Δθ/2): Δθ within
#: HALF_TURN_TOLERANCE of π ⟺ |cos(Δθ/2)| ≤ sin(HALF_TURN_TOLERANCE/2).
COMPONENT_TIE = float(np.sin(0.5 * HALF_TURN_TOLERANCE))


# -- storage ---------------------------------------------------------------------------------

def split(p: ArrayLike) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """The complex parts (p0, p1) of a DCN array of shape (..., 4)."""
    p = np.asarray(p, dtype=np.float64)
    return p[..., 0] + 1j * p[..., 1], p[..., 2] + 1j * p[..., 3]


def join(p0: ArrayLike, p1: ArrayLike) -> DCNArray:
    """A DCN array (..., 4) from complex parts p0, p1 (broadcast together)."""
    p0, p1 = np.broadcast_arrays(np.asarray(p0, np.complex128), np.asarray(p1, np.complex128))
    out = np.empty((*p0.shape, 4))
    out[..., 0], out[..., 1] = p0.real, p0.imag
    out[..., 2], out[..., 3] = p1.real, p1.imag
    return out


def identity(shape: tuple[int, ...] = ()) -> DCNArray:
    """The identity motion 1 + 0ε, of the given leading shape."""
    out = np.zeros((*shape, 4))
    out[..., 0] = 1.0
    return out


def check_unit(p: ArrayLike, name: str = "p") -> DCNArray:
    """Validate a unit DCN array: finite, shape (..., 4), |p0| = 1 within 1e-9 (then renormalised).

    Raises
    ------
    InputError
        Naming ``name`` and the offending value.
    """
    p = _checks.last_axis(name, p, 4)
    return p * _checks.unit_scale(name, np.hypot(p[..., 0], p[..., 1]))[..., None]


# -- the algebra (design.md §2 table) --------------------------------------------------------

def mul(p: ArrayLike, q: ArrayLike) -> DCNArray:
    """DCN product p·q = p0·q0 + (p1·conj(q0) + p0·q1)ε (dcn-paper, Def. 3.1).

    p, q: (..., 4), broadcast. The result applies q first, then p.
    """
    p0, p1 = split(p)
    q0, q1 = split(q)
    return join(p0 * q0, p1 * np.conj(q0) + p0 * q1)


def conj(p: ArrayLike) -> DCNArray:
    """Involution p̃ = conj(p0) + p1ε (dcn-paper, §3)."""
    p0, p1 = split(p)
    return join(np.conj(p0), p1)


def norm(p: ArrayLike) -> NDArray[np.float64]:
    """Norm |p| = |p0|, shape (...)."""
    p = np.asarray(p, dtype=np.float64)
    return np.hypot(p[..., 0], p[..., 1])


def inv(p: ArrayLike) -> DCNArray:
    """Inverse of a unit DCN: p⁻¹ = conj(p0) − p1ε, so that p·p⁻¹ = p⁻¹·p = 1."""
    p0, p1 = split(check_unit(p, "p"))
    return join(np.conj(p0), -p1)


def act(p: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Apply the motion p to points v: v ↦ p0²·v + 2·p0·p1 (dcn-paper, Prop. 3.3).

    Parameters
    ----------
    p : (..., 4) unit DCNs.
    v : (..., 2) points (x, y), broadcast against p's leading axes.

    Returns
    -------
    (..., 2) transformed points.
    """
    p0, p1 = split(check_unit(p, "p"))
    v = _checks.last_axis("v", v, 2)
    w = p0 * p0 * (v[..., 0] + 1j * v[..., 1]) + 2.0 * p0 * p1
    return np.stack([w.real, w.imag], axis=-1)


def from_pose(pose: ArrayLike) -> DCNArray:
    """Unit DCN of poses (x, y, θ): p0 = e^{iθ/2}, p1 = (x + iy)·conj(p0)/2.

    pose : (..., 3), metres and radians.
    """
    pose = _checks.last_axis("pose", pose, 3)
    half = 0.5 * pose[..., 2]
    out = np.empty((*pose.shape[:-1], 4))
    c, s = np.cos(half), np.sin(half)
    x, y = 0.5 * pose[..., 0], 0.5 * pose[..., 1]
    out[..., 0], out[..., 1] = c, s
    # (x + iy)/2 · (c − is)
    out[..., 2], out[..., 3] = x * c + y * s, y * c - x * s
    return out


def to_pose(p: ArrayLike) -> NDArray[np.float64]:
    """Poses (x, y, θ) of unit DCNs; θ = 2·arg p0 wrapped to (−π, π], (x + iy) = 2·p0·p1."""
    p0, p1 = split(check_unit(p, "p"))
    c = 2.0 * p0 * p1
    theta = 2.0 * np.angle(p0)
    return np.stack([c.real, c.imag, wrap_angle(theta)], axis=-1)


def wrap_angle(theta: ArrayLike) -> NDArray[np.float64]:
    """Angles wrapped to (−π, π]."""
    theta = np.asarray(theta, dtype=np.float64)
    wrapped = np.remainder(theta + np.pi, 2.0 * np.pi) - np.pi
    return np.where(wrapped == -np.pi, np.pi, wrapped)


def to_matrix(p: ArrayLike) -> NDArray[np.float64]:
    """Homogeneous 3×3 matrices of unit DCNs (design.md §2).

    [[Re p0², −Im p0², Re 2p0p1], [Im p0², Re p0², Im 2p0p1], [0, 0, 1]], shape (..., 3, 3).
    """
    p0, p1 = split(check_unit(p, "p"))
    r, t = p0 * p0, 2.0 * p0 * p1
    m = np.zeros((*p0.shape, 3, 3))
    m[..., 0, 0], m[..., 0, 1], m[..., 0, 2] = r.real, -r.imag, t.real
    m[..., 1, 0], m[..., 1, 1], m[..., 1, 2] = r.imag, r.real, t.imag
    m[..., 2, 2] = 1.0
    return m


def from_matrix(m: ArrayLike) -> DCNArray:
    """Unit DCNs of homogeneous planar rigid-motion matrices (..., 3, 3).

    Raises InputError unless the upper-left block is a rotation and the last row (0, 0, 1),
    both within 1e-9.
    """
    m = _checks.finite("m", m)
    if m.ndim < 2 or m.shape[-2:] != (3, 3):
        raise InputError(f"m must have shape (..., 3, 3), got {m.shape}", field="m", value=m)
    rot = m[..., :2, :2]
    error = np.abs(rot @ np.swapaxes(rot, -1, -2) - np.eye(2)).max(axis=(-1, -2))
    error = np.maximum(error, np.abs(np.linalg.det(rot) - 1.0))
    error = np.maximum(error, np.abs(m[..., 2, :] - [0.0, 0.0, 1.0]).max(axis=-1))
    if error.size and error.max() > _checks.UNIT_TOLERANCE:
        raise InputError("m must be a planar rigid motion (rotation block, last row 0 0 1), "
                         f"deviation {float(error.max()):.3g}", field="m", value=m)
    theta = np.arctan2(m[..., 1, 0], m[..., 0, 0])
    return from_pose(np.stack([m[..., 0, 2], m[..., 1, 2], theta], axis=-1))


def rotation_about(center: ArrayLike, theta: ArrayLike) -> DCNArray:
    """Rotation by θ about the point c: (1 + (c/2)ε)·e^{iθ/2}·(1 − (c/2)ε) (dcn-paper, §3).

    center : (..., 2); theta : (...), radians.
    """
    center = _checks.last_axis("center", center, 2)
    theta = _checks.finite("theta", theta)
    c = 0.5 * (center[..., 0] + 1j * center[..., 1])
    zero = np.zeros_like(c)
    shift, back = join(1.0 + zero, c), join(1.0 + zero, -c)
    return mul(mul(shift, join(np.exp(0.5j * theta), 0.0 * theta)), back)


def exp(x: ArrayLike) -> DCNArray:
    """Exponential of a DCN x = a + θi + x1ε: e^a·(e^{iθ} + (sin θ/θ)·x1ε) (dcn-paper, Prop. 4.2).

    The real part a of x0 only scales (it commutes with everything); a pure x (a = 0) maps to
    a unit DCN. sin θ/θ uses its Taylor series for |θ| < 1e-4.
    """
    x = _checks.last_axis("x", x, 4)
    theta = x[..., 1]
    scale = np.exp(x[..., 0])
    k = sinc(theta)
    x1 = x[..., 2] + 1j * x[..., 3]
    return join(scale * np.exp(1j * theta), scale * k * x1)


def log(p: ArrayLike) -> DCNArray:
    """Logarithm of a unit DCN e^{iθ} + q1ε: θi + (θ/sin θ)·q1ε, θ ∈ (−π, π] (dcn-paper, Prop. 4.3).

    θ/sin θ uses its Taylor series near 0. At θ = π (p0 = −1) the logarithm of a motion with a
    translation does not exist: use −p (the same motion), which SLERP does for you.

    Raises
    ------
    DegenerateError
        When p0 = −1 and q1 ≠ 0.
    """
    p0, p1 = split(check_unit(p, "p"))
    theta = np.angle(p0)
    half_turn = np.pi - np.abs(theta) < 1e-12
    bad = half_turn & (np.abs(p1) > 0.0)
    if bad.any():
        raise DegenerateError("log is undefined for p0 = -1 with a translation; use -p, the "
                              "same motion", field="p", value=np.asarray(p)[bad][0])
    k = np.where(half_turn, 0.0, 1.0 / sinc(theta))
    return join(1j * theta, k * p1)


def _flip(re: NDArray[np.float64], im: NDArray[np.float64], turn: str) -> NDArray[np.bool_]:
    """Where d0 = re + i·im must be negated for d^t to turn the way ``turn`` asks."""
    if turn == "shortest":
        return np.where(np.abs(re) <= COMPONENT_TIE, im < 0.0, re < 0.0)
    no_turn = np.abs(im) <= COMPONENT_TIE * np.maximum(1.0, np.abs(re))
    return np.where(no_turn, re < 0.0, im < 0.0 if turn == "ccw" else im > 0.0)


def align(d: ArrayLike, turn: str = "shortest") -> DCNArray:
    """Choose the sign of a relative motion d so that its rotation follows ``turn``.

    d and −d are the same motion, but exp(t·log d) goes round by 2·arg(±d0). With
    d0 = e^{iφ}: "shortest" makes Re d0 ≥ 0 (|rotation| ≤ π, an exact half turn goes ccw),
    "ccw" makes Im d0 ≥ 0 (rotation in [0, 2π)), "cw" makes Im d0 ≤ 0 (rotation in (−2π, 0]).
    A zero rotation always keeps d0 = +1.
    """
    _checks.one_of("turn", turn, TURNS)
    d = np.asarray(d, dtype=np.float64)
    return np.where(_flip(d[..., 0], d[..., 1], turn)[..., None], -d, d)


def slerp(p: ArrayLike, q: ArrayLike, t: ArrayLike, *, turn: str = "shortest") -> DCNArray:
    """Screw linear interpolation of unit DCNs: exp(t·log(q·p⁻¹))·p (dcn-paper, Def. 5.3).

    With d = q·p⁻¹ = e^{iφ} + d1ε (sign chosen by :func:`align`), the power has the closed
    form d^t = e^{itφ} + (sin tφ / sin φ)·d1ε.

    Parameters
    ----------
    p, q : (..., 4) unit DCNs.
    t : array-like broadcasting against the leading axes of p and q; t = 0 gives p, t = 1 gives
        q (or −q, the same motion). Values outside [0, 1] extrapolate along the same screw.
    turn : "shortest" | "ccw" | "cw"
        Which way round the rotation goes (see :func:`align`).

    Returns
    -------
    (..., 4) unit DCNs.
    """
    p = check_unit(p, "p")
    q = check_unit(q, "q")
    t = _checks.finite("t", t)
    d = align(mul(q, inv(p)), turn)
    d0, d1 = split(d)
    phi = np.angle(d0)
    dt = join(np.exp(1j * t * phi), sin_ratio(t, phi) * d1)
    return mul(dt, p)


def dlb(ps: ArrayLike, weights: ArrayLike) -> DCNArray:
    """Dual linear blend Σ wᵢpᵢ / |Σ wᵢpᵢ| of unit DCNs (Kavan et al.; design.md §2).

    Each pᵢ is first brought into the hemisphere of p₁ (the sign making the relative
    rotation pᵢ0·conj(p₁0) the shortest, an exact half turn counting as ccw), which makes
    the blend independent of the sign ambiguity and bi-invariant:
    p₀·DLB(pᵢ; w) = DLB(p₀·pᵢ; w) and DLB(pᵢ; w)·p₀ = DLB(pᵢ·p₀; w).

    Parameters
    ----------
    ps : (n, ..., 4) unit DCNs, blended along the first axis.
    weights : (n,) or broadcastable to (n, ...).

    Raises
    ------
    DegenerateError
        When Σ wᵢpᵢ0 vanishes (|·| < 1e-12), e.g. equal weights on opposite rotations.
    """
    ps = check_unit(ps, "ps")
    if ps.ndim < 2:
        raise InputError(f"ps must have shape (n, ..., 4), got {ps.shape}", field="ps",
                         value=ps)
    w = _checks.finite("weights", weights)
    if w.ndim == 1:
        if w.shape[0] != ps.shape[0]:
            raise InputError(f"weights must have shape ({ps.shape[0]},), got {w.shape}",
                             field="weights", value=weights)
        w = w.reshape(w.shape + (1,) * (ps.ndim - 2))
    p0, p1 = split(ps)
    rel = p0 * np.conj(p0[:1])
    sign = np.where(_flip(rel.real, rel.imag, "shortest"), -1.0, 1.0)
    s0 = np.sum(w * sign * p0, axis=0)
    s1 = np.sum(w * sign * p1, axis=0)
    size = np.abs(s0)
    if (size < 1e-12).any():
        raise DegenerateError("dual linear blend is undefined for these weights: the weighted "
                              f"sum of rotations vanishes (|Σ wᵢpᵢ0| = {float(size.min()):.3g})",
                              field="weights",
                              value=weights)
    return join(s0 / size, s1 / size)


def to_dualquat(p: ArrayLike) -> NDArray[np.float64]:
    """Embed unit DCNs into unit dual quaternions (rotation about z, plane = xy; design.md §2).

    p0 = a + bi ↦ a + b·k, p1 = c + di ↦ (c·i + d·j)ε: in (w, x, y, z | w, x, y, z) order the
    result is (a, 0, 0, b | 0, c, d, 0), shape (..., 8). The map is a group homomorphism
    that preserves the action on points of the plane z = 0.
    """
    p = check_unit(p, "p")
    out = np.zeros((*p.shape[:-1], 8))
    out[..., 0], out[..., 3] = p[..., 0], p[..., 1]
    out[..., 5], out[..., 6] = p[..., 2], p[..., 3]
    return out


def from_dualquat(dq: ArrayLike) -> DCNArray:
    """Inverse of :func:`to_dualquat` for planar dual quaternions (..., 8).

    Raises InputError when the dual quaternion is not a motion of the xy plane.
    """
    dq = _checks.last_axis("dq", dq, 8)
    off_plane = np.abs(dq[..., [1, 2, 4, 7]]).max(axis=-1) if dq.size else np.zeros(0)
    if off_plane.size and off_plane.max() > _checks.UNIT_TOLERANCE:
        raise InputError("dq is not a planar motion (rotation about z, translation in xy)",
                         field="dq", value=dq)
    return check_unit(dq[..., [0, 3, 5, 6]], "dq")
