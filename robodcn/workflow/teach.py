"""Teach by hand: with torque off, each confirmation records the present pose as a waypoint.

The pose is the FK of the present joints (robodcn.kinematics.fk of the servo ticks through
the arm's calibration). A :class:`Teaching` session records and undoes poses on an open bus
(a surface drives the dialogue: ``robodcn teach``); :func:`waypoints_toml` writes the
waypoints file that :func:`robodcn.workflow.files.load_waypoints` reads back
(``robodcn run poses.toml``).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from robodcn.bus import ServoBus
from robodcn.config import Arm
from robodcn.workflow.admin import present_state

log = logging.getLogger(__name__)


class Teaching:
    """Poses taught by hand on an open ``bus``: torque goes off when the session starts."""

    def __init__(self, bus: ServoBus, arm: Arm) -> None:
        self.bus = bus
        self.arm = arm
        self._poses: list[NDArray[np.float64]] = []
        bus.torque(False)

    def record(self) -> NDArray[np.float64]:
        """Record the present pose (x, y, θ) as the next waypoint and return it."""
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
        """The waypoints recorded so far, (m, 3): metres and radians."""
        return np.array(self._poses, dtype=np.float64).reshape(-1, 3)

    def __len__(self) -> int:
        return len(self._poses)


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def waypoints_toml(poses: Sequence[Sequence[float]], *, arm_name: str,
                   method: str | Sequence[str] | None = None,
                   beta: float | Sequence[float] | None = None,
                   turn: str | Sequence[str] | None = None) -> str:
    """The waypoints file for ``poses`` (x, y metres, θ radians; written as ``theta_deg``).

    ``method``, ``turn`` and ``beta`` are one value for the whole plan (``[plan]``) or one
    per segment (written on the waypoint each segment leads to).
    """
    lines = [f"# robodcn waypoints taught on arm {arm_name!r}: x, y in metres, theta_deg in "
             "degrees.",
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
    for i, (x, y, theta) in enumerate(np.asarray(poses, dtype=np.float64).reshape(-1, 3)):
        lines += ["", "[[waypoints]]", f"x = {round(float(x), 6)!r}", f"y = {round(float(y), 6)!r}",
                  f"theta_deg = {round(math.degrees(float(theta)), 4)!r}"]
        for key, values in per_segment.items():
            if i >= 1 and i - 1 < len(values):
                lines.append(f"{key} = {values[i - 1]}")
    return "\n".join(lines) + "\n"
