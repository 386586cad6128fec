"""The approach from start_joints: a joint-space segment, none when already there, the long way
inside the limits, the branch nearest the present joints."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from planner_helpers import (
    ARM3R,
    WAYPOINTS_3R,
    check_trajectory,
)

from robodcn import kinematics
from robodcn.planner import Trajectory, plan, plan_request

# -- approach -----------------------------------------------------------------------------------

def test_approach_segment_from_present_joints() -> None:
    present = np.array([0.1, -0.3, 0.2])
    traj = plan(ARM3R, WAYPOINTS_3R, start_joints=present, rate_hz=200)
    check_trajectory(traj, ARM3R, WAYPOINTS_3R, approach=True)
    np.testing.assert_array_equal(traj.joints[0], present)
    check_steps = np.abs(np.diff(traj.joints, axis=0)).max()
    assert check_steps * 200 <= max(j.max_velocity for j in ARM3R.joints)
    # the path proper starts where the approach ends
    direct = plan(ARM3R, WAYPOINTS_3R, rate_hz=200)
    assert traj.t.shape[0] > direct.t.shape[0]
    hit = np.flatnonzero(np.linalg.norm(traj.poses - WAYPOINTS_3R[0], axis=1) < 1e-12)
    assert hit.size and hit[0] > 0
    np.testing.assert_allclose(traj.joints[hit[0]:], direct.joints, atol=1e-9)
    # the approach is data: its length, in samples and seconds, survives JSON
    assert traj.approach_samples == hit[0] and direct.approach_samples == 0
    assert traj.approach_duration == pytest.approx(hit[0] / 200)
    assert Trajectory.from_json(traj.to_json()).approach_samples == hit[0]


def test_no_approach_when_already_there_and_replan() -> None:
    direct = plan(ARM3R, WAYPOINTS_3R, rate_hz=100)
    same = plan(ARM3R, WAYPOINTS_3R, rate_hz=100, start_joints=direct.joints[0] + 1e-5)
    assert same.t.shape == direct.t.shape and same.approach_samples == 0
    # the streamer's re-plan: same request, new present joints
    again = plan_request(dataclasses.replace(direct.request,
                                             start_joints=tuple(direct.joints[0] - 0.2)))
    np.testing.assert_allclose(again.joints[0], direct.joints[0] - 0.2, atol=1e-15)
    np.testing.assert_allclose(again.joints[-1], direct.joints[-1], atol=1e-9)


def test_approach_turns_the_long_way_inside_the_limits() -> None:
    """The nearest turn of the first pose's shoulder angle lies beyond the +170° limit, so
    the approach swings the shoulder the long way round instead of into the limit."""
    target = np.array([-2.9, -0.8, 0.5])
    pose = kinematics.fk(ARM3R.links, target[None])[0]
    wps = [pose, pose + np.array([0.0, 0.01, 0.0])]
    present = np.array([2.9, -0.8, 0.5])
    traj = plan(ARM3R, wps, start_joints=present, rate_hz=100)
    check_trajectory(traj, ARM3R, wps, approach=True)
    reached = np.flatnonzero(np.linalg.norm(traj.poses - pose, axis=1) < 1e-12)[0]
    np.testing.assert_allclose(traj.joints[reached], target, atol=1e-9)
    assert traj.joints[:, 0].max() == pytest.approx(2.9) and traj.joints[:, 0].min() < -2.8


def test_start_joints_pick_the_branch() -> None:
    direct = plan(ARM3R, WAYPOINTS_3R, rate_hz=100)  # the arm's preferred elbow: up
    down = kinematics.ik_branches(ARM3R.links, [WAYPOINTS_3R[0]])[1]
    traj = plan(ARM3R, WAYPOINTS_3R, rate_hz=100, start_joints=down[0])
    np.testing.assert_allclose(traj.joints[0], down[0], atol=1e-12)  # no approach needed
    assert (traj.joints[:, 1] >= 0).all() and (direct.joints[:, 1] <= 0).all()
