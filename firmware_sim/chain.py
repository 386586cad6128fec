"""Rigid-body dynamics of a serial chain moving in a plane, optionally turned about the
vertical by a base yaw joint.

Chain: joint i turns link i by q_i relative to link i−1; link angles φ = σ·S·q with S the
lower-triangular matrix of ones and σ = +1 (counter-clockwise positive, a planar arm) or
−1 (clockwise in the (r, z) plane: ROBOTIS's convention for a yawed arm, a positive angle
turns the arm forward and down). Link s at zero is the plane vector v_s (joint → next
joint); body b (a link's centre of mass c_b given at zero from its joint, or the payload at
the tool point) sits at p_b = Σ_s w_bs·e^{iφ_s} (points of the plane as complex numbers),
w_bs = v_s before its link, c_b on it, 0 after. With the Hermitian H_sr = Σ_b m_b w_bs w̄_br
and F_s = Σ_b m_b w_bs the kinetic energy is T = ½ φ̇ᵀ D φ̇ with
D_sr = Re(H_sr e^{i(φ_s−φ_r)}) + δ_sr I_s, and Euler–Lagrange gives::

    M(q)·q̈ + b(q, q̇) = τ,   M = Sᵀ·D·S,   b = σ·Sᵀ·(h + g),
    h_s = Σ_r Im(H_sr e^{i(φ_s−φ_r)})·φ̇_r²,   g_s = −Re(Ḡ · i F_s e^{iφ_s})

(G the gravity vector in the plane). For real H (links along their own axis) this is the
planar chain of Spong, Hutchinson & Vidyasagar, *Robot Modeling and Control* §7.4; the
complex H carries the constant offset angles of links and centres of mass given as vectors.

Base yaw (joint 0, angle ψ about +z): the plane is the vertical (r, z) plane at azimuth ψ.
A point's velocity from the yaw is normal to the plane, from the chain in it; a link's
angular velocity is φ̇_s about the joint axis plus ψ̇ about the vertical, and with principal
axes (radial, joint axis, vertical) at zero the joint axis stays one of them, so there is
no cross term either: T = ½ q̇ᵀ M q̇ + ½ I_ψ(q) ψ̇² with::

    I_ψ = I_y0 + Σ_b m_b r_b² + Σ_s (I_r,s sin² φ_s + I_z,s cos² φ_s),   r_b = Re p_b

(I_y0 the yaw body's inertia about the yaw axis; I_r,s, I_z,s link s's moments at its
centre of mass about the radial and the vertical axis at zero: after a turn by θ = −φ_s
about the joint axis the vertical reads (−sin θ, 0, cos θ) in the link's frame). This
gives the natural coupling and nothing else::

    I_ψ ψ̈ + (∂I_ψ/∂q · q̇) ψ̇ = τ_ψ,      M q̈ + b − ½ (∂I_ψ/∂q) ψ̇² = τ

where link s adds (I_r,s − I_z,s)·sin 2φ_s to ∂I_ψ/∂φ_s. I_r and I_z default to 0 (the
links turn with the yaw as point masses, the model before they could be given); products
of inertia are not modelled. Gravity is along −z and does not load the yaw.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

Vec = tuple[float, float]


def _suffix_matrix(d: list[list[float]], n: int) -> list[list[float]]:
    """M = Sᵀ D S: M_ij = Σ_{a ≥ i, b ≥ j} D_ab (suffix sums)."""
    suffix = [[0.0] * (n + 1) for _ in range(n + 1)]
    for a in range(n - 1, -1, -1):
        for b in range(n - 1, -1, -1):
            suffix[a][b] = d[a][b] + suffix[a + 1][b] + suffix[a][b + 1] - suffix[a + 1][b + 1]
    return [[suffix[i][j] for j in range(n)] for i in range(n)]


def _suffix(values: list[float]) -> list[float]:
    """Sᵀ·x: out_i = Σ_{a ≥ i} x_a."""
    out, acc = [0.0] * len(values), 0.0
    for a in range(len(values) - 1, -1, -1):
        acc += values[a]
        out[a] = acc
    return out


class Chain:
    """The equations of the module notes for one arm.

    Parameters
    ----------
    links : sequence of (float, float)
        Each link's vector at zero, m.
    masses, inertias : sequence of float
        Per link: kg, and kg·m² about its centre of mass (axis normal to the plane).
    com : sequence of (float, float)
        Per link: the centre of mass at zero from its joint, m.
    payload : float
        Point mass at the tool point, kg.
    gravity : (float, float)
        Gravity in the plane, m/s².
    sign : {1, -1}
        σ: +1 counter-clockwise positive joint angles, −1 clockwise.
    yaw_inertia : float, optional
        With a base yaw: the yaw body's inertia about the vertical axis, kg·m² (the joint
        vector then starts with the yaw).
    origin : (float, float)
        Where the first joint sits in the plane (e.g. (0, shoulder height)); only
        positions and the potential energy use it.
    inertias_r, inertias_z : sequence of float, optional
        With a base yaw: per link its moments at the centre of mass about the radial and
        the vertical axis at zero, kg·m² (default 0: only its point mass turns with the
        yaw).
    """

    def __init__(self, links: Sequence[Vec], masses: Sequence[float], com: Sequence[Vec],
                 inertias: Sequence[float], payload: float, gravity: Vec, sign: int = 1,
                 yaw_inertia: float | None = None, origin: Vec = (0.0, 0.0),
                 inertias_r: Sequence[float] | None = None,
                 inertias_z: Sequence[float] | None = None) -> None:
        n = len(links)
        self.n = n
        self.sign = sign
        self.yaw_inertia = yaw_inertia
        self.inertias = [float(x) for x in inertias]
        self.inertias_r = [0.0] * n if inertias_r is None else [float(x) for x in inertias_r]
        self.inertias_z = [0.0] * n if inertias_z is None else [float(x) for x in inertias_z]
        if len(self.inertias_r) != n or len(self.inertias_z) != n:
            raise ValueError(f"inertias_r and inertias_z need {n} values (one per link)")
        self.origin = complex(*origin)
        w = [complex(*v) for v in links]
        bodies = [(float(masses[b]), [w[s] if s < b else (complex(*com[b]) if s == b else 0j)
                                      for s in range(n)]) for b in range(n)]
        if payload > 0:
            bodies.append((float(payload), list(w)))
        self.bodies = bodies
        self._h = [[sum(m * lv[s] * lv[r].conjugate() for m, lv in bodies) for r in range(n)]
                   for s in range(n)]
        self._f = [sum((m * lv[s] for m, lv in bodies), 0j) for s in range(n)]
        self._g = complex(*gravity)

    @property
    def dof(self) -> int:
        return self.n + (self.yaw_inertia is not None)

    def _split(self, q: Sequence[float]) -> tuple[float, list[float]]:
        if self.yaw_inertia is None:
            return 0.0, list(q)
        return q[0], list(q[1:])

    def _phases(self, qc: Sequence[float]) -> list[complex]:
        out, acc = [], 0.0
        for qi in qc:
            acc += qi
            phi = self.sign * acc
            out.append(complex(math.cos(phi), math.sin(phi)))
        return out

    def plane_positions(self, q: Sequence[float]) -> list[complex]:
        """Each body's position in the chain's plane (r + i·z), m."""
        e = self._phases(self._split(q)[1])
        return [self.origin + sum((lv[s] * e[s] for s in range(self.n)), 0j)
                for _, lv in self.bodies]

    def dynamics(self, q: Sequence[float], qd: Sequence[float]
                 ) -> tuple[list[list[float]], list[float]]:
        """(M(q), b(q, q̇)) in joint coordinates (yaw first if any; module equations)."""
        n, sg = self.n, self.sign
        _, qc = self._split(q)
        wy, qdc = self._split(qd)
        e = self._phases(qc)
        phid = [sg * x for x in itertools.accumulate(qdc)]
        h = self._h
        d = [[0.0] * n for _ in range(n)]
        bias_phi = [0.0] * n
        gbar = self._g.conjugate()
        for a in range(n):
            row = d[a]
            cor = 0.0
            for b in range(n):
                z = h[a][b] * e[a] * e[b].conjugate()
                row[b] = z.real
                cor += z.imag * phid[b] * phid[b]
            row[a] += self.inertias[a]
            bias_phi[a] = cor - (gbar * 1j * self._f[a] * e[a]).real
        m = _suffix_matrix(d, n)
        bias = [sg * x for x in _suffix(bias_phi)]
        if self.yaw_inertia is None:
            return m, bias
        inertia = self.yaw_inertia
        d_phi = [0.0] * n
        for mass, lv in self.bodies:
            terms = [lv[s] * e[s] for s in range(n)]
            r = 0.0
            for t in terms:
                r += t.real
            inertia += mass * r * r
            for s in range(n):
                d_phi[s] -= 2.0 * mass * r * terms[s].imag
        for s in range(n):
            ir, iz = self.inertias_r[s], self.inertias_z[s]
            if ir or iz:
                cos, sin = e[s].real, e[s].imag
                inertia += ir * sin * sin + iz * cos * cos
                d_phi[s] += 2.0 * (ir - iz) * sin * cos
        d_q = [sg * x for x in _suffix(d_phi)]
        full = [[inertia] + [0.0] * n] + [[0.0, *row] for row in m]
        yaw_bias = sum(dq * v for dq, v in zip(d_q, qdc, strict=True)) * wy
        return full, [yaw_bias] + [b - 0.5 * dq * wy * wy for b, dq in zip(bias, d_q,
                                                                           strict=True)]

    def energy(self, q: Sequence[float], qd: Sequence[float]) -> float:
        """Kinetic plus potential energy, J (for conservation checks)."""
        m, _ = self.dynamics(q, [0.0] * self.dof)
        dof = self.dof
        kinetic = 0.5 * sum(qd[i] * m[i][j] * qd[j] for i in range(dof) for j in range(dof))
        gbar = self._g.conjugate()
        potential = -sum(mass * (gbar * p).real for (mass, _), p
                         in zip(self.bodies, self.plane_positions(q), strict=True))
        return kinetic + potential
