"""Failures at the right sample: out of reach, joint and tick limits, a waypoint outside the
limits, too fast a duration."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from planner_helpers import (
    ARM3R,
    JERK3R,
    WAYPOINTS_3R,
    first_bad_row,
    unlimited,
    variant,
)

from robodcn import kinematics, timing
from robodcn.errors import (
    AccelerationLimitError,
    JerkLimitError,
    JointLimitError,
    TickLimitError,
    UnreachableError,
    VelocityLimitError,
)
from robodcn.planner import plan

# -- failures at the right sample ---------------------------------------------------------------

def test_unreachable_sample_is_named() -> None:
    """The tool point stays put while θ swings the long way through ±π: the wrist point
    (l3 behind the tool) leaves the workspace in the middle, both ends are reachable."""
    arm = unlimited(ARM3R)
    start, end = [0.32, 0.0, -2.0], [0.32, 0.0, 2.0]
    rate, duration = 100, 4.0
    with pytest.raises(UnreachableError) as info:
        plan(arm, [start, end], duration=duration, rate_hz=rate)
    n = round(duration * rate)
    theta = -2.0 + timing.quintic(np.arange(n + 1) / n) * (4.0 - 2 * math.pi)  # shortest: cw
    wrist = np.hypot(0.32 - arm.links[2] * np.cos(theta), -arm.links[2] * np.sin(theta))
    expected = int(np.argmax(wrist > sum(arm.links[:2]) + kinematics.REACH_TOLERANCE))
    err = info.value
    assert err.sample == expected > 0
    assert err.t == pytest.approx(expected / rate)
    np.testing.assert_allclose(err.pose, [0.32, 0.0, theta[expected]], atol=1e-12)
    assert f"sample {expected}" in str(err) and "out of reach" in str(err)
    assert err.to_dict()["sample"] == expected
    # "auto" cannot time a path with a gap: it reports the gap, not the speeds before it
    with pytest.raises(UnreachableError) as info:
        plan(ARM3R, [start, end], rate_hz=rate)
    assert wrist_radius_at(info.value.pose) > sum(arm.links[:2])


def wrist_radius_at(pose: Any) -> float:
    return float(kinematics.wrist_radius(ARM3R.links, [pose])[0])


def test_unreachable_waypoint_is_named() -> None:
    wps = [*WAYPOINTS_3R, [0.6, 0.1, 0.0]]
    with pytest.raises(UnreachableError) as info:
        plan(ARM3R, wps)
    assert info.value.field == "waypoints[3]"
    assert "waypoints[3]" in str(info.value) and "0.35" in str(info.value)


def test_joint_limit_sample_is_named() -> None:
    # rotate the whole arm about the base (pole at the origin): the shoulder sweeps ~80°
    wps = [[0.28 * math.cos(0.2), 0.28 * math.sin(0.2), 0.2],
           [0.28 * math.cos(1.6), 0.28 * math.sin(1.6), 1.6]]
    free = plan(ARM3R, wps, profile="quintic", duration=3.0, rate_hz=100)
    shoulder = free.joints[:, 0]
    limit = 0.5 * (np.abs(shoulder).min() + np.abs(shoulder).max())
    narrow = variant(ARM3R, only=0, min=-limit, max=limit)
    expected = first_bad_row(np.abs(free.joints[:, :1]) > limit)
    with pytest.raises(JointLimitError) as info:
        plan(narrow, wps, profile="quintic", duration=3.0, rate_hz=100)
    err = info.value
    assert err.sample == expected and err.joint == "shoulder"
    np.testing.assert_allclose(err.pose, free.poses[expected], atol=1e-12)
    assert err.t == pytest.approx(free.t[expected])
    assert "'shoulder'" in str(err) and f"sample {expected} " in str(err)


def test_waypoint_outside_the_limits_is_named() -> None:
    free = plan(ARM3R, WAYPOINTS_3R, profile="quintic", duration=3.0, rate_hz=100)
    limit = abs(free.joints[0, 0]) * 0.9  # the first waypoint's shoulder is beyond it
    narrow = variant(ARM3R, only=0, min=-limit, max=limit)
    with pytest.raises(JointLimitError) as info:
        plan(narrow, WAYPOINTS_3R, profile="quintic", duration=3.0, rate_hz=100)
    assert info.value.sample == 0 and info.value.field == "waypoints[0]"
    assert "waypoints[0]" in str(info.value)


def test_tick_limit_sample_is_named() -> None:
    free = plan(ARM3R, WAYPOINTS_3R, profile="quintic", duration=4.0, rate_hz=100)
    narrow = variant(ARM3R, servo_min_tick=1500, servo_max_tick=2600)
    expected = first_bad_row((free.ticks < 1500) | (free.ticks > 2600))
    with pytest.raises(TickLimitError) as info:
        plan(narrow, WAYPOINTS_3R, duration=4.0, rate_hz=100)
    assert info.value.sample == expected
    assert info.value.value == free.ticks[expected][
        ARM3R.joint_names.index(info.value.joint)]


@pytest.mark.parametrize("profile", ["quintic", "trapezoid"])
def test_too_fast_duration_fails_at_the_first_fast_sample(profile: str) -> None:
    wps = WAYPOINTS_3R[:2]
    fast = unlimited(ARM3R)
    # trapezoid shape depends on the limits: compare against the quintic only
    loose = plan(fast, wps, duration=0.3, rate_hz=100, profile="quintic")
    q = loose.joints
    v = np.array([j.max_velocity for j in ARM3R.joints])
    a = np.array([j.max_acceleration for j in ARM3R.joints])
    vel = np.zeros_like(q)
    vel[1:] = np.abs(np.diff(q, axis=0)) * 100
    acc = np.zeros_like(q)
    acc[2:] = np.abs(np.diff(q, 2, axis=0)) * 100**2
    # the recommended jerk limits too: the third difference from rest, charged to its last sample
    j = np.array([jt.max_jerk for jt in JERK3R.joints])
    jerk = np.zeros_like(q)
    jerk[1:] = np.abs(np.diff(np.concatenate([q[:1], q[:1], q]), 3, axis=0)) * 100**3
    with pytest.raises((VelocityLimitError, AccelerationLimitError, JerkLimitError)) as info:
        plan(JERK3R, wps, duration=0.3, rate_hz=100, profile=profile)
    err = info.value
    assert err.field == "duration" and err.joint in ARM3R.joint_names
    assert f"sample {err.sample} " in str(err) and "rad/s" in str(err)
    if profile == "quintic":
        first_v = first_bad_row(vel > v) if (vel > v).any() else len(q)
        first_a = first_bad_row(acc > a) if (acc > a).any() else len(q)
        first_j = first_bad_row(jerk > j) if (jerk > j).any() else len(q)
        expected = min(first_v, first_a, first_j)
        assert err.sample == expected
        kind = (VelocityLimitError if first_v == expected else
                AccelerationLimitError if first_a == expected else JerkLimitError)
        assert isinstance(err, kind)
        np.testing.assert_allclose(err.pose, loose.poses[expected], atol=1e-12)
