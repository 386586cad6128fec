"""Rigid-body inverse dynamics of robodcn's arms: one vectorised τ(q, q̇, q̈) for everything.

A :class:`RigidChain` (plain numbers: an optional base yaw, a planar serial chain in a
vertical — or, for the planar arms, horizontal — plane, masses, centres of mass, inertias,
gravity, each joint's reflected rotor inertia) and the functions that serve the optimal
timing (torque limits: :func:`path_torque_coefficients`), the current prediction and the
tracking compensation (:func:`inverse_dynamics`), the collision threshold and
``check-config --payload`` (:func:`gravity_torque`, :func:`holding_torque_box`).

Method: the recursive Newton–Euler algorithm in 3-D (Featherstone, *Rigid Body Dynamics
Algorithms*, 2008, §5.3; Lynch & Park, *Modern Robotics*, 2017, §8.3), so the yaw joint's
pose-dependent inertia and the yaw-rate × chain coupling terms are those of the full
rigid-body dynamics. Checked in the tests against the energy balance, the existing planar
model and MuJoCo's ``mj_inverse`` on an OpenMANIPULATOR-X model.

Private modules: ``_chain`` (the data), ``_rnea`` (the recursion), ``_inverse`` (τ, g, M,
energy, tool point), ``_path`` (TOPP coefficients), ``_holding`` (the box search).
"""

from robodcn.dynamics._chain import GRAVITY_DOWN, STANDARD_GRAVITY, Link, RigidChain, Sense, Yaw
from robodcn.dynamics._holding import holding_torque_box
from robodcn.dynamics._inverse import (
    gravity_torque,
    inverse_dynamics,
    kinetic_potential,
    mass_matrix,
    tool_motion,
    tool_point,
)
from robodcn.dynamics._path import path_torque_coefficients

__all__ = ["GRAVITY_DOWN", "STANDARD_GRAVITY", "Link", "RigidChain", "Sense", "Yaw",
           "gravity_torque", "holding_torque_box", "inverse_dynamics", "kinetic_potential",
           "mass_matrix", "path_torque_coefficients", "tool_motion", "tool_point"]
