"""Property: any reachable request either plans cleanly or fails with a PlanError."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from planner_helpers import (
    ARM2R,
    ARM3R,
    check_trajectory,
)

from robodcn import kinematics, timing
from robodcn.config import Arm
from robodcn.errors import (
    AccelerationLimitError,
    InputError,
    PlanError,
    VelocityLimitError,
)
from robodcn.planner import plan

# -- property: any reachable request either plans cleanly or fails with a PlanError -------------

@pytest.mark.parametrize("arm", [ARM3R, ARM2R], ids=["3r", "2r"])
@given(data=st.data())
@settings(max_examples=40, deadline=None)
def test_random_requests_plan_or_fail_cleanly(arm: Arm, data: st.DataObject) -> None:
    m = data.draw(st.integers(2, 4), label="waypoints")
    limits = [(j.min_angle * 0.9, j.max_angle * 0.9) for j in arm.joints]
    q = np.array([[data.draw(st.floats(lo, hi)) for lo, hi in limits] for _ in range(m)])
    # Waypoints on the straight/folded elbow make the linear profile's auto time grow with
    # the rate (a √ singularity met at speed): keep the elbow bent for a fast test.
    q[:, 1] = np.sign(q[:, 1] + 1e-300) * np.clip(np.abs(q[:, 1]), 0.2, 2.5)
    wps = kinematics.fk(arm.links, q)
    kwargs = {
        "method": data.draw(st.sampled_from(["sclerp", "kenlerp", "seplerp", "dlb"])),
        "beta": data.draw(st.floats(0.0, 2.0)),
        "profile": data.draw(st.sampled_from(timing.PROFILES)),
        "blend": data.draw(st.booleans()),
        "rate_hz": data.draw(st.sampled_from([20, 100, 250])),
        "duration": data.draw(st.one_of(st.just("auto"), st.floats(0.5, 5.0))),
    }
    if data.draw(st.booleans(), label="start_joints"):
        kwargs["start_joints"] = [data.draw(st.floats(lo, hi)) for lo, hi in limits]
    try:
        traj = plan(arm, wps, **kwargs)
    except PlanError as err:
        assert err.sample is None or 0 <= err.sample < 10**6
        assert str(err)
        if kwargs["duration"] == "auto":
            # auto never fails on the limits it chose the duration for
            assert not isinstance(err, VelocityLimitError | AccelerationLimitError)
        return
    except InputError as err:  # only the 10⁶-sample cap may refuse a well-formed request
        assert err.field == "duration" and "more than 1000000" in str(err)
        return
    check_trajectory(traj, arm, wps, approach="start_joints" in kwargs)
