"""Gravity on the OpenMANIPULATOR-X (issue 18 §3) through the one inverse dynamics (issue 19):
the tracking compensation holds a commanded pose to ≤ 2 ticks where the uncompensated servo
droops, and the collision stop's threshold starts from the current gravity needs at each
sample (a loaded arm does not trip it, an obstacle still does). On firmware_sim's physics,
on virtual time (conftest.lockstep_arm)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import lockstep_arm

from robodcn import load_arm
from robodcn.config import arm_from_dict, rigid_chain
from robodcn.dynamics import gravity_torque
from robodcn.kinematics import fk_yawed
from robodcn.planner import plan
from robodcn.stream import execute
from robodcn.stream.collision import predicted_currents, threshold_profile
from robodcn.stream.compensation import lag_pulses
from robodcn.stream.servo_model import motor_of

OMX = load_arm("configs/omx.toml")
HOME_Q = np.array([0.0, -1.05, 0.35, 0.70])
#: leaning forward and down: the shoulder and elbow carry most of the arm's weight
STRETCHED_Q = np.array([0.3, 0.6, -0.3, -0.2])


def pose(q):
    return tuple(float(v) for v in fk_yawed(OMX.chain, np.asarray(q)[None])[0])


def loaded(kg: float):
    data = OMX.to_dict()
    data.setdefault("dynamics", {})["payload_kg"] = kg
    return arm_from_dict(data)


def run(arm, traj, obstacle=None, **options):
    """``traj`` on the simulated arm seated at its start, on virtual time (the physics step
    with the schedule, so a loaded host changes nothing: no late sample, no sag while the
    test is set up); ``obstacle`` (degrees) stops the shoulder there."""
    with lockstep_arm(arm, timing="fast", start_joints=traj.joints[0]) as (sa, clock):
        if obstacle is not None:
            sa.sim.servo(arm.servo_ids[1]).set_obstacle(obstacle)
        report = execute(traj, sa.bus, tracking_limit=None, clock=clock, **options)
        assert not sa.sim.errors, sa.sim.errors
    assert report.lateness_max_s == 0.0, "virtual time: every sample on time"
    return report


def test_the_compensated_omx_holds_a_stretched_pose_where_the_plain_servo_droops():
    traj = plan(OMX, [pose(HOME_Q), pose(STRETCHED_Q)], duration="auto")
    plain = run(OMX, traj, compensation=False, settle=1.0)
    led = run(OMX, traj, compensation=True, settle=1.0)
    assert plain.stop_reason == led.stop_reason == "completed", (plain.message, led.message)
    droop = np.abs(plain.final_error_ticks)
    assert droop[1] > 10 and droop[2] > 10, plain.final_error_ticks   # it visibly sags
    assert np.abs(led.final_error_ticks).max() <= 2, led.final_error_ticks


def test_a_hold_at_rest_lifts_the_sagged_arm_onto_the_plan():
    """A plan that (all but) stays where the arm was seated (a hold from rest, half a
    second): the uncompensated servo stays sagged below it, the compensated one is lifted
    onto it within the first samples."""
    import dataclasses

    start = pose(STRETCHED_Q)
    moving = plan(OMX, [start, (start[0] + 0.0002, *start[1:])], duration=0.5)
    n = len(moving.t)
    traj = dataclasses.replace(moving, joints=np.repeat(moving.joints[:1], n, axis=0),
                               ticks=np.repeat(moving.ticks[:1], n, axis=0),
                               poses=np.repeat(moving.poses[:1], n, axis=0))
    assert n >= 40 and np.ptp(traj.ticks, axis=0).max() == 0
    plain = run(OMX, traj, compensation=False, settle=0.5)
    led = run(OMX, traj, compensation=True, settle=0.5)
    assert np.abs(plain.final_error_ticks).max() > 10, plain.final_error_ticks
    assert np.abs(led.final_error_ticks).max() <= 2, led.final_error_ticks


def test_predicted_current_at_rest_is_the_gravity_current_and_the_threshold_is_above_it():
    q = np.repeat(STRETCHED_Q[None], 20, axis=0)
    current = predicted_currents(q, 0.01, OMX.servos, OMX)
    tau = gravity_torque(rigid_chain(OMX), STRETCHED_Q)
    motor = motor_of("xm430-w350")
    expected = tau * motor.resistance / (motor.eta_k * motor.voltage) * motor.voltage \
        / motor.resistance
    assert np.allclose(current, expected[None], atol=1e-9)
    assert abs(current[0, 1]) > 0.3                       # the shoulder really is loaded
    profile = threshold_profile(current, 0.01, [2.3] * 4, OMX)
    assert (profile > np.abs(current)).all()
    # a payload adds its own current
    heavier = predicted_currents(q, 0.01, OMX.servos, OMX, payload_kg=0.5)
    assert abs(heavier[0, 1]) > abs(current[0, 1]) + 0.2


def test_with_an_i_gain_the_lag_hands_the_load_to_the_integrator():
    pwm = np.full(1000, 200.0)
    p_only = lag_pulses(pwm, 0.01, 800)
    assert np.allclose(p_only, 200.0 / (800 / 128))
    with_i = lag_pulses(pwm, 0.01, 800, 100)
    assert with_i[0] == pytest.approx(p_only[0])            # the whole lead at once
    assert np.all(np.diff(with_i) < 0) and with_i[-1] < 0.2 * p_only[0]
    # the loop's PWM of that lag is the PWM asked for, sample by sample
    integral = np.concatenate([[0.0], np.cumsum(with_i * 10.0)[:-1]])
    assert np.allclose(800 / 128 * with_i + 100 / 65536 * integral, pwm)


def test_a_loaded_omx_moving_fast_is_no_collision_but_an_obstacle_is():
    arm = loaded(0.5)
    traj = plan(arm, [pose(HOME_Q), pose(STRETCHED_Q)], duration="auto")
    report = run(arm, traj)
    assert report.stop_reason == "completed", report.message
    assert report.collision is None
    q0, q1 = np.degrees(traj.joints[0, 1]), np.degrees(traj.joints[-1, 1])
    hit = run(arm, traj, obstacle=float(q0 + 0.4 * (q1 - q0)))
    assert hit.stop_reason == "collision", hit.message
    assert hit.collision["joint"] == "shoulder"
