"""Online operations on virtual time (:class:`robodcn.stream.VirtualClock`) against
firmware_sim over a pty, through dynamixel-sdk: the loop is held after a known sample while
the operation plans, so what is checked is the operation's logic — which samples go out
after the switch (limits, jerk, the path braked along, the goal reached, the lead of a
compensated tail) — not the host's timing (test_online.py, serial, has those).

Every check reads the goals the simulated servos accepted (``SimBus.goal_history``) and the
commanded joints of the samples sent (``Execution.sent``): the wire must carry exactly the
commanded ticks, and the commanded joints must keep the limits (their finite differences
at the stream rate; the ticks add at most 2 ticks × rate of quantisation to a velocity).
The simulator here is kinematic, so the goals go out uncompensated (``compensation=False``)
but in the compensation test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ARM3R
from online_helpers import (
    RATE,
    SLACK,
    START,
    TICK,
    A,
    J,
    V,
    _braking_distance,
    _check_jerk,
    _check_limits,
    _check_wire_steps,
    _distance_to_polyline,
    _fd,
    _jerk_move,
    _move,
    _run_at,
    _run_steps,
    _sent,
    arm_at_start,
)

from robodcn import kinematics, servo_units
from robodcn.errors import InputError, UnreachableError
from robodcn.stream import VirtualClock, start
from robodcn.stream.online_path import JointPath


@pytest.fixture
def sa():
    with arm_at_start() as s:
        yield s

# -- retarget -------------------------------------------------------------------------------

def _retarget_run(sa, traj, new_goal, at: float = 0.3):
    """Retarget ``traj`` to ``new_goal`` at the fraction ``at`` of it; the wire goals, the
    commanded joints, their ticks and the first changed sample (it completed)."""
    def ops(ex):
        ex.retarget([None, new_goal])

    report, ex, wire = _run_at(sa, traj, int(at * len(traj.t)) + 1, ops)
    assert report.stop_reason == "completed", report.headline
    _index, joints, ticks = _sent(ex, wire)
    return wire, joints, ticks, ex.switches[0][1]


def test_retarget_in_flight_is_smooth_and_ends_at_the_new_goal(sa):
    traj = _move(sa, duration=2.0)
    new_goal = (0.22, -0.05, 0.3)
    wire, joints, ticks, first = _retarget_run(sa, traj, new_goal)
    assert 0 < first < len(traj.t), "the switch came while the old move was running"
    # before the switch: the planned samples, unchanged
    assert np.array_equal(ticks[:first], traj.ticks[:first])
    _check_limits(joints)
    _check_wire_steps(ticks)
    # the arm was moving at the switch (no stop), and the move ends at the new goal
    vel, _ = _fd(joints)
    assert np.abs(vel[first - 1]).max() > 0.05 * V.min()
    end = kinematics.fk(ARM3R.links, joints[-1:])[0]
    assert np.allclose(end[:2], new_goal[:2], atol=1e-6)
    assert math.isclose(kinematics.wrap(end[2] - new_goal[2]), 0.0, abs_tol=1e-6)
    assert np.array_equal(wire[-1], ticks[-1])


def test_retarget_back_the_way_it_came_brakes_along_the_path_first(sa):
    """A goal behind the arm cannot be turned towards at full speed: the limits hold."""
    traj = _move(sa)

    def ops(ex):
        ex.retarget([None, START])

    _report, ex, wire = _run_at(sa, traj, int(0.5 * len(traj.t)) + 1, ops)
    _, joints, ticks = _sent(ex, wire)
    _check_limits(joints)
    _check_wire_steps(ticks)
    end = kinematics.fk(ARM3R.links, joints[-1:])[0]
    assert np.allclose(end[:2], START[:2], atol=1e-6)


def test_a_retarget_that_cannot_be_planned_changes_nothing(sa):
    traj = _move(sa)

    def ops(ex):
        with pytest.raises(UnreachableError):
            ex.retarget([None, (2.0, 2.0, 0.0)])

    report, ex, wire = _run_at(sa, traj, 100 + 1, ops)
    _, _, ticks = _sent(ex, wire)
    assert report.outcome == "done"
    assert np.array_equal(ticks, traj.ticks)


# -- smooth stop ----------------------------------------------------------------------------

def test_smooth_stop_decelerates_along_the_path_within_the_limits(sa):
    traj = _move(sa)

    def ops(ex):
        ex.stop("smooth")

    report, ex, wire = _run_at(sa, traj, int(0.45 * len(traj.t)) + 1, ops)
    assert report.stop_reason == "stopped" and report.outcome == "stopped"
    assert report.hold_goals is None, "a smooth stop ends on its last goal, no hold jump"
    _, joints, ticks = _sent(ex, wire)
    first = ex.switches[0][1]
    assert len(ticks) < len(traj.t), "it stopped before the end"
    _check_limits(joints)
    _check_wire_steps(ticks)
    # every goal sent lies on the planned joint path (IK rounding ½ tick + one tick)
    off = _distance_to_polyline(servo_units.ticks_to_radians(ticks[first:], ARM3R.servos),
                                 traj.joints)
    assert (off <= 1.5 * TICK + 1e-9).all(), off.max(0) / TICK
    # stopping distance ≤ time-optimal braking distance + one period of travel
    path, sigma = JointPath.of_samples(traj.joints)
    s0 = sigma[first - 1]
    sd0 = (sigma[first - 1] - sigma[first - 2]) * RATE
    travelled = float(np.sum(np.linalg.norm(np.diff(joints[first - 1:], axis=0), axis=1)))
    assert sd0 > 0.5
    assert travelled <= _braking_distance(path, s0, sd0) + sd0 / RATE


def test_hold_stop_holds_at_once(sa):
    traj = _move(sa)

    def ops(ex):
        ex.stop("hold")

    report, ex, _wire = _run_at(sa, traj, 200 + 1, ops)
    assert report.stop_reason == "stopped" and report.hold_goals is not None
    assert report.samples_sent < 0.6 * len(traj.t)
    assert not ex.switches


def test_stop_mode_is_checked(sa):
    traj = _move(sa)
    ex = start(traj, sa.bus)
    try:
        with pytest.raises(InputError) as info:
            ex.stop("sudden")
        assert info.value.field == "mode"
    finally:
        ex.stop("hold")
        ex.wait(10)


# -- pause / resume, speed ------------------------------------------------------------------

@pytest.mark.parametrize("at", [5, 100, 180], ids=["near-rest", "fast", "faster"])
def test_speed_scaling_keeps_the_scaled_limits(sa, at):
    """Over k's limits only while braking along the path (full limits) from the switch, and
    only as long as the brake goes: it ends where the scaled law takes over, which may be
    below k's joint velocities (the brake aims under the scaled controllable speed, and
    brakes again where that fell meanwhile; it failed with "cannot re-time the path" before).
    (A set_speed that lands late on a loaded host meets a fast arm:
    the brake's boundary is the brake's end, not the first sample within V·k.)"""
    traj = _move(sa)
    k = 0.5

    def ops(ex):
        ex.set_speed(k)
        assert ex.speed == k

    report, ex, wire = _run_at(sa, traj, at + 1, ops)
    assert report.outcome == "done", (report.headline, report.stop_reason, report.message)
    # (the move's own braking to its end starts near sample 300 of its 469: 180 + a loaded
    # host's delay still lands before it)
    assert ex.switches, "the speed change was applied"
    _, joints, ticks = _sent(ex, wire)
    first = ex.switches[0][1]
    _check_limits(joints)
    vel, acc = _fd(joints)
    over = np.flatnonzero((np.abs(acc[first - 1:]) > A * k * k * (1 + SLACK)).any(axis=1))
    within = int(over.max()) + first + 1 if over.size else first
    speed = np.linalg.norm(vel, axis=1)
    assert (np.diff(speed[first - 1:within]) <= 1e-9).all(), "a brake: the speed only falls"
    assert (np.abs(vel[within - 1]) <= V * k * (1 + SLACK)).all()
    _check_limits(joints[within - 1:], V * k, A * k * k)
    _check_wire_steps(ticks)
    assert np.array_equal(ticks[-1], traj.ticks[-1])
    assert len(ticks) > len(traj.t) + 0.25 * (len(traj.t) - first), "slower"


def test_speed_scaling_a_slower_fixed_duration_plan_slows_it_by_k(sa):
    """A 2 s plan (slower than the limits allow) at k = 0.5 takes about twice its remaining
    time and is never faster than 0.5 × its own speed at the same point of the path, once it
    has slowed down to it (re-timing it time-optimally under the scaled limits made it
    faster, 1401 → 713 ms)."""
    traj = _move(sa, duration=2.0)
    k = 0.5

    def ops(ex):
        ex.set_speed(k)

    report, ex, wire = _run_at(sa, traj, int(0.3 * len(traj.t)) + 1, ops)
    assert report.outcome == "done", report.headline
    _, joints, ticks = _sent(ex, wire)
    _check_limits(joints)
    first = ex.switches[0][1]
    left, now = len(traj.t) - first, len(ticks) - first
    assert 1.8 * left <= now <= 2.3 * left, (left, now)
    # speed along the path against the plan's at the same arc length
    _, sigma = JointPath.of_samples(traj.joints)
    plan_speed = np.diff(sigma) * RATE
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(joints, axis=0), axis=1))])
    speed = np.diff(arc) * RATE
    limit = k * np.interp(arc[1:], 0.5 * (sigma[1:] + sigma[:-1]), plan_speed)
    slowed = first + int(np.argmax(speed[first:] <= limit[first:] * 1.01))
    assert (speed[slowed:] <= limit[slowed:] * 1.01 + 1e-3).all()
    assert np.array_equal(ticks[-1], traj.ticks[-1])


def test_speed_scaling_while_the_move_brakes_to_its_end_lets_it_end_as_planned(sa):
    """Where the plan already brakes to its end at the full limits, no law under k's limits
    reaches the end from the present speed (a brake to them runs past it): no error, no
    swap, every planned goal sent."""
    traj = _move(sa)

    def ops(ex):
        ex.set_speed(0.5)
        assert ex.speed == 0.5

    report, ex, wire = _run_at(sa, traj, len(traj.t) - 100 + 1, ops)
    assert report.outcome == "done" and not ex.switches, report.headline
    _, _, ticks = _sent(ex, wire)
    assert np.array_equal(ticks, traj.ticks)


def test_speed_scale_out_of_range_names_scale(sa):
    traj = _move(sa)
    ex = start(traj, sa.bus)
    try:
        for bad in (0.0, 1.5, -1, float("nan"), True):
            with pytest.raises(InputError) as info:
                ex.set_speed(bad)
            assert info.value.field == "scale"
    finally:
        ex.stop("hold")
        ex.wait(10)


def test_with_compensation_a_retarget_tail_is_led_like_the_plan(sa):
    """The tail's goals are the compensated goals of its joints, led like the plan's: the
    plan from the goal the servos held before the stream, the tail from the goal sent
    before the switch (its first goal within one step v_max·T of it), not its bare ticks:
    without the lead the goals would jump back by the lag."""
    from robodcn.stream.compensation import compensated_ticks, max_steps
    from robodcn.stream.online.samples import LEAD_HISTORY
    from robodcn.stream.source import servo_state

    traj = _move(sa, duration=2.0)
    held = servo_state(sa.bus)[0]

    def ops(ex):
        ex.retarget([None, (0.22, -0.05, 0.3)])

    report, ex, wire = _run_at(sa, traj, int(0.3 * len(traj.t)) + 1, ops, compensation=True)
    assert report.stop_reason == "completed" and report.compensation, report.headline
    _index, _, joints = ex.sent()
    first = ex.switches[0][1]
    kw = dict(arm=ARM3R, p_gains=sa.bus.position_p_gains)
    plan = compensated_ticks(traj.joints, 1.0 / RATE, sa.bus.servos, sa.bus.limits,
                             start_goal=held, **kw)
    # (led across the switch: the samples before it give the differences there)
    k = LEAD_HISTORY
    led = compensated_ticks(joints[first - k:], 1.0 / RATE, sa.bus.servos, sa.bus.limits,
                            start_goal=wire[first - 1], first=k, **kw)[k:]
    bare = servo_units.radians_to_ticks(joints, ARM3R.servos)
    tail = slice(first, len(joints))
    # the lead is large while moving fast: the bare ticks are far from the wire there
    assert np.abs(wire[tail] - bare[tail]).max() > 10
    # before the switch the plan's goals, led from the goal held; after it the tail's,
    # led from the goal sent last
    assert np.array_equal(wire[:first], plan[:first])
    assert np.array_equal(wire[tail], led)
    # so the tail's own goals (the source's, before the loop's step guard) step no further
    # than v_max·T (+ a tick of rounding) across the switch: the guard slews nothing there
    step = max_steps(ARM3R, sa.bus.servos, 1.0 / RATE, len(ARM3R.servos))
    src = ex.stream.source
    own = np.array([src.sent_goal(i) for i in range(first - 3, first + 10)])
    around = np.abs(np.diff(own, axis=0))
    assert (around <= np.floor(step) + 1).all(), around


def test_a_led_tail_starts_within_a_step_of_the_goal_before_it_and_ends_on_its_own(sa):
    """A compensated tail is led from the goal sent before its switch (its first goal
    within v_max·T of it), across the switch (the samples before it give the differences);
    one too short to ramp from there to its own last goal is led without that start, so it
    still ends on its last goal (the step guard slews) — unless it is an operation's last
    segment (``settle``, at rest: tests/test_online_lead_ramp.py lengthens it instead)."""
    from robodcn.stream.compensation import max_steps
    from robodcn.stream.online import OnlineSamples
    from robodcn.stream.online.samples import LEAD_HISTORY
    from robodcn.stream.source import PlannedSamples

    traj = _move(sa, duration=1.0)
    planned = PlannedSamples(traj, sa.bus, compensation=True)
    root = OnlineSamples.of_planned(planned, sa.bus)
    step = max_steps(ARM3R, sa.bus.servos, 1.0 / RATE, len(ARM3R.servos))
    switch = len(traj.t) // 2
    before = root.sent_goal(switch - 1)
    back = traj.joints[switch::-1]                  # back the way it came, from the switch
    path, sigma = JointPath.of_samples(back)
    node = OnlineSamples(root, switch, back, sigma, path, sa.bus, RATE, traj.joint_names)
    assert (np.abs(node.sent_goal(switch) - before) <= np.ceil(step)).all()
    k = LEAD_HISTORY
    history = traj.joints[switch - k:switch]
    own = planned.commanded_for(np.vstack([history, back]), first=k)
    assert np.array_equal(node.sent_goal(len(node) - 1), own[-1])
    # three samples at rest where the arm is, at speed: their rest goal lacks the lead of
    # the motion the goal before carries, further than three steps from it
    short = np.repeat(traj.joints[switch:switch + 1], 3, axis=0)
    path, sigma = JointPath.of_samples(np.vstack([short, short]))
    node = OnlineSamples(root, switch, short, sigma[:3], path, sa.bus, RATE, traj.joint_names)
    own = planned.commanded_for(np.vstack([history, short]), first=k)
    assert np.array_equal(node.sent_goal(len(node) - 1), own[-1])
    assert (np.abs(own[-1] - before) > 3 * step).any()
    assert (np.abs(node.sent_goal(switch) - before) > 2 * step).any()


def test_a_late_read_compares_with_the_swapped_source_past_the_plans_end(sa):
    """The tracking reference of a read that lands late is the swapped source's goal there,
    also past the planned trajectory's own samples (it indexed the tail node's own ticks
    with the stream's sample index before: wrong goals, or an IndexError)."""
    from robodcn.stream.feedback import CommFailures, Feedback
    from robodcn.stream.loop import Stream
    from robodcn.stream.online import OnlineSamples
    from robodcn.stream.options import ExecutionOptions
    from robodcn.stream.source import PlannedSamples

    traj = _move(sa, duration=0.5)
    clock = VirtualClock()
    opts = ExecutionOptions(clock=clock)
    failures = CommFailures(sa.bus, opts.max_comm_failures)
    feedback = Feedback(sa.bus, opts, traj, failures, clock, len(traj.t))
    stream = Stream(PlannedSamples(traj, sa.bus), sa.bus, opts, feedback, failures)
    root = OnlineSamples.of_trajectory(traj, sa.bus)
    back = traj.joints[::-1]            # a tail longer than the rest of the plan
    tail = np.vstack([back, back[::-1]])
    path, sigma = JointPath.of_samples(tail)
    switch = len(traj.t) // 2
    node = OnlineSamples(root, switch, tail, sigma, path, sa.bus, RATE, traj.joint_names)
    stream.swap(node)
    assert len(node) > len(traj.t) + len(tail) // 4
    late = len(node) - 3 + 0.5          # the read lands half-way between two late samples
    stream.t_start = 0.0
    clock.advance(late / RATE)
    ref = feedback.plan_at_read(stream, 10, node.goal(10))
    expected = (node.goal(len(node) - 3) + node.goal(len(node) - 2)) / 2.0
    np.testing.assert_allclose(ref, expected)


