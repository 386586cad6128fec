"""An arm's tool pose as the surfaces show it: FK of joint angles for a planar or a yawed
arm, the pose's keys and units, and a pose as a waypoint-file table.

A planar arm's pose is (x, y, θ) (:func:`robodcn.kinematics.fk`); a yawed arm's (x, y, z,
pitch) in its base frame (:func:`robodcn.kinematics.fk_yawed`): metres and radians inside,
degrees for the user (``theta_deg``, ``pitch_deg`` in files). The keys are the arm's
``pose_keys`` (:data:`robodcn.config.PLANAR_POSE`, :data:`robodcn.config.YAWED_POSE`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import kinematics
from robodcn.config import PLANAR_POSE, YAWED_POSE, Arm

#: The pose keys that are angles (radians inside, degrees for the user).
ANGLE_KEYS = frozenset({"theta", "pitch"})
#: How a pose key is shown: the symbol in text and tables.
SYMBOLS = {"x": "x", "y": "y", "z": "z", "theta": "θ", "pitch": "pitch"}


def tool_poses(arm: Arm, joints: ArrayLike) -> NDArray[np.float64]:
    """Tool poses (n, len(arm.pose_keys)) of joint angles (n, k) rad: (x, y, θ) of a planar
    arm, (x, y, z, pitch) of a yawed one (m, rad)."""
    q = np.asarray(joints, dtype=np.float64).reshape(-1, arm.dof)
    if arm.yawed:
        return kinematics.fk_yawed(arm.chain, q)
    return kinematics.fk(arm.links, q)


def tool_pose(arm: Arm, joints: ArrayLike) -> NDArray[np.float64]:
    """:func:`tool_poses` of one joint vector (k,): the pose (3,) or (4,)."""
    return tool_poses(arm, np.asarray(joints, dtype=np.float64)[None, :])[0]


def keys_of_width(width: int) -> tuple[str, ...]:
    """The pose keys of a pose row of ``width`` numbers (4: a yawed arm's, else planar)."""
    return YAWED_POSE if width == 4 else PLANAR_POSE


def file_key(key: str) -> str:
    """A pose key as a waypoints file writes it: angles in degrees (``theta_deg``)."""
    return f"{key}_deg" if key in ANGLE_KEYS else key


def pose_table(keys: Sequence[str], pose: ArrayLike, *, digits: int = 6,
               angle_digits: int = 4) -> dict[str, float]:
    """A pose (m, rad) as a waypoints file's keys: ``x``, ``y`` (``z``) in metres rounded
    to ``digits``, ``theta_deg`` / ``pitch_deg`` in degrees rounded to ``angle_digits``."""
    out: dict[str, float] = {}
    for key, value in zip(keys, np.asarray(pose, dtype=np.float64).tolist(), strict=True):
        if key in ANGLE_KEYS:
            out[file_key(key)] = round(math.degrees(value), angle_digits)
        else:
            out[key] = round(value, digits)
    return out


__all__ = ["ANGLE_KEYS", "SYMBOLS", "file_key", "keys_of_width", "pose_table", "tool_pose",
           "tool_poses"]
