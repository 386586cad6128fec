"""Inverse dynamics of a :class:`RigidChain`: the recursive Newton–Euler algorithm in 3-D.

Vectorised over n samples (arrays (n, 3) per body; the loops run over the chain's links only).
All vectors are in the base frame (x forward at yaw 0, z up). With ψ the yaw angle,
e_r = (cos ψ, sin ψ, 0), e_n = (−sin ψ, cos ψ, 0) and e_z the yawed frame's axes, a plane
vector (r, z) is r·e_r + z·e_z; every chain joint turns about u = −σ·e_n (σ = +1 for
``sense="ccw"``, −1 for "cw": about the base's +y axis at yaw 0, ROBOTIS's convention), and
link j's absolute plane angle is θ_j = σ·Q_j with Q_j = q₁ + … + q_j.

Forward pass (velocities and accelerations; Lynch & Park, *Modern Robotics* §8.3.2, or
Featherstone, *Rigid Body Dynamics Algorithms* §5.3, written with 3-vectors)::

    ω₀ = ψ̇·e_z,  α₀ = ψ̈·e_z
    ω_j = ψ̇·e_z + Q̇_j·u,   α_j = ψ̈·e_z + Q̈_j·u + Q̇_j·(ω₀ × u)
    o₁ = shoulder,  o_{j+1} = o_j + d_j          (d_j: link j's vector turned by θ_j)
    a(p) = a(o_j) + α_j × (p − o_j) + ω_j × (ω_j × (p − o_j))   for a point p of body j

Backward pass (forces on body j from its parent: f_j, moment about its joint n_j)::

    F_j = m_j·(a(c_j) − g)
    f_j = F_j + f_{j+1},     f_{k+1} = m_p·(a(tool) − g)    (the payload point mass)
    n_j = I_j·α_j + ω_j × I_j·ω_j + (c_j − o_j) × F_j + n_{j+1} + d_j × f_{j+1}
    τ_j = u·n_j + J_j·q̈_j            (J_j: the joint's armature, reflected rotor inertia)
    τ_yaw = e_z·(I₀_zz·α₀ + c₀ × F₀ + n₁ + o₁ × f₁) + J₀·ψ̈

I_j = Σ_a I_a·a·aᵀ over link j's principal axes a ∈ {e_r', e_n, e_z'} (its r and z axes
turned by θ_j). Friction is not counted. Rotor gyroscopic terms are neglected (as MuJoCo's
``armature`` does).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn.dynamics._chain import RigidChain
from robodcn.errors import InputError

Array = NDArray[np.float64]


def joint_array(chain: RigidChain, name: str, value: ArrayLike) -> tuple[Array, bool]:
    """``value`` as a finite (n, dof) array and whether it was given as one sample (dof,)."""
    array = _checks.finite(name, value)
    single = array.ndim == 1
    if single:
        array = array[None, :]
    if array.ndim != 2 or array.shape[1] != chain.dof:
        raise InputError(f"{name} must have shape (n, {chain.dof}) (one column per joint, "
                         f"yaw first), got {array.shape}", field=name, value=value)
    return array, single


def payload_mass(value: object) -> float:
    """A payload mass in kg: a finite real ≥ 0."""
    if not _checks.is_finite_real(value) or float(value) < 0.0:  # type: ignore[arg-type]
        raise InputError(f"payload_kg must be a finite number ≥ 0, got "
                         f"{_checks.show(value)}", field="payload_kg", value=value)
    return float(value)  # type: ignore[arg-type]


@dataclass(frozen=True)
class _Body:
    """One link's motion at n samples (all (n, 3) except the (n,) velocities)."""

    origin: Array      # o_j, its joint
    vector: Array      # d_j, joint → next joint
    com: Array         # c_j − o_j
    omega: Array
    alpha: Array
    axes: tuple[Array, Array, Array]   # principal axes (e_r', e_n, e_z')
    com_velocity: Array
    com_acceleration: Array


