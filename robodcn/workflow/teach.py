"""Teach by hand: with torque off, each confirmation records the present pose as a waypoint.

The pose is the FK of the present joints through the arm's calibration
(:func:`robodcn.workflow.poses.tool_poses`): x, y, θ on a planar arm, x, y, z, pitch on an
arm with a base yaw. A :class:`Teaching` session records and undoes poses on an open bus
(a surface drives the dialogue: ``robodcn teach``); :func:`waypoints_toml` writes the
waypoints file that :func:`robodcn.workflow.files.load_waypoints` reads back
(``robodcn run poses.toml``).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn.bus import ServoBus
from robodcn.config import PLANAR_POSE, Arm
from robodcn.workflow.admin import present_state
from robodcn.workflow.poses import file_key, pose_table

log = logging.getLogger(__name__)


class Teaching:
    """Poses taught by hand on an open ``bus``: torque goes off when the session starts."""

    def __init__(self, bus: ServoBus, arm: Arm) -> None:
        self.bus = bus
        self.arm = arm
        self._poses: list[NDArray[np.float64]] = []
        bus.torque(False)

    def record(self) -> NDArray[np.float64]:
        """Record the present pose (the arm's pose keys: x, y, θ or x, y, z, pitch) as the
        next waypoint and return it."""
        pose = present_state(self.bus, self.arm).pose
        self._poses.append(pose)
        log.info("waypoint %d: %s", len(self._poses) - 1, pose)
        return pose

    def undo(self) -> bool:
        """Drop the last waypoint; False when there was none."""
        if not self._poses:
            return False
        self._poses.pop()
        return True

    @property
    def poses(self) -> NDArray[np.float64]:
        """The waypoints recorded so far, (m, len(arm.pose_keys)): metres and radians."""
        return np.array(self._poses, dtype=np.float64).reshape(-1, len(self.arm.pose_keys))

    def __len__(self) -> int:
        return len(self._poses)


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def waypoints_toml(poses: Sequence[Sequence[float]], *, arm_name: str,
                   method: str | Sequence[str] | None = None,
                   beta: float | Sequence[float] | None = None,
                   turn: str | Sequence[str] | None = None,
                   keys: Sequence[str] = PLANAR_POSE,
                   extras: Sequence[Mapping[str, Any]] | None = None) -> str:
    """The waypoints file for ``poses`` (metres, radians; the angles written in degrees:
    ``theta_deg``, ``pitch_deg``), one row of ``keys`` each (x, y, θ, or a yawed arm's x, y,
    z, pitch).

    ``method``, ``turn`` and ``beta`` are one value for the whole plan (``[plan]``) or one
    per segment (written on the waypoint each segment leads to). ``extras`` holds per
    waypoint further keys to write on it (``gripper = "close"``, ``payload_kg``).
    """
    keys = tuple(keys)
    units = ", ".join(file_key(k) for k in keys)
    lines = [f"# robodcn waypoints taught on arm {arm_name!r}: {units} (metres, degrees).",
             "# [plan] holds plan options for every segment; a waypoint may carry method, turn",
             "# and beta for the segment that leads to it. Run with: robodcn run FILE",
             f"arm = {_toml_string(arm_name)}", "", "[plan]"]
    per_segment: dict[str, list[str]] = {}
    for key, value in (("method", method), ("turn", turn)):
        if isinstance(value, str):
            lines.append(f"{key} = {_toml_string(value)}")
        elif value is not None:
            per_segment[key] = [_toml_string(v) for v in value]
    if isinstance(beta, int | float):
        lines.append(f"beta = {float(beta)!r}")
    elif beta is not None:
        per_segment["beta"] = [repr(float(b)) for b in beta]
    rows = np.asarray(poses, dtype=np.float64).reshape(-1, len(keys))
    for i, pose in enumerate(rows):
        lines += ["", "[[waypoints]]"]
        lines += [f"{key} = {value!r}" for key, value in pose_table(keys, pose).items()]
        for key, values in per_segment.items():
            if i >= 1 and i - 1 < len(values):
                lines.append(f"{key} = {values[i - 1]}")
        for key, value in (extras[i] if extras is not None and i < len(extras) else {}).items():
            lines.append(f"{key} = {_toml_value(value)}")
    return "\n".join(lines) + "\n"


def _toml_value(value: Any) -> str:
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(float(value)) if isinstance(value, float) else repr(value)