# -- jerk limits: every online law keeps them, across every switch ------------------------

def test_jerk_limited_smooth_stop_brakes_along_the_path_within_every_limit(sa):
    # a 2 s move: the stop lands while it moves whatever the planning and the host take
    traj = _jerk_move(sa, duration=2.0)
    _check_jerk(traj.joints)  # the plan itself (profile "optimal", stretched) keeps them

    def ops(ex):
        ex.stop("smooth")

    report, ex, wire = _run_at(sa, traj, int(0.4 * len(traj.t)) + 1, ops)
    assert report.stop_reason == "stopped" and report.hold_goals is None, report.headline
    _, joints, ticks = _sent(ex, wire)
    first = ex.switches[0][1]
    # before the end of the path (a jerk-limited brake from full speed may take longer in
    # time than the plan's own way to its end, never as far)
    arc = np.linalg.norm(np.diff(joints, axis=0), axis=1).sum()
    assert arc < 0.9 * np.linalg.norm(np.diff(traj.joints, axis=0), axis=1).sum()
    _check_jerk(joints)
    assert np.array_equal(ticks[:first], traj.ticks[:first])
    off = _distance_to_polyline(servo_units.ticks_to_radians(ticks[first:], ARM3R.servos),
                                 traj.joints)
    assert (off <= 1.5 * TICK + 1e-9).all(), off.max(0) / TICK
    vel, _ = _fd(joints)
    assert np.abs(vel[first - 1]).max() > 0.1 * V.min(), "it was moving at the switch"


