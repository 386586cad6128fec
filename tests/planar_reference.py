"""An independent planar reference for the dynamics tests: the older planar arm model.

Not robodcn code: robodcn's one inverse dynamics is :func:`robodcn.dynamics.inverse_dynamics`
on :func:`robodcn.config.rigid_chain`. This model has its own equations, so the dynamics
tests (tests/test_dynamics.py, tests/test_rigid_chain.py) compare that implementation
against it (it was ``robodcn.stream.servo_model.ArmDynamics``).

Arm (planar serial chain, the arm file's optional ``[dynamics]`` table; defaults: 0.10 kg a
link, centre of mass mid-link, slender-rod inertia m·l²/12, no payload, plane horizontal).
With absolute link angles φ = S·q (S lower-triangular ones), body b (a link's centre of mass
or the payload) at p_b = Σ_s L_bs·(cos φ_s, sin φ_s), the Lagrangian gives (Spong,
Hutchinson & Vidyasagar, *Robot Modeling and Control*, §7.4)::

    τ = Sᵀ·(D(φ)·φ̈ + h(φ, φ̇) + g(φ)),   D_sr = H_sr·cos(φ_s − φ_r) + δ_sr·I_s,
    h_s = Σ_r H_sr·sin(φ_s − φ_r)·φ̇_r²,  H_sr = Σ_b m_b·L_bs·L_br,
    g_s = −(Σ_b m_b·L_bs)·(G·(−sin φ_s, cos φ_s))
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

#: Default link mass, kg (the simulator's and robodcn.config's default too).
DEFAULT_LINK_MASS_KG = 0.10


@dataclass(frozen=True)
class ArmDynamics:
    """Mass properties of a planar arm (SI), from its ``[dynamics]`` table and links.

    A planar reference model only (module notes)."""

    links: tuple[float, ...]
    masses: tuple[float, ...]
    com: tuple[float, ...]
    inertias: tuple[float, ...]
    payload: float = 0.0
    gravity: tuple[float, float] = (0.0, 0.0)

    @classmethod
    def of(cls, links: tuple[float, ...], table: Mapping[str, Any] | None) -> ArmDynamics:
        table = table or {}
        n = len(links)
        masses = tuple(table.get("link_masses", [DEFAULT_LINK_MASS_KG] * n))
        com = tuple(table.get("link_com", [length / 2 for length in links]))
        inertias = tuple(table.get("link_inertias",
                                   [m * length ** 2 / 12 for m, length in zip(masses, links,
                                                                              strict=True)]))
        gravity = table.get("gravity", [0.0, 0.0])
        if isinstance(gravity, bool):
            gravity = [0.0, -9.81] if gravity else [0.0, 0.0]
        return cls(tuple(links), masses, com, inertias, float(table.get("payload_kg", 0.0)),
                   (float(gravity[0]), float(gravity[1])))

    def _lever(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Body masses m (B,) and lever lengths L (B, n) (module notes)."""
        n = len(self.links)
        rows, masses = [], []
        for b in range(n):
            rows.append([self.links[s] if s < b else (self.com[b] if s == b else 0.0)
                         for s in range(n)])
            masses.append(self.masses[b])
        if self.payload > 0.0:
            rows.append(list(self.links))
            masses.append(self.payload)
        return np.array(masses), np.array(rows)

    def torques(self, q: NDArray[np.float64], qd: NDArray[np.float64],
                qdd: NDArray[np.float64]) -> NDArray[np.float64]:
        """Joint torques τ (n_samples, n) of the module's equations, vectorised over samples."""
        m, lever = self._lever()
        n = len(self.links)
        s_mat = np.tril(np.ones((n, n)))
        phi, phid, phidd = q @ s_mat.T, qd @ s_mat.T, qdd @ s_mat.T
        h_mat = np.einsum("b,bs,br->sr", m, lever, lever)
        diff = phi[:, :, None] - phi[:, None, :]
        d_mat = h_mat * np.cos(diff) + np.diag(self.inertias)
        tau_abs = np.einsum("tsr,tr->ts", d_mat, phidd)
        tau_abs += np.einsum("sr,tsr,tr->ts", h_mat, np.sin(diff), phid ** 2)
        first = m @ lever      # Σ_b m_b·L_bs
        gx, gy = self.gravity
        tau_abs -= first * (gx * -np.sin(phi) + gy * np.cos(phi))
        return tau_abs @ s_mat


__all__ = ["DEFAULT_LINK_MASS_KG", "ArmDynamics"]