@dataclass(frozen=True)
class _Motion:
    """The forward pass: yaw frame, bodies, tool point."""

    e_r: Array
    e_z: Array
    u: Array
    omega0: Array
    alpha0: Array
    yaw_com: Array
    yaw_com_velocity: Array
    yaw_com_acceleration: Array
    bodies: tuple[_Body, ...]
    tool: Array
    tool_velocity: Array
    tool_acceleration: Array


def _split(chain: RigidChain, q: Array) -> tuple[Array, Array]:
    """(yaw column (n,), chain columns (n, k)); the yaw is 0 without a yaw joint."""
    if chain.yaw is None:
        return np.zeros(q.shape[0]), q
    return q[:, 0], q[:, 1:]


def _cross(a: Array, b: Array) -> Array:
    """a × b row by row for (n, 3) arrays (np.cross's general path is slow on small n)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=1)


def _point(origin_v: Array, origin_a: Array, omega: Array, alpha: Array, arm: Array
           ) -> tuple[Array, Array]:
    """Velocity and acceleration of a point at ``arm`` from a body point (rigid motion)."""
    w_arm = _cross(omega, arm)
    return origin_v + w_arm, origin_a + _cross(alpha, arm) + _cross(omega, w_arm)


def forward(chain: RigidChain, q: Array, qd: Array, qdd: Array) -> _Motion:
    """The forward pass of the module docstring at n samples (validated (n, dof) arrays)."""
    n = q.shape[0]
    psi, qc = _split(chain, q)
    psid, qcd = _split(chain, qd)
    psidd, qcdd = _split(chain, qdd)
    c, s = np.cos(psi), np.sin(psi)
    zeros = np.zeros(n)
    e_r = np.stack([c, s, zeros], axis=1)
    e_n = np.stack([-s, c, zeros], axis=1)
    e_z = np.zeros((n, 3))
    e_z[:, 2] = 1.0
    sign = chain.sign
    u = -sign * e_n
    omega0 = psid[:, None] * e_z
    alpha0 = psidd[:, None] * e_z
    w0_u = _cross(omega0, u)

    def plane(vec: tuple[float, float], er: Array, ez: Array) -> Array:
        return vec[0] * er + vec[1] * ez

    zero3 = np.zeros((n, 3))
    yaw_com = plane(chain.yaw.com if chain.yaw is not None else (0.0, 0.0), e_r, e_z)
    yaw_v, yaw_a = _point(zero3, zero3, omega0, alpha0, yaw_com)
    origin = plane(chain.shoulder, e_r, e_z)
    v_o, a_o = _point(zero3, zero3, omega0, alpha0, origin)

    theta = sign * np.cumsum(qc, axis=1)
    big_qd = np.cumsum(qcd, axis=1)
    big_qdd = np.cumsum(qcdd, axis=1)
    bodies = []
    for j, link in enumerate(chain.links):
        ct, st = np.cos(theta[:, j])[:, None], np.sin(theta[:, j])[:, None]
        er_j = ct * e_r + st * e_z
        ez_j = -st * e_r + ct * e_z
        omega = omega0 + big_qd[:, j, None] * u
        alpha = alpha0 + big_qdd[:, j, None] * u + big_qd[:, j, None] * w0_u
        vector = plane(link.vector, er_j, ez_j)
        com = plane(link.com, er_j, ez_j)
        com_v, com_a = _point(v_o, a_o, omega, alpha, com)
        bodies.append(_Body(origin, vector, com, omega, alpha, (er_j, -e_n, ez_j),
                            com_v, com_a))
        v_o, a_o = _point(v_o, a_o, omega, alpha, vector)
        origin = origin + vector
    return _Motion(e_r, e_z, u, omega0, alpha0, yaw_com, yaw_v, yaw_a, tuple(bodies),
                   origin, v_o, a_o)


def _inertia_times(principal: tuple[float, float, float],
                   axes: tuple[Array, Array, Array], vec: Array) -> Array:
    """I·vec with I = Σ_a I_a·a·aᵀ (principal moments along unit axes)."""
    out = np.zeros_like(vec)
    for moment, axis in zip(principal, axes, strict=True):
        if moment:
            out += moment * np.einsum("ni,ni->n", axis, vec)[:, None] * axis
    return out


def gravity_vector(chain: RigidChain, motion: _Motion) -> Array:
    """g in the base frame, (n, 3): g_r·e_r + g_z·e_z."""
    g_r, g_z = chain.gravity
    return g_r * motion.e_r + g_z * motion.e_z


def rnea(chain: RigidChain, q: Array, qd: Array, qdd: Array, payload: float,
         with_gravity: bool = True) -> Array:
    """τ (n, dof) of the module's equations on validated arrays; gravity optional."""
    motion = forward(chain, q, qd, qdd)
    g = gravity_vector(chain, motion) if with_gravity else np.zeros_like(motion.tool)
    k = len(chain.links)
    tau = np.empty_like(q)
    offset = chain.dof - k
    f_next = payload * (motion.tool_acceleration - g)
    n_next = np.zeros_like(f_next)
    for j in range(k - 1, -1, -1):
        link, body = chain.links[j], motion.bodies[j]
        force = link.mass * (body.com_acceleration - g)
        i_omega = _inertia_times(link.principal, body.axes, body.omega)
        moment = (_inertia_times(link.principal, body.axes, body.alpha)
                  + _cross(body.omega, i_omega) + _cross(body.com, force)
                  + n_next + _cross(body.vector, f_next))
        f_next = force + f_next
        n_next = moment
        tau[:, offset + j] = (np.einsum("ni,ni->n", motion.u, moment)
                              + link.armature * qdd[:, offset + j])
    if chain.yaw is not None:
        yaw = chain.yaw
        force = yaw.mass * (motion.yaw_com_acceleration - g)
        moment = (yaw.inertia_z * motion.alpha0 + _cross(motion.yaw_com, force) + n_next
                  + _cross(motion.bodies[0].origin, f_next))
        tau[:, 0] = moment[:, 2] + yaw.armature * qdd[:, 0]
    return tau


