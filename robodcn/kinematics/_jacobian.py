"""The planar arm's Jacobian and singularity measures (conventions: :mod:`._planar`).

J (n, 3, k) of the tool pose (x, y, θ) with respect to the joints, from φ_i = q_1 + … + q_i:
∂x/∂q_j = −Σ_{i≥j} l_i sin φ_i, ∂y/∂q_j = Σ_{i≥j} l_i cos φ_i, ∂θ/∂q_j = 1; the wrist
position's |det| is l1·l2·|sin q2| (Lynch & Park, *Modern Robotics* §5.1), zero at the
stretched-out or folded arm.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.kinematics._planar import _joints, _links

__all__ = ["jacobian", "manipulability", "near_singular"]


def jacobian(links: Sequence[float], q: ArrayLike) -> NDArray[np.float64]:
    """Jacobian (n, 3, k) of (x, y, θ) with respect to q: ∂x/∂q_j = −Σ_{i≥j} l_i sin φ_i,
    ∂y/∂q_j = Σ_{i≥j} l_i cos φ_i, ∂θ/∂q_j = 1."""
    links = _links(links)
    q = _joints(q, len(links))
    phi = np.cumsum(q, axis=1)
    lengths = np.asarray(links)
    # Reverse cumulative sums give the Σ over i ≥ j.
    jx = -np.cumsum((lengths * np.sin(phi))[:, ::-1], axis=1)[:, ::-1]
    jy = np.cumsum((lengths * np.cos(phi))[:, ::-1], axis=1)[:, ::-1]
    return np.stack([jx, jy, np.ones_like(q)], axis=1)


def manipulability(links: Sequence[float], q: ArrayLike) -> NDArray[np.float64]:
    """|det| of the wrist-position Jacobian, l1·l2·|sin q2| (n,): 0 at the straight or folded
    arm (for 3R it is also |det J| of the full (x, y, θ) Jacobian)."""
    links = _links(links)
    q = _joints(q, len(links))
    return links[0] * links[1] * np.abs(np.sin(q[:, 1]))


def near_singular(links: Sequence[float], q: ArrayLike, tol: float = 1e-3) -> NDArray[np.bool_]:
    """Whether each configuration is within ``tol`` of a singularity: |sin q2| < tol."""
    links = _links(links)
    q = _joints(q, len(links))
    return np.abs(np.sin(q[:, 1])) < tol
