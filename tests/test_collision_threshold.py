"""A Current Limit of 0 never makes a 0 A collision threshold (robodcn.stream.collision).

Seen on a loaded host: "collision at joint 'shoulder': current 0.26 A above 0.00 A for 3
cycles at sample 2". The default threshold is min(2·peak + 0.5 A, 0.9·I_limit); a servo's
Current Limit read as 0 (a late status packet of the Position D Gain read just before it,
0 on an XM430, taken for the Current Limit's answer; or a position-mode servo configured
with 0, which does not bound its current) made it 0.9·0 = 0 A."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ARM3R, lockstep_arm

from robodcn.planner import plan
from robodcn.stream import execute
from robodcn.stream.collision import (
    FALLBACK_LIMIT_A,
    LIMIT_SHARE,
    MARGIN_A,
    ChainThresholds,
    current_caps,
    predicted_currents,
    threshold_profile,
    thresholds,
)

MOVE = [(0.25, 0.10, 0.0), (0.12, 0.24, math.radians(60))]
XM430_LIMIT_A = 1193 * 2.69e-3


def test_a_limit_that_is_not_positive_caps_at_the_fallback():
    caps = current_caps([0.0, XM430_LIMIT_A, -1.0, math.nan, math.inf])
    fallback = LIMIT_SHARE * FALLBACK_LIMIT_A
    assert caps[0] == caps[2] == caps[3] == caps[4] == pytest.approx(fallback)
    assert caps[1] == pytest.approx(LIMIT_SHARE * XM430_LIMIT_A)


@pytest.mark.parametrize("zero", [0, 1, 2])
def test_a_zero_current_limit_gives_the_thresholds_of_the_fallback_limit(zero):
    traj = plan(ARM3R, MOVE, duration="auto")
    period = float(traj.t[1] - traj.t[0])
    predicted = predicted_currents(traj.joints, period, ARM3R.servos, ARM3R)
    limits = [XM430_LIMIT_A] * 3
    misread = list(limits)
    misread[zero] = 0.0                      # the Current Limit read as the D Gain's 0
    profile = threshold_profile(predicted, period, misread, ARM3R)
    assert profile.min() >= MARGIN_A         # was 0.00 A at every sample of that joint
    fallback = list(limits)
    fallback[zero] = FALLBACK_LIMIT_A
    np.testing.assert_array_equal(profile, threshold_profile(predicted, period, fallback,
                                                             ARM3R))
    assert thresholds(predicted, misread, ARM3R).min() >= MARGIN_A
    chain = ChainThresholds(period, ARM3R.servos, ARM3R, None, misread, None)

    class Plan:                              # a chain of one node: the plan itself
        prev, switch, joints = None, 0, traj.joints

    assert min(chain.at(Plan, i).min() for i in range(len(traj.t))) >= MARGIN_A


def test_a_move_on_a_bus_that_read_a_zero_current_limit_is_no_collision():
    # the field run, deterministically: the bus's Current Limit of the shoulder read 0 A
    traj = plan(ARM3R, MOVE, duration="auto")
    with lockstep_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as (sa, clock):
        assert sa.bus.current_limits[0] == pytest.approx(XM430_LIMIT_A)
        sa.bus.current_limits = (0.0, *sa.bus.current_limits[1:])
        report = execute(traj, sa.bus, tracking_limit=None, clock=clock)
    assert report.stop_reason == "completed", report.message
    assert report.collision is None
    assert min(report.collision_threshold_a) >= MARGIN_A