def energy(chain: RigidChain, q: Array, qd: Array, payload: float) -> tuple[Array, Array]:
    """Kinetic and potential energy (n,), (n,) of validated (n, dof) q, q̇ (rotors included).

    T = Σ_b ½·m_b·|v(c_b)|² + ½·ω_bᵀ·I_b·ω_b + ½·m_p·|v(tool)|² + Σ_j ½·J_j·q̇_j²,
    V = −Σ_b m_b·g·c_b − m_p·g·tool.
    """
    motion = forward(chain, q, qd, np.zeros_like(q))
    g = gravity_vector(chain, motion)

    def dot(a: Array, b: Array) -> Array:
        return np.einsum("ni,ni->n", a, b)

    kinetic = 0.5 * payload * dot(motion.tool_velocity, motion.tool_velocity)
    potential = -payload * dot(g, motion.tool)
    kinetic = kinetic + 0.5 * (qd * qd) @ np.asarray(chain.armature)
    for link, body in zip(chain.links, motion.bodies, strict=True):
        kinetic = kinetic + 0.5 * link.mass * dot(body.com_velocity, body.com_velocity)
        kinetic = kinetic + 0.5 * dot(body.omega,
                                      _inertia_times(link.principal, body.axes, body.omega))
        potential = potential - link.mass * dot(g, body.origin + body.com)
    if chain.yaw is not None:
        yaw = chain.yaw
        kinetic = kinetic + 0.5 * yaw.mass * dot(motion.yaw_com_velocity,
                                                 motion.yaw_com_velocity)
        kinetic = kinetic + 0.5 * yaw.inertia_z * qd[:, 0] ** 2
        potential = potential - yaw.mass * dot(g, motion.yaw_com)
    return kinetic, potential
