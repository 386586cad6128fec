"""Shared arms, waypoints and checks of the planner tests (tests/test_planner_*.py)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np

import robodcn
from robodcn import kinematics, servo_units
from robodcn.config import Arm, arm_from_dict, load_arm
from robodcn.planner import Trajectory, plan

CONFIGS = Path(__file__).resolve().parent.parent / "configs"
ARM3R = load_arm(CONFIGS / "arm3r.toml")
ARM2R = load_arm(CONFIGS / "arm2r.toml")
WAYPOINTS_3R = [[0.25, 0.10, 0.0], [0.15, 0.20, 1.0], [0.0, 0.28, 1.5]]
WAYPOINTS_2R = [[0.18, 0.08, 0.0], [0.10, 0.15, 0.0], [-0.05, 0.2, 0.0]]


def variant(arm: Arm, only: int | None = None, **changes: Any) -> Arm:
    """The arm with every joint's (or servo's, keys 'servo_x') values replaced, or only
    joint ``only``'s."""
    data = arm.to_dict()
    for i, joint in enumerate(data["joints"]):
        if only is not None and i != only:
            continue
        for key, value in changes.items():
            if key.startswith("servo_"):
                joint["servo"][key.removeprefix("servo_")] = value
            else:
                joint[key] = value
    return arm_from_dict(data, source=arm.source)


def with_jerk(arm: Arm, per_accel: float | None) -> Arm:
    """``arm`` with jerk limits per_accel × a per joint (None: no jerk limit)."""
    return dataclasses.replace(arm, joints=tuple(
        dataclasses.replace(j, max_jerk=None if per_accel is None
                            else per_accel * j.max_acceleration) for j in arm.joints))


# the example configs' recommended jerk limits (their commented max_jerk keys: 20 × a), built
# explicitly: the shipped configs leave them off
JERK3R = with_jerk(ARM3R, 20.0)
JERK2R = with_jerk(ARM2R, 20.0)


def unlimited(arm: Arm) -> Arm:
    """The arm with dynamic limits no servo has (built directly: the loader refuses them),
    so that only geometry decides."""
    joints = tuple(dataclasses.replace(j, max_velocity=1e4, max_acceleration=1e7, max_jerk=None)
                   for j in arm.joints)
    return dataclasses.replace(arm, joints=joints)


def check_trajectory(traj: Trajectory, arm: Arm, waypoints: Any, approach: bool = False) -> None:
    """Shapes, timing, FK consistency, ticks, and every limit, checked from the arrays."""
    wp = np.asarray(waypoints, dtype=float)
    n = traj.t.shape[0]
    assert traj.t[0] == 0.0
    np.testing.assert_allclose(np.diff(traj.t), 1.0 / traj.rate_hz, rtol=0, atol=1e-9)
    assert traj.poses.shape == (n, 3) and traj.joints.shape == traj.ticks.shape == (n, arm.dof)
    assert traj.ticks.dtype == np.int64
    assert traj.joint_names == arm.joint_names and traj.servo_ids == arm.servo_ids
    if not approach:
        np.testing.assert_allclose(traj.poses[0, :2], wp[0, :2], atol=1e-12)
    np.testing.assert_allclose(traj.poses[-1, :2], wp[-1, :2], atol=1e-12)
    fk = kinematics.fk(arm.links, traj.joints)
    np.testing.assert_allclose(fk[:, :2], traj.poses[:, :2], atol=1e-9)
    if arm.dof == 3:
        assert np.abs(kinematics.wrap(fk[:, 2] - traj.poses[:, 2])).max() < 1e-9
        assert abs(kinematics.wrap(traj.poses[-1, 2] - wp[-1, 2])) < 1e-12
    np.testing.assert_array_equal(traj.ticks, servo_units.radians_to_ticks(traj.joints,
                                                                           arm.servos))
    lo = np.array([j.min_angle for j in arm.joints])
    hi = np.array([j.max_angle for j in arm.joints])
    assert (traj.joints >= lo).all() and (traj.joints <= hi).all()
    v = np.array([j.max_velocity for j in arm.joints])
    a = np.array([j.max_acceleration for j in arm.joints])
    assert (np.abs(np.diff(traj.joints, axis=0)) * traj.rate_hz <= v * (1 + 1e-9)).all()
    assert (np.abs(np.diff(traj.joints, 2, axis=0)) * traj.rate_hz**2 <= a * (1 + 1e-9)).all()
    # the arm starts from and ends at rest: the first and last steps are accelerations too
    ends = np.abs(traj.joints[[1, -1]] - traj.joints[[0, -2]]) * traj.rate_hz**2
    assert (ends <= a * (1 + 1e-9)).all()



def first_bad_row(bad: np.ndarray) -> int:
    rows = bad.any(axis=1)
    assert rows.any()
    return int(np.argmax(rows))


ISSUE_VIAS = [[0.25, 0.10, 0.0], [0.2, 0.15, math.radians(20)], [0.15, 0.2, math.radians(40)],
              [0.12, 0.24, math.radians(60)], [0.05, 0.25, math.radians(80)]]


def fd_ratio(traj: Trajectory, arm: Arm, history: np.ndarray | None = None) -> float:
    """Worst finite-difference velocity/acceleration/jerk over its limit (rest or history
    before, rest after), computed here from the samples."""
    q = traj.joints
    worst = 0.0
    for order, limit in ((1, [j.max_velocity for j in arm.joints]),
                         (2, [j.max_acceleration for j in arm.joints]),
                         (3, [j.max_jerk or math.inf for j in arm.joints])):
        pre = np.repeat(q[:1], order, axis=0) if history is None else history[-order:]
        p = np.concatenate([pre, q, np.repeat(q[-1:], order, axis=0)])
        d = np.abs(np.diff(p, order, axis=0)) * traj.rate_hz ** order
        worst = max(worst, float((d / np.asarray(limit)).max()))
    return worst




def moving_state(arm: Arm, at: float = 0.4) -> tuple[Trajectory, int, robodcn.StartState]:
    run = plan(arm, ISSUE_VIAS[:1] + ISSUE_VIAS[-1:], rate_hz=1000)
    i = int(at * run.t.shape[0])
    q = run.joints
    state = robodcn.StartState(q[i], (q[i + 1] - q[i - 1]) * 500.0,
                               (q[i + 1] - 2 * q[i] + q[i - 1]) * 1e6)
    return run, i, state


def distance_to_polyline(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Each point's distance to the polyline through ``line``'s rows: to the two segments
    beside its nearest vertex (scipy's KD-tree), clamped to them."""
    from scipy.spatial import cKDTree

    _, nearest = cKDTree(line).query(points)
    best = np.full(len(points), np.inf)
    for lo in (nearest - 1, nearest):
        i = np.clip(lo, 0, len(line) - 2)
        a, ab = line[i], line[i + 1] - line[i]
        t = np.clip(np.einsum("pk,pk->p", points - a, ab)
                    / np.maximum(np.einsum("pk,pk->p", ab, ab), 1e-300), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(points - a - t[:, None] * ab, axis=1))
    return best
