"""Auto timing: feasible and minimal, from rest, blended, the closed form against the search,
jerk limits."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from planner_helpers import (
    ARM3R,
    JERK2R,
    JERK3R,
    WAYPOINTS_2R,
    WAYPOINTS_3R,
    check_trajectory,
    fd_ratio,
    with_jerk,
)

from robodcn import kinematics, timing
from robodcn.config import Arm, arm_from_dict
from robodcn.errors import (
    AccelerationLimitError,
    JerkLimitError,
    VelocityLimitError,
)
from robodcn.interpolate import interpolate
from robodcn.planner import plan

# -- auto timing --------------------------------------------------------------------------------

@pytest.mark.parametrize(("arm", "waypoints"), [(JERK3R, WAYPOINTS_3R[:2]),
                                                (JERK2R, WAYPOINTS_2R[:2])], ids=["3r", "2r"])
@pytest.mark.parametrize("profile", timing.UNIFORM_PROFILES)
def test_auto_is_feasible_and_minimal(arm: Arm, waypoints: Any, profile: str) -> None:
    """With the recommended jerk limits too: auto passes, the plan re-run with its own duration
    is the same plan, and one period less fails — for the quintic (smooth: jerk ∝ 1/T³)
    under the jerk limit; the linear and trapezoid laws step in velocity/acceleration, so
    their sampled jerk is not monotone in T (timing docstring) and their minimality is
    checked without a jerk limit."""
    assert all(j.max_jerk is not None for j in arm.joints)
    rate = 500
    for a in (arm, with_jerk(arm, None)):
        traj = plan(a, waypoints, profile=profile, rate_hz=rate)
        check_trajectory(traj, a, waypoints)
        assert fd_ratio(traj, a) <= 1 + 1e-9
        total = traj.duration
        assert total * rate > 100  # so that 0.99·T drops at least one sample period
        again = plan(a, waypoints, profile=profile, rate_hz=rate, duration=total)
        np.testing.assert_allclose(again.joints, traj.joints, atol=1e-12)
        if profile == "quintic" or a is not arm:
            with pytest.raises((VelocityLimitError, AccelerationLimitError, JerkLimitError)):
                plan(a, waypoints, profile=profile, rate_hz=rate, duration=0.99 * total)


def test_linear_profile_starts_from_rest() -> None:
    """The velocity step at t = 0 is an acceleration from a standing arm, named at sample 1."""
    wps = WAYPOINTS_3R[:2]
    rate = 100
    auto = plan(ARM3R, wps, profile="linear", rate_hz=rate)
    check_trajectory(auto, ARM3R, wps)
    # A duration whose constant velocity is within every limit but whose first step is not:
    q = auto.joints
    a = np.array([j.max_acceleration for j in ARM3R.joints])
    v = np.array([j.max_velocity for j in ARM3R.joints])
    travel = np.abs(q[-1] - q[0])
    fast = float(np.max(travel / v)) * 1.2  # about 80 % of the velocity limit
    first_step = travel / (fast * rate)
    assert (first_step * rate**2 > a).any()  # the premise of the test
    with pytest.raises(AccelerationLimitError) as info:
        plan(ARM3R, wps, profile="linear", rate_hz=rate, duration=fast)
    assert info.value.sample == 1


def test_auto_blended_is_minimal() -> None:
    rate = 500
    traj = plan(ARM3R, WAYPOINTS_3R, profile="quintic", blend=True, rate_hz=rate)
    check_trajectory(traj, ARM3R, WAYPOINTS_3R)
    with pytest.raises((VelocityLimitError, AccelerationLimitError, JerkLimitError)):
        plan(ARM3R, WAYPOINTS_3R, profile="quintic", blend=True, rate_hz=rate,
             duration=0.99 * traj.duration)


def test_auto_closed_form_matches_the_search() -> None:
    """At a high rate the finite-difference auto duration tends to the closed form, with the
    jerk term ∛(max|d³q/dτ³| / j) where the arm sets jerk limits (and without them)."""
    wps = WAYPOINTS_3R[:2]
    dense = 20000
    tau = np.arange(dense + 1) / dense
    poses = interpolate(wps[0], wps[1], timing.quintic(tau))
    q = kinematics.ik_path(ARM3R.links, poses, elbow=ARM3R.elbow)
    d1 = np.gradient(q, tau, axis=0)
    d2 = np.gradient(d1, tau, axis=0)
    d3 = np.gradient(d2, tau, axis=0)
    v = [j.max_velocity for j in ARM3R.joints]
    a = [j.max_acceleration for j in ARM3R.joints]
    jerk = [j.max_jerk for j in JERK3R.joints]
    closed = timing.auto_duration(d1, d2, v, a, d3, jerk)
    free = timing.auto_duration(d1, d2, v, a)
    assert closed > free  # the jerk limit binds on this move
    assert plan(JERK3R, wps, profile="quintic", rate_hz=1000).duration == pytest.approx(
        closed, rel=5e-3)
    assert plan(ARM3R, wps, profile="quintic", rate_hz=1000).duration == \
        pytest.approx(free, rel=5e-3)


def jerk_arm(jerk: float) -> Arm:
    data = ARM3R.to_dict()
    for joint in data["joints"]:
        joint["max_jerk"] = jerk
    return arm_from_dict(data, source=ARM3R.source)


def test_jerk_limit_is_respected_by_auto_timing_and_checked() -> None:
    free = plan(ARM3R, WAYPOINTS_3R[:2], profile="quintic")
    jerk3 = np.abs(np.diff(np.concatenate([free.joints[:1]] * 2 + [free.joints]
                                          + [free.joints[-1:]] * 2), 3, axis=0)).max()
    limit = 0.5 * jerk3 * free.rate_hz**3
    arm = jerk_arm(limit)
    slow = plan(arm, WAYPOINTS_3R[:2], profile="quintic")
    assert slow.duration > free.duration
    q = np.concatenate([slow.joints[:1]] * 3 + [slow.joints] + [slow.joints[-1:]] * 2)
    assert (np.abs(np.diff(q, 3, axis=0)) * slow.rate_hz**3 <= limit * (1 + 1e-9)).all()
    from robodcn.errors import JerkLimitError

    with pytest.raises(JerkLimitError) as info:
        plan(arm, WAYPOINTS_3R[:2], profile="quintic", duration=free.duration)
    v = info.value.violation
    assert v.quantity == "jerk" and v.unit == "rad/s^3" and v.value > v.limit == limit
    assert info.value.field == "duration"