@pytest.mark.parametrize("at", [0.2, 0.45], ids=["accelerating", "cruising"])
def test_jerk_limited_speed_change_in_motion_keeps_every_limit(sa, at):
    traj = _jerk_move(sa, duration=2.0)  # room for the switch (placed ≈ 0.15 s ahead)

    def ops(ex):
        ex.set_speed(0.5)

    report, ex, wire = _run_at(sa, traj, int(at * len(traj.t)) + 1, ops)
    assert report.outcome == "done", report.headline
    assert ex.switches, "the speed change was applied"
    _, joints, ticks = _sent(ex, wire)
    _check_jerk(joints)
    assert np.array_equal(ticks[-1], traj.ticks[-1])
    assert len(ticks) > len(traj.t), "slower"


def test_jerk_limited_pause_resume_and_speed_scaling_keep_every_limit(sa):
    """Paused at 30 % of a jerk-limited move, held for 0.5 s of the schedule, resumed at
    k = 0.5 (set while paused): every limit holds throughout and k's limits after the
    resume; it stands still in between and ends at the plan's goal. On virtual time: the
    schedule's logic, not the host's (a host stall past the Bus Watchdog stops the arm,
    as it must, and is no finding about pause or resume)."""
    traj = _jerk_move(sa, duration=2.0)
    k = 0.5
    paused_at = int(0.3 * len(traj.t)) + 1

    def pause(ex):
        ex.pause()
        assert ex.paused

    def speed_and_resume(ex):
        assert ex.paused and not ex.done
        ex.set_speed(k)        # while paused: taken by the resume
        ex.resume()
        assert not ex.paused and ex.speed == k

    report, ex, wire = _run_steps(sa, traj, [(paused_at, pause),
                                             (paused_at + int(0.5 * RATE), speed_and_resume)])
    assert report.outcome == "done", report.headline
    _, joints, ticks = _sent(ex, wire)
    _check_jerk(joints)
    resumed = ex.switches[1][1]
    _check_jerk(joints[resumed - 3:], V * k, A * k * k, J * k ** 3)
    assert np.array_equal(ticks[-1], traj.ticks[-1])
    still = np.all(np.diff(ticks, axis=0) == 0, axis=1)
    runs = np.diff(np.flatnonzero(np.diff(np.concatenate([[0], still, [0]]))))[::2]
    assert runs.max() >= 0.4 * RATE


