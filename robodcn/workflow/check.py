"""``check-config``: validate an arm file and summarise it in the user's units (degrees).

:func:`summary` is data (a dict, SI; ``robodcn check-config`` renders it,
:func:`robodcn.cli.config_cmd.summary_text`);
:func:`workspace_samples` gives the tool points reachable inside the joint limits for
:func:`robodcn.plots.plot_workspace`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn import kinematics, servo_units
from robodcn.config import Arm


def summary(arm: Arm) -> dict[str, Any]:
    """Links, reach, per joint the angle and tick ranges, servo map and bus of ``arm`` (SI)."""
    inner, outer = kinematics.workspace(arm.links)
    joints = []
    for j in arm.joints:
        s = j.servo
        # The joint angles the tick range allows (direction may swap the ends).
        ends = servo_units.ticks_to_radians(np.array([[s.min_tick], [s.max_tick]]), [s])[:, 0]
        joints.append({
            "name": j.name, "min": j.min_angle, "max": j.max_angle,
            "max_velocity": j.max_velocity, "max_acceleration": j.max_acceleration,
            "servo": {"id": s.id, "model": s.model, "ticks_per_turn": s.ticks_per_turn,
                      "zero_offset": s.zero_offset, "direction": s.direction,
                      "min_tick": s.min_tick, "max_tick": s.max_tick},
            "tick_range_angles": [float(ends.min()), float(ends.max())],
            "limits_inside_ticks": bool(ends.min() <= j.min_angle and j.max_angle <= ends.max()),
        })
    return {"name": arm.name, "source": arm.source, "dof": arm.dof,
            "full_pose": arm.dof == 3, "links": list(arm.links),
            "reach": {"wrist_inner": inner, "wrist_outer": outer,
                      "tool_max": float(sum(arm.links))},
            "elbow": arm.elbow, "home": list(arm.home), "joints": joints,
            "bus": {"port": arm.bus.port, "baud": arm.bus.baud, "protocol": arm.bus.protocol,
                    "rate_hz": arm.bus.rate_hz}}


def workspace_samples(arm: Arm, per_joint: int = 41) -> NDArray[np.float64]:
    """Tool poses (n, 3) of a grid over the joint limits, ``per_joint`` values a joint.

    The reachable workspace inside the joint limits (not just the annulus): FK of every
    combination, vectorised.
    """
    axes = [np.linspace(j.min_angle, j.max_angle, per_joint) for j in arm.joints]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, arm.dof)
    return kinematics.fk(arm.links, grid)
