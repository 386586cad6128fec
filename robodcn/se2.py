"""Planar rigid motions as 3×3 homogeneous matrices: the yardstick for the DCN fast path.

Closed-form exponential and logarithm of SE(2) (Lynch & Park, Modern Robotics §3.3 in the
plane) and matrix ScLERP exp(s·log(B·A⁻¹))·A. Arrays of matrices have shape (..., 3, 3).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn._series import SERIES_ANGLE


def from_pose(pose: ArrayLike) -> NDArray[np.float64]:
    """Homogeneous matrices [[cos θ, −sin θ, x], [sin θ, cos θ, y], [0, 0, 1]] of poses (..., 3)."""
    pose = _checks.last_axis("pose", pose, 3)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    m = np.zeros((*pose.shape[:-1], 3, 3))
    m[..., 0, 0], m[..., 0, 1], m[..., 0, 2] = c, -s, pose[..., 0]
    m[..., 1, 0], m[..., 1, 1], m[..., 1, 2] = s, c, pose[..., 1]
    m[..., 2, 2] = 1.0
    return m


def to_pose(m: ArrayLike) -> NDArray[np.float64]:
    """Poses (x, y, θ ∈ (−π, π]) of homogeneous matrices (..., 3, 3)."""
    m = np.asarray(m, np.float64)
    return np.stack([m[..., 0, 2], m[..., 1, 2], np.arctan2(m[..., 1, 0], m[..., 0, 0])], axis=-1)


def _v_coefficients(theta: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """(sin θ/θ, (1 − cos θ)/θ) with series near 0: the entries of SE(2)'s V(θ)."""
    small = np.abs(theta) < SERIES_ANGLE
    safe = np.where(small, 1.0, theta)
    a = np.where(small, 1.0 - theta * theta / 6.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 * theta - theta ** 3 / 24.0, (1.0 - np.cos(safe)) / safe)
    return a, b


def exp(twist: ArrayLike) -> NDArray[np.float64]:
    """exp of se(2) twists (vx, vy, ω): [[R(ω), V(ω)·v], [0, 1]], V = [[a, −b], [b, a]],
    a = sin ω/ω, b = (1 − cos ω)/ω."""
    twist = _checks.last_axis("twist", twist, 3)
    w = twist[..., 2]
    a, b = _v_coefficients(w)
    vx, vy = twist[..., 0], twist[..., 1]
    return from_pose(np.stack([a * vx - b * vy, b * vx + a * vy, w], axis=-1))


def log(m: ArrayLike) -> NDArray[np.float64]:
    """Twist (vx, vy, ω), ω ∈ (−π, π], with exp(twist) = m: v = V(ω)⁻¹·t."""
    pose = to_pose(m)
    w = pose[..., 2]
    a, b = _v_coefficients(w)
    det = a * a + b * b
    x, y = pose[..., 0], pose[..., 1]
    return np.stack([(a * x + b * y) / det, (a * y - b * x) / det, w], axis=-1)


def inv(m: ArrayLike) -> NDArray[np.float64]:
    """Inverse rigid motion [[Rᵀ, −Rᵀt], [0, 1]]."""
    m = np.asarray(m, np.float64)
    out = np.zeros_like(m)
    rt = np.swapaxes(m[..., :2, :2], -1, -2)
    out[..., :2, :2] = rt
    out[..., :2, 2] = -(rt @ m[..., :2, 2:3])[..., 0]
    out[..., 2, 2] = 1.0
    return out


def sclerp(a: ArrayLike, b: ArrayLike, s: ArrayLike, *,
           omega: float | None = None) -> NDArray[np.float64]:
    """Matrix screw interpolation exp(s·log(B·A⁻¹))·A, s of shape (n,) → (n, 3, 3).

    log takes the rotation in (−π, π]; pass ``omega`` (the signed turn from A to B) to go
    round another way: the twist is then (V(ω)⁻¹·t, ω), the same screw's other branch.
    """
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    s = _checks.samples("s", s)
    rel = b @ inv(a)
    if omega is None:
        twist = log(rel)
    else:
        ca, cb = _v_coefficients(np.asarray(omega, np.float64))
        x, y = rel[..., 0, 2], rel[..., 1, 2]
        det = ca * ca + cb * cb
        twist = np.array([(ca * x + cb * y) / det, (ca * y - cb * x) / det, omega])
    return exp(s[:, None] * twist) @ a
