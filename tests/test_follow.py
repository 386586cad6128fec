"""Follow a stream of targets (robodcn.stream.follow) on the wire: firmware_sim over a pty
through dynamixel-sdk, on virtual time (the loop is held at each target's arrival, so the
checks are the session's logic, not the host's timing).

Every check reads what the simulated servos accepted (``SimBus.goal_history``) and the
commanded joints of the samples sent (``Follower.sent``): the wire carries exactly the
commanded ticks, and the commanded joints keep the limits."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ARM3R
from omx_helpers import OMX
from online_helpers import JERK_ARM, arm_at_start

from robodcn import kinematics, servo_units
from robodcn.errors import InputError, NoMoveError
from robodcn.planner.path import user_pose
from robodcn.simulated import simulated_arm
from robodcn.stream import VirtualClock, follow

RATE = 1000.0
T = 1.0 / RATE
GAP = 1.0 / 30.0
#: finite differences of the commanded joints land within this of a limit
SLACK = 1e-6


def _limits(arm):
    v = np.array([j.max_velocity for j in arm.joints])
    a = np.array([j.max_acceleration for j in arm.joints])
    return v, a


def run_session(sa, arm, steps, **kw):
    """Open a session on virtual time, hold the loop at each (time s, op) of ``steps`` and
    run ``op(follower)``; release and wait. The follower, its report and the wire goals."""
    clock = VirtualClock()
    clock.hold(0.0)
    sa.sim.clear_log()
    before = len(sa.sim.goal_history(arm.servo_ids[0]))
    f = follow(sa.bus, arm, rate_hz=RATE, clock=clock, watchdog_ms=0, skip_late=False, **kw)
    try:
        assert clock.wait_parked(), f.error
        t0 = f.stream.t_start
        for t, op in steps:
            clock.hold(t0 + t)
            if not f.done:
                assert clock.wait_parked(), f.error
            op(f)
    except BaseException:
        f.stop("hold")
        raise
    finally:
        clock.release()
    report = f.wait(60)
    assert report is not None and f.done
    wire = np.array([sa.sim.goal_history(i)[before:] for i in arm.servo_ids]).T
    return f, report, wire


def _commanded(f, wire, arm):
    """The commanded joints of the samples sent; the wire carries exactly their ticks."""
    index, _, joints = f.sent()
    assert (np.diff(index) == 1).all(), "every sample sent once, in order"
    ticks = servo_units.radians_to_ticks(joints, arm.servos)
    assert np.array_equal(wire[:len(ticks)], ticks)
    return index, joints


def _check_limits(joints, arm, jerk=None):
    v, a = _limits(arm)
    q = np.vstack([joints[:1], joints[:1], joints, joints[-1:], joints[-1:]])
    vel = np.diff(q, axis=0) * RATE
    acc = np.diff(vel, axis=0) * RATE
    assert (np.abs(vel) <= v * (1 + SLACK)).all(), np.abs(vel).max(0) / v
    assert (np.abs(acc) <= a * (1 + SLACK)).all(), np.abs(acc).max(0) / a
    if jerk is not None:
        jk = np.abs(np.diff(acc, axis=0)) * RATE
        assert (jk <= jerk * (1 + SLACK)).all(), jk.max(0) / jerk


def _smooth_stream(arm, q0, share=0.4, hz=0.8):
    """A smooth target motion from rest at ``share`` of the arm's velocity and acceleration
    limits: joint j moves by a_j·(1 − cos ω_j t), ω_j = 2π·hz·(1, 0.75, 1.25, …)[j], so the
    joints never rest at once between t = 0 and t = 2.5/hz s."""
    v, a = _limits(arm)
    w = 2 * math.pi * hz * np.array([1.0, 0.75, 1.25, 0.9])[:len(q0)]
    amp = np.minimum(share * v / w, share * a / w ** 2) * np.array([1, -1, 1, -1])[:len(q0)]

    def at(t):
        t = np.asarray(t, dtype=np.float64)[..., None]
        return q0 + amp * (1 - np.cos(w * t))
    return at


def _best_lag(joints, times, signal, upto=0.08):
    """(lag s, RMS rad) of the commanded joints against the signal delayed by the lag that
    fits best (0.5 ms steps)."""
    fits = [(float(np.sqrt(np.mean((joints - signal(times - lag)) ** 2))), lag)
            for lag in np.arange(0.0, upto, 0.0005)]
    rms, lag = min(fits)
    return lag, rms


# -- tracking a stream ----------------------------------------------------------------------

@pytest.mark.parametrize("arm", [ARM3R, JERK_ARM], ids=["arm3r", "arm3r-jerk"])
def test_a_smooth_30hz_joint_stream_is_tracked_one_target_period_behind(arm):
    """A smooth target streamed at 30 Hz at 40 % of the limits: followed with a lag ≤ one
    target period + 2 bus periods and RMS error ≤ 0.5° after that lag, never at rest
    mid-stream, within v, a (and j), and the stream ends at rest on the last target."""
    n = 70
    with arm_at_start() as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], arm.servos)[0]
        signal = _smooth_stream(arm, q0)
        steps = [(k * GAP, lambda f, k=k: f.target(joints=signal(k * GAP)))
                 for k in range(n)]
        steps.append((n * GAP, lambda f: f.end()))
        f, report, wire = run_session(sa, arm, steps)
    assert report.outcome == "done" and report.stop_reason == "completed", report.message
    assert f.taken == n and f.refused == 0
    index, joints = _commanded(f, wire, arm)
    jerk = None if arm is ARM3R else np.array([j.max_jerk for j in arm.joints])
    _check_limits(joints, arm, jerk)
    times = index * T
    mid = (times > 0.3) & (times < (n - 3) * GAP)
    lag, rms = _best_lag(joints[mid], times[mid], signal)
    assert lag <= GAP + 2 * T, lag
    assert math.degrees(rms) <= 0.5, math.degrees(rms)
    speed = np.abs(np.diff(joints, axis=0)).max(axis=1) * RATE
    assert speed[mid[1:]].min() > 0.05, "the arm never comes to rest mid-stream"
    np.testing.assert_allclose(joints[-1], signal((n - 1) * GAP), atol=1e-9)


def test_a_new_target_changes_the_next_goal_and_a_reversal_stays_within_the_limits():
    """A target alone at sample 100 (the arm at rest): sample 100 is the first goal that
    changes; a reversal at sample 400, mid-flight, bends the next sample's motion back at
    once and the arm ends on the second target, every step within v, a and j."""
    arm = JERK_ARM
    with arm_at_start() as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], arm.servos)[0]
        far = q0 + np.array([0.8, -0.6, 0.7])
        back = q0 - np.array([0.3, -0.2, 0.2])
        steps = [(0.0995, lambda f: f.target(joints=far)),
                 (0.3995, lambda f: f.target(joints=back)),
                 (0.4005, lambda f: f.end())]
        f, report, wire = run_session(sa, arm, steps)
    assert report.outcome == "done", report.message
    index, joints = _commanded(f, wire, arm)
    moved = np.flatnonzero(np.abs(joints - q0).max(axis=1) > 1e-12)
    assert index[moved[0]] == 100
    vel = np.diff(joints, axis=0) * RATE
    acc = np.diff(vel, axis=0) * RATE
    # before the reversal the arm accelerates toward `far`; from sample 400 toward `back`
    assert (np.sign(vel[398]) == np.sign(far - q0)).all()
    assert (np.sign(acc[399]) == np.sign(back - far)).all()
    _check_limits(joints, arm, np.array([j.max_jerk for j in arm.joints]))
    np.testing.assert_allclose(joints[-1], back, atol=1e-9)


def test_a_pose_stream_goes_through_the_branch_continuous_ik():
    """Poses on a circle at 30 Hz: the commanded tool follows the circle one target period
    behind (position within 1 mm after the lag) and ends on the last pose."""
    arm = ARM3R
    with arm_at_start() as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], arm.servos)[0]
        start = kinematics.fk(arm.links, q0[None])[0]
        r, w = 0.03, 2 * math.pi * 0.5

        def pose(t):
            return (start[0] + r * (math.cos(w * t) - 1), start[1] + r * math.sin(w * t),
                    start[2])
        n = 60
        steps = [(k * GAP, lambda f, k=k: f.target(pose=pose(k * GAP))) for k in range(n)]
        steps.append((n * GAP, lambda f: f.end()))
        f, report, wire = run_session(sa, arm, steps, space="pose")
    assert report.outcome == "done", report.message
    index, joints = _commanded(f, wire, arm)
    _check_limits(joints, arm)
    tool = kinematics.fk(arm.links, joints)
    times = index * T
    mid = (times > 0.3) & (times < (n - 3) * GAP)
    want = np.array([pose(t - GAP) for t in times[mid]])
    assert np.abs(tool[mid, :2] - want[:, :2]).max() < 1e-3
    np.testing.assert_allclose(tool[-1], pose((n - 1) * GAP), atol=1e-6)


@pytest.mark.filterwarnings("ignore::robodcn.stream.RateWarning")  # virtual time: no skips
def test_an_omx_joint_stream_keeps_its_limits():
    """The omx (4 joints, torque limits checked with the payload): a 30 Hz stream, within
    v and a, ending on its last target."""
    with simulated_arm(OMX, timing="fast", dynamics=False) as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], OMX.servos)[0]
        signal = _smooth_stream(OMX, q0, share=0.3)
        n = 45
        steps = [(k * GAP, lambda f, k=k: f.target(joints=signal(k * GAP)))
                 for k in range(n)]
        steps.append((n * GAP, lambda f: f.end()))
        f, report, wire = run_session(sa, OMX, steps, payload_kg=0.1)
    assert report.outcome == "done", report.message
    _index, joints = _commanded(f, wire, OMX)
    _check_limits(joints, OMX)
    np.testing.assert_allclose(joints[-1], signal((n - 1) * GAP), atol=1e-9)


# -- ending ---------------------------------------------------------------------------------

def test_the_deadman_stops_smoothly_when_no_target_comes_while_moving():
    """timeout_s = 0.2: a far target, then none: 0.2 s after it the arm brakes to rest
    within the limits, short of the target, and the report says stopped, naming
    timeout_s."""
    arm = JERK_ARM
    with arm_at_start() as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], arm.servos)[0]
        far = q0 + np.array([0.8, 0.6, 0.9])
        f, report, wire = run_session(sa, arm, [(0.05, lambda f: f.target(joints=far))],
                                      timeout_s=0.2)
    assert report.stop_reason == "stopped" and report.outcome == "stopped"
    assert "timeout_s" in report.message
    index, joints = _commanded(f, wire, arm)
    _check_limits(joints, arm, np.array([j.max_jerk for j in arm.joints]))
    # the first sample whose step is shorter than the one before (steps k, k + 1 of the
    # second difference at k end at sample k + 2): not before 0.05 + 0.2 s
    braking = np.flatnonzero(np.diff(np.abs(np.diff(joints[:, 0]))) < 0)
    assert index[braking[0]] + 2 > 250
    assert np.abs(joints[-1] - far).max() > 0.1, "stopped short of the target"
    assert np.abs(f.generator.state[1]).max() < 1e-9, "the last sample is at rest"
    assert np.abs(np.diff(joints[-2:], axis=0)).max() < 1e-6


def test_the_deadman_leaves_a_session_at_rest_alone():
    """No target for longer than timeout_s while the arm rests on its target: the session
    goes on (nothing to stop) until it is ended."""
    with arm_at_start() as sa:
        status = {}
        _f, report, _ = run_session(
            sa, ARM3R, [(0.5, lambda f: status.setdefault("at", f.status)),
                        (0.5, lambda f: f.end())], timeout_s=0.1)
    assert status["at"] == "following"
    assert report.outcome == "done"


def test_a_smooth_stop_brakes_to_rest_and_reports_stopped():
    arm = JERK_ARM
    with arm_at_start() as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], arm.servos)[0]
        far = q0 + np.array([0.8, 0.6, 0.9])
        f, report, wire = run_session(sa, arm, [(0.0, lambda f: f.target(joints=far)),
                                                (0.2, lambda f: f.stop())])
    assert report.stop_reason == "stopped" and "stopped smoothly" in report.message
    _index, joints = _commanded(f, wire, arm)
    _check_limits(joints, arm, np.array([j.max_jerk for j in arm.joints]))
    assert np.abs(joints[-1] - far).max() > 0.1
    with pytest.raises(NoMoveError):
        f.target(joints=far)


def test_a_hold_stop_holds_at_once():
    with arm_at_start() as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], ARM3R.servos)[0]
        _f, report, _ = run_session(
            sa, ARM3R, [(0.0, lambda f: f.target(joints=q0 + 1.0)),
                        (0.1, lambda f: f.stop("hold"))])
    assert report.stop_reason == "stopped" and report.samples_sent <= 102


# -- bad targets ----------------------------------------------------------------------------

def test_bad_targets_are_refused_by_name_and_the_arm_goes_on_to_the_last_good_one():
    """Joints beyond a limit, the wrong count, NaN, a pose in a joints session, a bad
    velocity: InputError naming the field; the session goes on to the previous target."""
    arm = ARM3R
    errors = []

    def bad(**kw):
        def op(f):
            with pytest.raises(InputError) as exc:
                f.target(**kw)
            errors.append(exc.value)
        return op
    with arm_at_start() as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], arm.servos)[0]
        good = q0 + np.array([0.2, -0.1, 0.1])
        beyond = good.copy()
        beyond[1] = math.radians(175.0)
        steps = [(0.0, lambda f: f.target(joints=good)),
                 (0.05, bad(joints=beyond)), (0.06, bad(joints=[0.1, 0.2])),
                 (0.07, bad(joints=[math.nan, 0.0, 0.0])),
                 (0.08, bad(pose=(0.2, 0.1, 0.0))),
                 (0.09, bad(joints=good, velocity=[1.0])),
                 (0.1, lambda f: f.end())]
        f, report, wire = run_session(sa, arm, steps)
    fields = [e.field for e in errors]
    assert fields == ["joints", "joints", "joints", "pose", "velocity"]
    assert "175.0°" in str(errors[0]) and arm.joints[1].name in str(errors[0])
    assert f.taken == 1 and f.refused == 5
    _, joints = _commanded(f, wire, arm)
    np.testing.assert_allclose(joints[-1], good, atol=1e-9)
    assert report.outcome == "done"


def test_an_unreachable_pose_is_refused_naming_pose():
    with arm_at_start() as sa:
        errors = []

        def op(f):
            with pytest.raises(InputError) as exc:
                f.target(pose=(2.0, 0.0, 0.0))
            errors.append(exc.value)
        _, report, _ = run_session(sa, ARM3R, [(0.01, op), (0.02, lambda f: f.end())],
                                   space="pose")
    assert errors[0].field == "pose" and "out of reach" in str(errors[0])
    assert report.outcome == "done"


def test_session_arguments_are_checked_before_any_write():
    with arm_at_start() as sa:
        for kw, field in [({"space": "cartesian"}, "space"), ({"timeout_s": -1}, "timeout_s"),
                          ({"tracking_limit": -1.0}, "tracking_limit")]:
            with pytest.raises(InputError) as exc:
                follow(sa.bus, ARM3R, rate_hz=RATE, **kw).wait(10)
            assert exc.value.field == field


def test_the_session_s_record_is_its_commanded_samples():
    with arm_at_start() as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], ARM3R.servos)[0]
        f, _, _ = run_session(sa, ARM3R, [(0.0, lambda f: f.target(joints=q0 + 0.2)),
                                          (0.01, lambda f: f.end())])
    traj = f.commanded()
    assert traj.joints.shape == (f.source.made, 3)
    np.testing.assert_allclose(traj.poses, user_pose(ARM3R, traj.joints))
    np.testing.assert_allclose(traj.joints[-1], q0 + 0.2, atol=1e-9)


def _physics_session(compensation):
    """A 30 Hz ramp of 10 targets on the physics sim (lockstep virtual time), ended at rest:
    the follower, its report, the last target and the servos' final ticks."""
    from conftest import lockstep_arm

    with lockstep_arm(ARM3R, timing="fast") as (sa, clock):
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], ARM3R.servos)[0]
        goal = q0 + np.array([0.4, -0.3, 0.35])
        clock.hold(0.0)
        f = follow(sa.bus, ARM3R, rate_hz=100.0, clock=clock, watchdog_ms=0,
                   skip_late=False, compensation=compensation)
        try:
            assert clock.wait_parked(), f.error
            t0 = f.stream.t_start
            for k in range(1, 11):
                clock.hold(t0 + k * GAP)
                assert clock.wait_parked(), f.error
                f.target(joints=q0 + (goal - q0) * k / 10)
            f.end()
        finally:
            clock.release()
        report = f.wait(60)
    return f, report, goal


