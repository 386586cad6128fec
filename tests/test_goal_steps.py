"""No goal step beyond the joint's velocity limit (issue 17 §7), on the wire: every Goal
Position the simulated servos accepted (firmware_sim's goal history, the goals written
before the stream included) steps at most v_max·T (+1 tick of rounding) — from rest, when
the compensation lead switches on, at the end, when it switches off, and at a hold."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest
from conftest import ARM3R, lockstep_arm

from robodcn import load_arm
from robodcn.kinematics import fk_yawed
from robodcn.planner import plan
from robodcn.simulated import simulated_arm
from robodcn.stream import StopSignal, execute

OMX = load_arm("configs/omx.toml")
MOVE_3R = [(0.25, 0.10, 0.0), (0.12, 0.24, math.radians(60))]


def omx_move():
    a = fk_yawed(OMX.chain, np.array([[0.0, -1.05, 0.35, 0.70]]))[0]
    b = fk_yawed(OMX.chain, np.array([[0.3, 0.6, -0.3, -0.2]]))[0]
    return [tuple(map(float, a)), tuple(map(float, b))]


def step_limits(arm, rate_hz):
    return np.array([j.max_velocity / rate_hz * s.ticks_per_turn / (2 * math.pi)
                     for j, s in zip(arm.joints, arm.servos, strict=True)])


def wire_steps(sim, arm, since):
    """Per joint, the largest |Δgoal| among the goals accepted from index ``since`` on
    (the goal held before the stream included)."""
    out = []
    for i in arm.servo_ids:
        history = np.array(sim.goal_history(i)[since[i] - 1:], dtype=np.int64)
        out.append(int(np.abs(np.diff(history)).max()) if len(history) > 1 else 0)
    return np.array(out)


@pytest.mark.parametrize("arm,waypoints,rate", [(ARM3R, MOVE_3R, 100.0),
                                                (ARM3R, MOVE_3R, 1000.0),
                                                (OMX, None, 100.0)],
                         ids=["3r-100Hz", "3r-1kHz", "omx-100Hz"])
def test_a_compensated_move_steps_within_the_velocity_limit_from_rest_to_rest(arm, waypoints,
                                                                               rate):
    traj = plan(arm, waypoints or omx_move(), duration="auto", rate_hz=rate)
    # On virtual time (conftest.lockstep_arm): every sample on time, so a step is the lead's,
    # not the schedule's; in real time a host stalled 260 ms tripped the Bus Watchdog.
    with lockstep_arm(arm, timing="fast", start_joints=traj.joints[0]) as (sa, clock):
        since = {i: len(sa.sim.goal_history(i)) for i in arm.servo_ids}
        report = execute(traj, sa.bus, tracking_limit=None, settle=0.3, skip_late=False,
                         clock=clock)
        steps = wire_steps(sa.sim, arm, since)
    assert report.compensation and report.stop_reason == "completed", report.message
    assert report.samples_sent == len(traj.t)
    assert (steps <= step_limits(arm, rate) + 1).all(), (steps, step_limits(arm, rate))


@pytest.mark.serial    # real time: a stop from another thread at a wall-clock moment
@pytest.mark.parametrize("arm,waypoints", [(ARM3R, MOVE_3R), (OMX, None)], ids=["3r", "omx"])
def test_a_hold_mid_move_keeps_the_goal_it_was_heading_for(arm, waypoints):
    traj = plan(arm, waypoints or omx_move(), duration="auto")
    stop = StopSignal()
    with simulated_arm(arm, timing="fast", start_joints=traj.joints[0]) as sa:
        since = {i: len(sa.sim.goal_history(i)) for i in arm.servo_ids}
        timer = threading.Timer(0.45 * traj.t[-1], stop.set)
        timer.start()
        try:
            report = execute(traj, sa.bus, tracking_limit=None, stop=stop, settle=0.3)
        finally:
            timer.cancel()
        steps = wire_steps(sa.sim, arm, since)
        last_sent = [sa.sim.goal_history(i)[-2] for i in arm.servo_ids]
    assert report.stop_reason == "stopped", report.message
    assert report.samples_sent < report.samples_total
    assert report.hold_goals is not None
    # the hold is the goal last streamed (no step back by the loop's lag) ...
    assert list(report.hold_goals) == last_sent
    # ... and no step on the wire exceeded the limit, the hold's included
    assert (steps <= step_limits(arm, traj.rate_hz) + 1).all(), steps
