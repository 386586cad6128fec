"""What a move measured, as data: time, present ticks and joint angles per feedback read.

The CLI's progress callback and the HTTP service (:meth:`robodcn.moves.MoveRecord.recording`:
one row per feedback read of the stream) give ``(elapsed s, present ticks)`` pairs;
:func:`recording` turns them into a JSON-ready dict (SI) and :func:`recording_csv` into CSV
whose headers name their units (as ``plan --format csv``), for
``GET /v1/moves/{id}/record`` and for plots.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from typing import Any

import numpy as np

from robodcn import servo_units
from robodcn.config import Arm
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
    """CSV, one row per read; every header names its unit: t_s, q_<joint>_rad,
    tick_<servo id> (ticks), then the pose: x_m, y_m, theta_rad (a yawed arm's x_m, y_m,
    z_m, pitch_rad)."""
    data = recording(arm, samples)
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["t_s", *(f"q_{n}_rad" for n in arm.joint_names),
                     *(f"tick_{i}" for i in arm.servo_ids),
                     *(f"{key}_{'m' if key in 'xyz' else 'rad'}" for key in arm.pose_keys)])
    for t, q, k, p in zip(data["t"], data["joints"], data["ticks"], data["poses"], strict=True):
        writer.writerow([repr(t), *map(repr, q), *k, *map(repr, p)])
    return out.getvalue()