def test_with_compensation_goals_are_led_and_the_arm_ends_nearer_its_target():
    """The physics sim (servos with a P loop, friction, the arm's masses) on virtual time:
    with tracking compensation each goal is led like a planned move's (every led goal
    within v_max·T + 1 tick of the one before), and the arm comes to rest nearer its last
    target than the same session uncompensated (whose position loop stalls short of it)."""
    led, report, goal = _physics_session(True)
    plain, plain_report, _ = _physics_session(False)
    src = led.source
    assert src.compensated and not plain.source.compensated
    assert report.stop_reason == "completed" and plain_report.stop_reason == "completed"
    assert not np.array_equal(src.commanded[:src.made], src.ticks[:src.made])
    np.testing.assert_array_equal(plain.source.commanded[:plain.source.made],
                                  plain.source.ticks[:plain.source.made])
    np.testing.assert_allclose(src.joints[src.made - 1], goal, atol=1e-9)
    steps = np.abs(np.diff(src.commanded[:src.made], axis=0))
    delta = np.array([j.max_velocity for j in ARM3R.joints]) / 100.0 / (2 * math.pi / 4096)
    assert (steps <= delta + 1).all(), "every led goal within v_max·T (+1 tick) of the last"
    led_miss = np.abs(report.final_error_ticks).sum()
    plain_miss = np.abs(plain_report.final_error_ticks).sum()
    assert led_miss < plain_miss, (report.final_error_ticks, plain_report.final_error_ticks)


