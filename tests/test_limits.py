"""robodcn.path_timing.limits: the arm's per-joint limits, derived once."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from robodcn.config import load_arm
from robodcn.path_timing import JointLimits

CONFIGS = Path(__file__).resolve().parent.parent / "configs"
ARM3R = load_arm(CONFIGS / "arm3r.toml")


def test_of_reads_the_joints():
    lim = JointLimits.of(ARM3R)
    assert lim.v.tolist() == [j.max_velocity for j in ARM3R.joints]
    assert lim.a.tolist() == [j.max_acceleration for j in ARM3R.joints]
    assert lim.j is None and not lim.jerk_limited
    assert np.isinf(lim.jerk).all() and lim.jerk.shape == (3,)


def test_jerk_inf_where_a_joint_sets_none():
    joints = list(ARM3R.joints)
    joints[1] = dataclasses.replace(joints[1], max_jerk=500.0)
    lim = JointLimits.of(dataclasses.replace(ARM3R, joints=tuple(joints)))
    assert lim.jerk_limited
    assert lim.j is not None and lim.j[1] == 500.0
    assert math.isinf(lim.j[0]) and math.isinf(lim.j[2])


@pytest.mark.parametrize("k", [0.25, 0.5, 2.0])
def test_scaled_is_a_time_scaling(k):
    joints = tuple(dataclasses.replace(j, max_jerk=100.0) for j in ARM3R.joints)
    lim = JointLimits.of(dataclasses.replace(ARM3R, joints=joints))
    s = lim.scaled(k)
    np.testing.assert_allclose(s.v, lim.v * k)
    np.testing.assert_allclose(s.a, lim.a * k ** 2)
    np.testing.assert_allclose(s.j, lim.j * k ** 3)
    back = s.scaled(1.0 / k)
    np.testing.assert_allclose(back.a, lim.a)
    m = lim.shrunk(k)
    np.testing.assert_allclose(m.a, lim.a * k)
    np.testing.assert_allclose(m.j, lim.j * k)
    assert JointLimits.of(ARM3R).scaled(k).j is None
