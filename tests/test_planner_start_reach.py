"""A lone waypoint's path starts at the start's pose: start joints that put the tool where
the IK has no solution within the limits (over the top, behind the yaw axis) are refused
naming start_joints, on every profile, instead of an AssertionError from inside the
planner (seen on 958 of 3000 random omx requests with a uniform profile)."""

from __future__ import annotations

import pytest
from omx_helpers import OMX

from robodcn.errors import UnreachableError
from robodcn.planner import plan

GOAL = [0.15, 0.05, 0.15, 0.0]


@pytest.mark.parametrize("profile", ["quintic", "linear", "trapezoid", "optimal"])
@pytest.mark.parametrize("start", [[1.45, 1.12, -0.63, 1.38],     # over the top
                                   [-0.35, -1.44, -0.26, 1.31]])  # behind the yaw axis
def test_start_joints_the_path_cannot_leave_from_are_refused_naming_them(profile, start):
    with pytest.raises(UnreachableError) as err:
        plan(OMX, [GOAL], start_joints=start, profile=profile)
    assert err.value.field == "start_joints" and err.value.value == start
    assert "start_joints put the tool at" in str(err.value)


def test_a_start_in_reach_plans_from_there():
    start = [0.2, -0.3, 0.4, 0.5]
    traj = plan(OMX, [GOAL], start_joints=start, profile="quintic")
    assert abs(traj.joints[0] - start).max() < 1e-9
