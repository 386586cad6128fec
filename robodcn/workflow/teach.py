"""Teach by hand: with torque off, each confirmation records the present pose as a waypoint.

The pose is the FK of the present joints (robodcn.kinematics.fk of the servo ticks through
the arm's calibration). :func:`teach` drives the dialogue through a ``prompt`` callback
(Enter records, ``u`` undoes the last waypoint, ``q`` or end of input finishes);
:func:`waypoints_toml` writes the waypoints file that :func:`robodcn.workflow.files.load_waypoints`
reads back (``robodcn run poses.toml``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from robodcn.bus import ServoBus
from robodcn.config import Arm
from robodcn.workflow.admin import present_state
from robodcn.workflow.calibrate import Prompt

PROMPT = "Enter: record the present pose, u: undo the last one, q: finish"


def teach(bus: ServoBus, arm: Arm, prompt: Prompt,
          say: Callable[[str], None] = lambda text: None) -> NDArray[np.float64]:
    """Torque off, then record poses until ``q`` or end of input; returns them, (m, 3).

    ``say`` receives one line per event (recorded pose, undo, unknown answer).
    """
    bus.torque(False)
    poses: list[NDArray[np.float64]] = []
    while True:
        try:
            answer = prompt(f"[{len(poses)} recorded] {PROMPT}").strip().lower()
        except EOFError:
            break
        if answer == "":
            pose = present_state(bus, arm).pose
            poses.append(pose)
            say(f"waypoint {len(poses) - 1}: x={pose[0]:.4f} m, y={pose[1]:.4f} m, "
                f"θ={math.degrees(pose[2]):.2f}°")
        elif answer == "u":
            if poses:
                poses.pop()
                say(f"undone; {len(poses)} recorded")
            else:
                say("nothing to undo")
        elif answer == "q":
            break
        else:
            say(f"unknown answer {answer!r}: {PROMPT}")
    return np.array(poses, dtype=np.float64).reshape(-1, 3)


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
