"""Planning from a moving start_state: matched and within limits, its rules and JSON, off the
first waypoint, with jerk limits, retargets against braking, replans from a brake's end."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from planner_helpers import (
    ARM3R,
    ISSUE_VIAS,
    fd_ratio,
    moving_state,
    with_jerk,
)

import robodcn
from robodcn import kinematics
from robodcn.errors import (
    InputError,
)
from robodcn.planner import Trajectory, plan


@pytest.mark.parametrize("goal", [ISSUE_VIAS[-1], [0.0, 0.28, 1.9], [0.22, 0.05, -0.3]],
                         ids=["same-goal", "further", "back"])
def test_moving_start_is_matched_and_within_limits(goal: list[float]) -> None:
    free = with_jerk(ARM3R, None)
    run, i, state = moving_state(free)
    here = [float(x) for x in run.poses[i]]
    traj = plan(free, [here, goal], rate_hz=1000, start_state=state)
    assert traj.start_state == state
    np.testing.assert_array_equal(traj.joints[0], state.joints)
    q0, v0, a0 = state.arrays()
    from robodcn.planner.validate import start_history

    history = start_history(q0, v0, a0, 1000.0)
    assert fd_ratio(traj, free, history) <= 1 + 1e-9
    # velocity continuous across the start: the first step is v0 Δt within one sample of
    # maximum acceleration
    a = np.array([j.max_acceleration for j in free.joints])
    step = (traj.joints[1] - traj.joints[0]) * 1000 - v0
    assert (np.abs(step) <= a / 1000 * (1 + 1e-9)).all()
    np.testing.assert_allclose(traj.poses[-1, :2], goal[:2], atol=1e-9)
    if goal is ISSUE_VIAS[-1]:
        # retargeting to the goal it was heading for: no slower than the rest of that move
        assert traj.duration <= run.duration - i / 1000 + 2e-3


def test_start_state_rules_and_json() -> None:
    free = with_jerk(ARM3R, None)
    run, i, state = moving_state(free)
    here = [float(x) for x in run.poses[i]]
    with pytest.raises(InputError) as info:
        plan(free, [here, ISSUE_VIAS[-1]], rate_hz=1000, start_state=state, duration=3.0)
    assert info.value.field == "duration"
    with pytest.raises(InputError) as info:
        plan(free, [here, ISSUE_VIAS[-1]], rate_hz=1000, start_state=state, profile="quintic")
    assert info.value.field == "start_state"
    with pytest.raises(InputError) as info:
        plan(free, [here, ISSUE_VIAS[-1]], start_state=state, start_joints=state.joints)
    assert info.value.field == "start_state"
    too_fast = robodcn.StartState(state.joints, [10.0, 0.0, 0.0])
    with pytest.raises(InputError) as info:
        plan(free, [here, ISSUE_VIAS[-1]], start_state=too_fast)
    assert info.value.field == "start_state.velocities[0]"
    traj = plan(free, [here, ISSUE_VIAS[-1]], rate_hz=1000, start_state=state)
    back = Trajectory.from_json(traj.to_json(), free)
    assert back.start_state == traj.start_state
    np.testing.assert_array_equal(back.joints, traj.joints)
    # a body gives it as an object
    from robodcn import contract

    req = contract.parse_request({"waypoints": [here, ISSUE_VIAS[-1]], "rate_hz": 1000,
                                  "start_state": state.to_dict()}, free)
    assert req.start_state == state


def test_moving_start_from_a_pose_off_the_first_waypoint_goes_there_first() -> None:
    """With a start state the path runs from FK(joints) through every waypoint."""
    free = with_jerk(ARM3R, None)
    _, _, state = moving_state(free)
    traj = plan(free, [ISSUE_VIAS[2], ISSUE_VIAS[-1]], rate_hz=1000, start_state=state)
    d = np.linalg.norm(traj.poses[:, :2] - ISSUE_VIAS[2][:2], axis=1)
    assert d.min() < 1e-9  # stops there (no blend) and goes on
    np.testing.assert_allclose(traj.poses[-1, :2], ISSUE_VIAS[-1][:2], atol=1e-9)


@pytest.mark.parametrize("goal", [ISSUE_VIAS[-1], [0.22, 0.05, -0.3]], ids=["same", "back"])
def test_moving_start_with_jerk_limits_keeps_every_limit(goal: list[float]) -> None:
    arm = with_jerk(ARM3R, 20.0)
    run, i, state = moving_state(arm)
    here = [float(x) for x in run.poses[i]]
    traj = plan(arm, [here, goal], rate_hz=1000, start_state=state)
    np.testing.assert_array_equal(traj.joints[0], state.joints)
    from robodcn.planner.validate import start_history

    history = start_history(*state.arrays(), 1000.0)
    assert fd_ratio(traj, arm, history) <= 1 + 1e-9
    np.testing.assert_allclose(traj.poses[-1, :2], goal[:2], atol=1e-9)


@pytest.mark.parametrize("goal", [[0.07, 0.30, math.radians(100)], [0.22, 0.05, -0.3]],
                         ids=["3cm-10deg-off", "back"])
@pytest.mark.parametrize("at", [0.2, 0.4, 0.6])
def test_retarget_to_another_goal_beats_braking_then_going(goal: list[float], at: float
                                                           ) -> None:
    """A retarget from a moving state is no slower than braking to rest along its velocity
    at the acceleration limits and then the from-rest optimal plan from there (the bound any
    decent retarget must beat; before, a goal 3 cm / 10° off took twice that), keeps every
    limit and starts at the given velocity."""
    free = with_jerk(ARM3R, None)
    run, i, state = moving_state(free, at)
    here = [float(x) for x in run.poses[i]]
    traj = plan(free, [here, goal], rate_hz=1000, start_state=state)
    q0, v0, a0 = state.arrays()
    from robodcn.planner.validate import start_history

    assert fd_ratio(traj, free, start_history(q0, v0, a0, 1000.0)) <= 1 + 1e-9
    a = np.array([j.max_acceleration for j in free.joints])
    step = (traj.joints[1] - traj.joints[0]) * 1000 - v0
    assert (np.abs(step) <= a / 1000 * (1 + 1e-9)).all()
    np.testing.assert_allclose(traj.poses[-1, :2], goal[:2], atol=1e-9)
    t0 = float(np.max(np.abs(v0) / (2 * a)))  # braking on the line q0 + v0 t: 2 t0 to rest
    q_stop = q0 + v0 * t0
    stop_pose = [float(x) for x in kinematics.fk(free.links, q_stop[None, :])[0]]
    go = plan(free, [stop_pose, goal], rate_hz=1000, start_joints=list(q_stop))
    assert traj.duration <= 1.02 * (2 * t0 + go.duration) + 2e-3


def test_replan_from_the_end_of_a_brake_is_finite() -> None:
    """Issue 17 §7: a replace during a braking pause or stop (q̇ = 0 or nearly, q̈ at the
    limit) plans without a numpy warning or a non-finite sample (the brake from such a state,
    which divided by T₀ = 0, is test_path_timing's test_brake_without_velocity_is_no_brake)."""
    from robodcn.planner import StartState

    arm = ARM3R
    q0 = np.array([0.3, -1.0, 0.5])
    a = np.array([j.max_acceleration for j in arm.joints])
    here = kinematics.fk(arm.links, q0[None])[0].tolist()
    planned = 0
    for qd in ([0.0, 0.0, 0.0], [1e-13, 0.0, 0.0], [1e-300, -1e-300, 0.0]):
        for signs in ([-1, 1, 0], [1, 1, 1], [0, 0, 0]):
            state = StartState(tuple(q0), tuple(qd), tuple(0.99 * a * np.array(signs)))
            for goal in ([0.1, 0.25, 1.0], here):
                with np.errstate(divide="raise", invalid="raise", over="raise"), \
                        warnings.catch_warnings():
                    warnings.simplefilter("error", RuntimeWarning)
                    traj = plan(arm, [here, goal], start_state=state)
                assert np.isfinite(traj.joints).all()
                np.testing.assert_array_equal(traj.joints[0], q0)
                planned += 1
    assert planned == 18