def test_jerk_limited_retarget_brakes_to_rest_then_leaves_within_every_limit(sa):
    # a 2 s move: the switch lands while it moves whatever the planning takes (≈ 0.1 s)
    traj = _jerk_move(sa, duration=2.0)
    new_goal = (0.22, -0.05, 0.3)
    _wire, joints, ticks, first = _retarget_run(sa, traj, new_goal)
    assert np.array_equal(ticks[:first], traj.ticks[:first])
    _check_jerk(joints)
    # under jerk limits it brakes to rest along the present path, then leaves from there
    vel, _ = _fd(joints)
    speed = np.linalg.norm(vel, axis=1)
    assert speed[first - 1] > 0.2 * V.min(), "it was moving at the switch"
    rest = first + int(np.argmax(speed[first:] < 1e-6))
    off = _distance_to_polyline(servo_units.ticks_to_radians(ticks[first:rest], ARM3R.servos),
                                 traj.joints)
    assert (off <= 1.5 * TICK + 1e-9).all(), "braked along the present path"
    end = kinematics.fk(ARM3R.links, joints[-1:])[0]
    assert np.allclose(end[:2], new_goal[:2], atol=1e-6)


# -- where switches are placed from ----------------------------------------------------------

def test_the_first_changed_sample_is_due_the_expected_planning_time_plus_two_periods(sa):
    """Request → first changed goal (issue 10 §2): held at a known sample, each retarget
    places its first changed sample ⌈planning time expected × rate⌉ + 2 samples after the
    one in progress: due the expected planning time + 1.5–2.5 periods after the request
    (the request comes halfway through a period). The wall-clock latency on firmware_sim is
    measured by ``make bench`` (bench_online: due − planning against the same rule)."""
    traj = _move(sa, duration=3.0)
    goals = [(0.2, 0.15, 0.2), (0.15, 0.2, 0.5), (0.1, 0.22, 0.9), (0.05, 0.25, 1.2)]
    at = [200 + 60 * k for k in range(len(goals))]

    def retarget(goal):
        def op(ex):
            if not ex.switches:  # placed from a known expectation: 10 ms
                ex.planning_times.set("retarget", False, [0.01])
            ex.retarget([None, goal])
        return op

    report, ex, _wire = _run_steps(sa, traj, [(a, retarget(g))
                                              for a, g in zip(at, goals, strict=True)])
    assert report.outcome == "done", report.headline
    assert len(ex.switches) == len(goals)
    for a, (_requested, first, due, _took, ahead) in zip(at, ex.switches, strict=True):
        assert first == a + 1 + math.ceil(ahead * RATE), (a, first, ahead)
        asked = ex.stream.t_start + (a - 0.5) / RATE  # the held clock when it was asked
        assert ahead + 1.5 / RATE - 1e-9 <= due - asked <= ahead + 2.5 / RATE + 1e-9


