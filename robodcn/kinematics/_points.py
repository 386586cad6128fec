"""Every joint centre of a chain, not only its tool point: the points keep-out zones test.

Planar arm (:mod:`._planar`): φ_i = q_1 + … + q_i, joint centre j (j = 0 the first joint,
at the origin) P_j = Σ_{i<j} l_i·(cos φ_i, sin φ_i), P_k the tool point: (x, y) in its plane.

Yawed arm (:mod:`._yawed`): ψ_i = α_i − Σ_{m≤i} q_m, joint centre j in the arm's vertical
plane (r_j, z_j) = (Σ_{i<j} L_i cos ψ_i, h + Σ_{i<j} L_i sin ψ_i), P_0 the shoulder on the
yaw axis at height h, P_k the tool point (:func:`plane_fk`'s); the base frame's
(x, y) = r·(cos yaw, sin yaw).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.kinematics._planar import _joints, _links
from robodcn.kinematics._yawed import Chain


def planar_points(links: Sequence[float], q: ArrayLike) -> NDArray[np.float64]:
    """Joint centres and tool point (n, k + 1, 2) (x, y) of a planar arm at joints q
    (n, k): the first joint at the origin, the tool last (module docstring)."""
    lengths = np.asarray(_links(links))
    q = _joints(q, len(lengths))
    phi = np.cumsum(q, axis=1)
    out = np.zeros((q.shape[0], len(lengths) + 1, 2))
    np.cumsum(lengths * np.cos(phi), axis=1, out=out[:, 1:, 0])
    np.cumsum(lengths * np.sin(phi), axis=1, out=out[:, 1:, 1])
    return out


def yawed_points(chain: Chain, q: ArrayLike) -> NDArray[np.float64]:
    """Chain joint centres and tool point (n, k + 1, 2) (r, z) in the vertical plane of a
    yawed arm at joints q (n, k + 1) (yaw first, turning that plane): the shoulder first,
    the tool last (module docstring)."""
    q = _joints(q, chain.dof)
    psi = chain.angles - np.cumsum(q[:, 1:], axis=1)
    lengths = np.asarray(chain.lengths)
    out = np.zeros((q.shape[0], len(lengths) + 1, 2))
    out[:, :, 1] = chain.shoulder_height
    np.cumsum(lengths * np.cos(psi), axis=1, out=out[:, 1:, 0])
    out[:, 1:, 1] += np.cumsum(lengths * np.sin(psi), axis=1)
    return out


__all__ = ["planar_points", "yawed_points"]
