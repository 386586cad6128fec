"""Public inverse dynamics of a :class:`RigidChain`: τ, holding torque, M(q), energy, tool point.

τ(q, q̇, q̈) = M(q)·q̈ + C(q, q̇)·q̇ + g(q) at the output shafts, by the recursive Newton–Euler
algorithm of :mod:`robodcn.dynamics._rnea` (links, payload point mass at the tool point,
gravity, each joint's armature J_rotor·N²·q̈; no friction). Every function takes (n, dof)
arrays in joint order (yaw first) and never loops over samples; a (dof,) array is one sample
and gives a (dof,) result.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.dynamics._chain import RigidChain
from robodcn.dynamics._rnea import energy, forward, joint_array, payload_mass, rnea
from robodcn.errors import InputError

Array = NDArray[np.float64]


def _same_shape(name: str, array: Array, q: Array) -> None:
    if array.shape != q.shape:
        raise InputError(f"{name} must have the shape of q {q.shape}, got {array.shape}",
                         field=name, value=array)


def _shape(single: bool, out: Array) -> Array:
    return out[0] if single else out


def inverse_dynamics(chain: RigidChain, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike,
                     payload_kg: float = 0.0) -> Array:
    """Joint torques τ (n, dof), N·m, that give the motion (q, q̇, q̈) (module docstring).

    Parameters
    ----------
    chain : RigidChain
    q, qd, qdd : array_like (n, dof)
        Joint angles (rad), velocities (rad/s), accelerations (rad/s²), yaw first.
    payload_kg : float
        A point mass at the tool point, kg.

    Returns
    -------
    ndarray (n, dof)
        τ = M(q)·q̈ + C(q, q̇)·q̇ + g(q), rotor armature included; (dof,) for one sample.
    """
    q_arr, single = joint_array(chain, "q", q)
    qd_arr, _ = joint_array(chain, "qd", qd)
    qdd_arr, _ = joint_array(chain, "qdd", qdd)
    _same_shape("qd", qd_arr, q_arr)
    _same_shape("qdd", qdd_arr, q_arr)
    return _shape(single, rnea(chain, q_arr, qd_arr, qdd_arr, payload_mass(payload_kg)))


def gravity_torque(chain: RigidChain, q: ArrayLike, payload_kg: float = 0.0) -> Array:
    """Holding torque g(q) (n, dof), N·m: τ at rest (q̇ = q̈ = 0) with the payload."""
    q_arr, single = joint_array(chain, "q", q)
    zero = np.zeros_like(q_arr)
    return _shape(single, rnea(chain, q_arr, zero, zero, payload_mass(payload_kg)))


def mass_matrix(chain: RigidChain, q: ArrayLike, payload_kg: float = 0.0) -> Array:
    """Joint-space inertia M(q) (n, dof, dof), kg·m², armature on the diagonal.

    Column i is τ(q, 0, e_i) without gravity (Walker & Orin's method 1).
    """
    q_arr, single = joint_array(chain, "q", q)
    payload = payload_mass(payload_kg)
    n, dof = q_arr.shape
    zero = np.zeros_like(q_arr)
    out = np.empty((n, dof, dof))
    for i in range(dof):
        unit = np.zeros_like(q_arr)
        unit[:, i] = 1.0
        out[:, :, i] = rnea(chain, q_arr, zero, unit, payload, with_gravity=False)
    return _shape(single, out)


def kinetic_potential(chain: RigidChain, q: ArrayLike, qd: ArrayLike,
                      payload_kg: float = 0.0) -> tuple[Array, Array]:
    """Kinetic and potential energy (n,), J, of (q, q̇): bodies, payload, rotors (0-d arrays
    for one sample).

    V is measured from the base origin (V = −Σ m·g·c); d/dt(T + V) = τ·q̇ along any motion.
    """
    q_arr, single = joint_array(chain, "q", q)
    qd_arr, _ = joint_array(chain, "qd", qd)
    _same_shape("qd", qd_arr, q_arr)
    kinetic, potential = energy(chain, q_arr, qd_arr, payload_mass(payload_kg))
    if single:
        return kinetic[0, ...], potential[0, ...]
    return kinetic, potential


def tool_point(chain: RigidChain, q: ArrayLike) -> Array:
    """The tool point (n, 3) in the base frame, m.

    With a yaw joint: (r·cos ψ, r·sin ψ, z). Without one the chain's plane is the (x, z)
    plane: (r, 0, z) — for a horizontal planar arm that is (x, 0, y) of its own plane.
    """
    q_arr, single = joint_array(chain, "q", q)
    zero = np.zeros_like(q_arr)
    return _shape(single, forward(chain, q_arr, zero, zero).tool)


def tool_motion(chain: RigidChain, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike
                ) -> tuple[Array, Array, Array]:
    """The tool point's position, velocity and acceleration (each (n, 3), base frame, m,
    m/s, m/s²) of the motion (q, q̇, q̈): the forward pass of :mod:`._rnea`, ṗ = J q̇ and
    p̈ = J q̈ + J̇ q̇. Along a path q(s) pass (q, q′, q″) to get (p, p′, p″) = (p, dp/ds,
    d²p/ds²): the chain rule is the same."""
    q_arr, single = joint_array(chain, "q", q)
    qd_arr, _ = joint_array(chain, "qd", qd)
    qdd_arr, _ = joint_array(chain, "qdd", qdd)
    motion = forward(chain, q_arr, qd_arr, qdd_arr)
    return (_shape(single, motion.tool), _shape(single, motion.tool_velocity),
            _shape(single, motion.tool_acceleration))


__all__ = ["gravity_torque", "inverse_dynamics", "kinetic_potential", "mass_matrix",
           "tool_motion", "tool_point"]