def test_planning_times_start_from_a_guess_and_follow_the_measurements():
    from robodcn.stream import PlanningTimes

    times = PlanningTimes()
    assert times.expected("retarget", False) == 0.01          # the first guess
    assert times.expected("retarget", True) == 0.12           # jerk-limited laws: longer
    times.record("retarget", False, 0.004)
    times.record("retarget", False, 0.02)
    assert times.expected("retarget", False) == 0.004         # optimistic: the fastest
    for took in (0.03, 0.03, 0.03, 0.03):                     # the guess and 0.004 drop out
        times.record("retarget", False, took)
    assert times.times("retarget", False) == [0.02, 0.03, 0.03, 0.03, 0.03]
    times.record("pause", True, 0.01)
    times.record("pause", True, 0.05)
    assert times.expected("pause", True) == 0.05               # jerk: the slowest kept
    assert times.expected("pause", False) == 0.003             # another kind of arm


def test_a_shared_planning_times_places_the_next_executions_switches(sa):
    """One PlanningTimes passed to every execution (as a service does): what one measured,
    the next places its first switch from."""
    from robodcn.stream import PlanningTimes

    shared = PlanningTimes()
    traj = _move(sa, duration=1.0)
    _report, ex, _wire = _run_at(sa, traj, 300, lambda ex: ex.retarget([None, (0.22, -0.05, 0.3)]),
                                 planning_times=shared)
    assert ex.planning_times is shared and shared.warmed
    measured = shared.times("retarget", False)
    assert len(measured) == 2                                  # the guess and this one
    again = _move(sa, duration=1.0)
    _report, ex2, _wire = _run_at(sa, again, 300, lambda ex: ex.retarget([None, START]),
                                  planning_times=shared)
    placed_for = ex2.switches[0][4]
    assert placed_for == min(measured)
