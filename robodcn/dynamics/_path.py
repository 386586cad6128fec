"""Torque along a joint path q(s): the coefficients TOPP-RA's torque constraint needs.

With q̇ = q'·ṡ and q̈ = q'·s̈ + q''·ṡ² (q' = dq/ds, q'' = d²q/ds²), the inverse dynamics
τ = M(q)·q̈ + C(q, q̇)·q̇ + g(q) is linear in (s̈, ṡ²) (Pham & Pham, "A new approach to
time-optimal path parameterization based on reachability analysis", IEEE T-RO 2018, §III)::

    τ = a(s)·s̈ + b(s)·ṡ² + c(s),
    a = M(q)·q',   b = M(q)·q'' + C(q, q')·q',   c = g(q)

since C(q, q̇)·q̇ is quadratic in q̇. Each is one Newton–Euler pass: a = τ(q, 0, q') and
b = τ(q, q', q'') without gravity, c = τ(q, 0, 0) with it (armature included in a and b).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.dynamics._chain import RigidChain
from robodcn.dynamics._rnea import joint_array, payload_mass, rnea
from robodcn.errors import InputError

Array = NDArray[np.float64]


def path_torque_coefficients(chain: RigidChain, q: ArrayLike, q_s: ArrayLike,
                             q_ss: ArrayLike, payload_kg: float = 0.0
                             ) -> tuple[Array, Array, Array]:
    """(a, b, c), each (n, dof), with τ = a·s̈ + b·ṡ² + c along the path (module docstring).

    Parameters
    ----------
    chain : RigidChain
    q, q_s, q_ss : array_like (n, dof)
        The path's joint angles and their first and second derivatives in s, yaw first.
    payload_kg : float
        Point mass at the tool point, kg.
    """
    q_arr, single = joint_array(chain, "q", q)
    qs_arr, _ = joint_array(chain, "q_s", q_s)
    qss_arr, _ = joint_array(chain, "q_ss", q_ss)
    for name, array in (("q_s", qs_arr), ("q_ss", qss_arr)):
        if array.shape != q_arr.shape:
            raise InputError(f"{name} must have the shape of q {q_arr.shape}, got "
                             f"{array.shape}", field=name, value=array)
    payload = payload_mass(payload_kg)
    zero = np.zeros_like(q_arr)
    a = rnea(chain, q_arr, zero, qs_arr, payload, with_gravity=False)
    b = rnea(chain, q_arr, qs_arr, qss_arr, payload, with_gravity=False)
    c = rnea(chain, q_arr, zero, zero, payload)
    if single:
        return a[0], b[0], c[0]
    return a, b, c


__all__ = ["path_torque_coefficients"]
