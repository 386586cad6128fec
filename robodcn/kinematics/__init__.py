"""Arm kinematics: planar serial chains and a base yaw turning a chain in a vertical plane.

Two arm kinds, one module each:

- :mod:`robodcn.kinematics._planar` — a planar 2R/3R arm in the (x, y) plane, CCW joint
  angles, poses (x, y, θ): :func:`ik`, :func:`ik_path` …; its FK in
  :mod:`robodcn.kinematics._forward` (:func:`fk`), its Jacobian and singularity measures in
  :mod:`robodcn.kinematics._jacobian` (:func:`jacobian` …)
- :mod:`robodcn.kinematics._yawed` — a base yaw turning a planar chain of offset links in a
  vertical plane (the OpenMANIPULATOR-X), servo angles with ROBOTIS's conventions, poses
  (x, y, z, pitch): :class:`Chain`, :func:`fk_yawed`, :func:`ik_yawed`, :func:`to_plane` …

Every function takes arrays of shape (n, ...) and never loops over samples in Python.
"""

from robodcn.kinematics._forward import fk, fk_unchecked
from robodcn.kinematics._jacobian import jacobian, manipulability, near_singular
from robodcn.kinematics._planar import (
    ELBOWS,
    REACH_TOLERANCE,
    SINGULAR_TOLERANCE,
    choose_branches,
    ik,
    ik_branches,
    ik_path,
    ik_path_unchecked,
    ik_paths_unchecked,
    reachable,
    try_ik_path,
    workspace,
    wrap,
    wrist_points,
    wrist_radius,
)
from robodcn.kinematics._points import planar_points, yawed_points
from robodcn.kinematics._yawed import (
    AXIS_TOLERANCE,
    MAX_PITCH,
    Chain,
    fk_yawed,
    from_plane,
    ik_yawed,
    ik_yawed_branches,
    ik_yawed_path,
    plane_fk,
    reachable_yawed,
    to_plane,
    try_ik_yawed_path,
    unreachable_error,
    unwrap_yaw,
    why_unreachable,
    wrist_radius_yawed,
)

__all__ = [
    "AXIS_TOLERANCE",
    "ELBOWS",
    "MAX_PITCH",
    "REACH_TOLERANCE",
    "SINGULAR_TOLERANCE",
    "Chain",
    "choose_branches",
    "fk",
    "fk_unchecked",
    "fk_yawed",
    "from_plane",
    "ik",
    "ik_branches",
    "ik_path",
    "ik_path_unchecked",
    "ik_paths_unchecked",
    "ik_yawed",
    "ik_yawed_branches",
    "ik_yawed_path",
    "jacobian",
    "manipulability",
    "near_singular",
    "planar_points",
    "plane_fk",
    "reachable",
    "reachable_yawed",
    "to_plane",
    "try_ik_path",
    "try_ik_yawed_path",
    "unreachable_error",
    "unwrap_yaw",
    "why_unreachable",
    "workspace",
    "wrap",
    "wrist_points",
    "wrist_radius",
    "wrist_radius_yawed",
    "yawed_points",
]