def test_pause_resume_and_speed_are_generator_inputs():
    """pause: brake to rest and stay (targets refused meanwhile); resume: on to the last
    target; set_speed(0.5): the limits v·k, a·k² from then on; every step within the
    limits and the session ends on its target."""
    arm = ARM3R
    refused = []

    def paused_target(f):
        with pytest.raises(NoMoveError) as exc:
            f.target(joints=f.targets.last.joints)
        refused.append(exc.value)
    with arm_at_start() as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], arm.servos)[0]
        far = q0 + np.array([0.9, 0.7, 0.9])
        steps = [(0.0, lambda f: f.target(joints=far)), (0.15, lambda f: f.pause()),
                 (0.5, paused_target), (0.5, lambda f: f.resume()),
                 (0.5, lambda f: f.set_speed(0.5)), (0.51, lambda f: f.end())]
        f, report, wire = run_session(sa, arm, steps)
    assert report.outcome == "done", report.message
    assert refused and "paused" in str(refused[0])
    index, joints = _commanded(f, wire, arm)
    _check_limits(joints, arm)
    vel = np.abs(np.diff(joints, axis=0)) * RATE
    v, _ = _limits(arm)
    at_rest = (index[1:] > 400) & (index[1:] < 500)
    assert vel[at_rest].max() < 1e-9, "paused: at rest until the resume"
    after = index[1:] > 520
    assert (vel[after] <= 0.5 * v * (1 + SLACK)).all(), "half speed after set_speed(0.5)"
    assert vel[after].max() > 0.4 * v.min()
    np.testing.assert_allclose(joints[-1], far, atol=1e-9)
