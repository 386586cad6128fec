"""Planned trajectories for both arms: every profile, blended or stopping, fixed durations,
per-segment methods, the interpolation under the profile, continuous velocity at blended
vias."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from planner_helpers import (
    ARM2R,
    ARM3R,
    WAYPOINTS_2R,
    WAYPOINTS_3R,
    check_trajectory,
)

import robodcn
from robodcn import timing
from robodcn.config import Arm
from robodcn.interpolate import interpolate
from robodcn.planner import Trajectory, plan


@pytest.mark.parametrize(("arm", "waypoints"), [(ARM3R, WAYPOINTS_3R), (ARM2R, WAYPOINTS_2R)],
                         ids=["arm3r", "arm2r"])
@pytest.mark.parametrize("profile", timing.PROFILES)
@pytest.mark.parametrize("blend", [False, True])
def test_plans_for_both_arms(arm: Arm, waypoints: Any, profile: str, blend: bool) -> None:
    traj = robodcn.plan(arm, waypoints, profile=profile, blend=blend, rate_hz=200)
    check_trajectory(traj, arm, waypoints)
    assert traj.method == "sclerp" and traj.request.arm is arm


def test_fixed_duration_and_per_segment_methods() -> None:
    traj = plan(ARM3R, WAYPOINTS_3R, profile="quintic", method=["seplerp", "kenlerp"], beta=0.5,
                turn=["shortest", "shortest"], duration=3.0, rate_hz=100)
    check_trajectory(traj, ARM3R, WAYPOINTS_3R)
    assert traj.duration == pytest.approx(3.0)
    assert traj.method == ["seplerp", "kenlerp"]
    # without blend, the arm stops at the via point: a sample sits on it at rest
    at = np.argmin(np.linalg.norm(traj.poses[:, :2] - WAYPOINTS_3R[1][:2], axis=1))
    np.testing.assert_allclose(traj.poses[at], WAYPOINTS_3R[1], atol=1e-12)
    steps = np.abs(np.diff(traj.joints, axis=0)).max(axis=1)
    assert steps[at] < 1e-3 * steps.max() and steps[at - 1] < 1e-3 * steps.max()
    # the first segment is SEP-LERP: a straight line in x, y
    first = traj.poses[: at + 1, :2]
    d = np.subtract(WAYPOINTS_3R[1][:2], WAYPOINTS_3R[0][:2])
    cross = (first[:, 0] - WAYPOINTS_3R[0][0]) * d[1] - (first[:, 1] - WAYPOINTS_3R[0][1]) * d[0]
    assert np.abs(cross).max() < 1e-12


def test_single_segment_matches_interpolate_under_the_profile() -> None:
    traj = plan(ARM3R, WAYPOINTS_3R[:2], method="kenlerp", beta=1.7, duration=1.5,
                profile="trapezoid", rate_hz=100)
    n = traj.t.shape[0] - 1
    poses = traj.poses
    # the profile is a trapezoid with some acceleration fraction: recover s from the
    # interpolation itself (its θ is linear in s) and check the positions agree
    s = (poses[:, 2] - WAYPOINTS_3R[0][2]) / (WAYPOINTS_3R[1][2] - WAYPOINTS_3R[0][2])
    expected = interpolate(WAYPOINTS_3R[0], WAYPOINTS_3R[1], s, method="kenlerp", beta=1.7)
    np.testing.assert_allclose(poses, expected, atol=1e-12)
    assert n == 150
    speed = np.diff(s)
    assert speed.max() == pytest.approx(speed[n // 2], rel=1e-9)  # cruising in the middle


# -- blending -----------------------------------------------------------------------------------

def max_velocity_jump(traj: Trajectory) -> float:
    v = np.diff(traj.poses[:, :2], axis=0) * traj.rate_hz
    return float(np.linalg.norm(np.diff(v, axis=0), axis=1).max())


def test_blended_via_points_have_continuous_velocity() -> None:
    corner = [[0.25, 0.0, 0.0], [0.25, 0.2, 0.5], [0.05, 0.25, 1.0]]
    slow = [plan(ARM3R, corner, profile="quintic", blend=True, duration=3.0, rate_hz=r)
            for r in (100, 1000)]
    # continuous velocity: the largest step in velocity shrinks with the sample period
    assert max_velocity_jump(slow[1]) < 0.2 * max_velocity_jump(slow[0])
    traj = slow[1]
    dist = np.linalg.norm(traj.poses[:, :2] - corner[1][:2], axis=1)
    at = int(np.argmin(dist))
    speed = np.linalg.norm(np.diff(traj.poses[:, :2], axis=0), axis=1) * traj.rate_hz
    assert dist[at] <= speed.max() / traj.rate_hz  # passes through the via point
    assert speed[at] > 0.3 * speed.max()  # without stopping there
    stop = plan(ARM3R, corner, blend=False, duration=3.0, rate_hz=1000)
    stop_speed = np.linalg.norm(np.diff(stop.poses[:, :2], axis=0), axis=1) * 1000
    at_stop = int(np.argmin(np.linalg.norm(stop.poses[:, :2] - corner[1][:2], axis=1)))
    assert stop_speed[at_stop] < 1e-3 * stop_speed.max()
