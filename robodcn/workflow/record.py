"""What a move measured, as data: time, present ticks and joint angles per feedback read.

The CLI's progress callback and the HTTP service (:meth:`robodcn.moves.MoveRecord.recording`:
one row per feedback read of the stream) give ``(elapsed s, present ticks)`` pairs;
:func:`recording` turns them into a JSON-ready dict (SI) and :func:`recording_csv` into CSV
whose headers name their units (as ``plan --format csv``), for
``GET /v1/moves/{id}/record`` and for plots.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from robodcn import servo_units
from robodcn.config import Arm
from robodcn.planner.trajectory import csv_rows
from robodcn.workflow.poses import tool_poses


def recording(arm: Arm, samples: Sequence[tuple[float, Sequence[int]]]) -> dict[str, Any]:
    """{"joint_names", "servo_ids", "pose_keys", "t" (s), "ticks", "joints" (rad), "poses"
    (x, y, θ; a yawed arm's x, y, z, pitch: m, rad)}."""
    t = np.array([s[0] for s in samples], dtype=np.float64)
    ticks = np.array([list(s[1]) for s in samples], dtype=np.int64).reshape(-1, arm.dof)
    joints = servo_units.ticks_to_radians(ticks, arm.servos) if len(ticks) else ticks * 0.0
    poses = tool_poses(arm, joints) if len(ticks) else np.zeros((0, len(arm.pose_keys)))
    return {"joint_names": list(arm.joint_names), "servo_ids": list(arm.servo_ids),
            "pose_keys": list(arm.pose_keys),
            "t": t.tolist(), "ticks": ticks.tolist(), "joints": joints.tolist(),
            "poses": poses.tolist()}


def recording_csv(arm: Arm, samples: Sequence[tuple[float, Sequence[int]]]) -> str:
    """CSV, one row per read, in ``plan --format csv``'s columns
    (:func:`robodcn.planner.trajectory.csv_rows`): t_s, the pose, q_<joint>_rad,
    tick_<servo id>."""
    data = recording(arm, samples)
    return csv_rows(arm.pose_keys, arm.joint_names, arm.servo_ids, data["t"], data["poses"],
                    data["joints"], data["ticks"])

