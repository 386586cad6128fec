"""Saved trajectories: a Trajectory JSON (``plan --format json``), which kind of file a
path is, and a parsed JSON value that is either kind of trajectory."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from robodcn import servo_units
from robodcn.config import Arm
from robodcn.errors import InputError
from robodcn.planner import Trajectory
from robodcn.workflow.files._common import fail, read
from robodcn.workflow.files._joint import joint_trajectory
from robodcn.workflow.files._samples import check_joint_samples


def load_trajectory(path: str | Path, arm: Arm, *, text: str | None = None) -> Trajectory:
    """A saved Trajectory JSON for ``arm``: same joints and servos, ticks as this arm's
    calibration gives them, every sample inside the arm's limits."""
    source = str(path)
    text = read(path) if text is None else text
    try:
        traj = Trajectory.from_json(text, arm)
    except InputError as exc:
        raise InputError(f"{source}: {exc.message}", field=exc.field, value=exc.value) from exc
    if tuple(traj.joint_names) != arm.joint_names:
        raise fail(source, "joint_names", f"{list(traj.joint_names)} do not match arm "
                    f"{arm.name!r} {list(arm.joint_names)}", list(traj.joint_names))
    expected = servo_units.radians_to_ticks(traj.joints, arm.servos)
    if not np.array_equal(expected, traj.ticks):
        i, j = (int(v) for v in np.argwhere(expected != traj.ticks)[0])
        raise fail(source, f"ticks[{i}][{j}]", f"is {int(traj.ticks[i, j])}, but joint "
                    f"{arm.joint_names[j]!r} at {math.degrees(traj.joints[i, j]):.3f}° is tick "
                    f"{int(expected[i, j])} with this arm's calibration: plan it again for "
                    "this arm", int(traj.ticks[i, j]))
    check_joint_samples(arm, traj.joints, traj.rate_hz, source=source,
                        point_of_sample=np.arange(len(traj.t)))
    return traj



def file_kind(path: str | Path) -> tuple[str, str | None]:
    """("waypoints" | "trajectory" | "joint_trajectory", the JSON text or None)."""
    source = str(path)
    if Path(path).suffix.lower() == ".toml":
        return "waypoints", None
    text = read(path)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{source}: neither a waypoints .toml nor valid JSON: {exc}",
                         field="file", value=source) from exc
    if isinstance(data, dict) and "points" in data and "joint_names" in data:
        return "joint_trajectory", text
    if isinstance(data, dict) and "ticks" in data and "t" in data:
        return "trajectory", text
    raise InputError(f"{source}: JSON is neither a Trajectory (t, poses, joints, ticks ...) "
                     "nor a JointTrajectory (joint_names, points)", field="file", value=source)



def trajectory_from_data(data: Any, arm: Arm, rate_hz: float, *, source: str = "trajectory"
                         ) -> Trajectory:
    """A parsed JSON value that is a Trajectory (``plan --format json``) or a JointTrajectory,
    checked for ``arm`` — e.g. the ``trajectory`` field of an HTTP move request. ``rate_hz``
    resamples a JointTrajectory; a Trajectory keeps its own rate."""
    if isinstance(data, dict) and "points" in data and "joint_names" in data:
        return joint_trajectory(data, arm, rate_hz, source=source)
    if isinstance(data, dict) and "ticks" in data and "t" in data:
        return load_trajectory(source, arm, text=json.dumps(data))
    raise InputError(f"{source}: must be a Trajectory (t, poses, joints, ticks, ...) or a "
                     "JointTrajectory (joint_names, points)", field=source, value=None)
