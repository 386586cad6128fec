"""A replacement whose goal is where the arm already is, with a numeric duration (issue 17 §7:
the stress run's 500 ValueError on replace with ``duration``)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ARM3R

from robodcn.errors import InputError
from robodcn.path_timing import JointLimits
from robodcn.planner.path import user_pose
from robodcn.stream.online.retarget import Retargeting
from robodcn.stream.online.state import State
from robodcn.stream.online.timing import Timing
from robodcn.stream.online_path import JointPath

RATE = 100.0
Q = np.array([0.4, -0.8, 0.3])


def _state(history: np.ndarray) -> State:
    path, sigma = JointPath.of_samples(history)
    return State.of_history(2, history, path, float(sigma[-1]), RATE)


def _retargeting() -> Retargeting:
    return Retargeting(ARM3R, Timing(JointLimits.of(ARM3R), RATE), None)


def test_a_replacement_to_where_the_resting_arm_is_holds_for_its_duration():
    state = _state(np.tile(Q, (3, 1)))
    goal = tuple(user_pose(ARM3R, Q[None, :])[0])
    segments = _retargeting().tail(state, [None, goal], {"duration": 1.5})
    joints = np.vstack([seg[0] for seg in segments])
    assert len(joints) == pytest.approx(1.5 * RATE, abs=1)
    assert np.allclose(joints, Q, atol=1e-6)


def test_a_replacement_to_where_a_moving_arm_is_refuses_the_duration():
    step = np.array([0.004, -0.003, 0.002])
    history = np.vstack([Q - 2 * step, Q - step, Q])
    state = _state(history)
    goal = tuple(user_pose(ARM3R, Q[None, :])[0])
    try:
        segments = _retargeting().tail(state, [None, goal], {"duration": 1.5})
    except InputError as exc:
        assert exc.field == "duration"
    else:
        # the arm has to brake and come back: a real motion, stretched to the duration
        joints = np.vstack([seg[0] for seg in segments])
        assert len(joints) == pytest.approx(1.5 * RATE, rel=0.1)
        assert np.allclose(joints[-1], Q, atol=1e-3)
