"""The loop's bound on every goal it writes (robodcn.stream.step_guard, issue 17 §7): a source
whose goals step beyond v_max·T is slewed toward at v_max·T (+1 tick) per write, and the
loop writes on after the last sample until the servos' goal is the source's last one."""

from __future__ import annotations

import math

import numpy as np
from conftest import ARM3R, lockstep_arm
from stream_helpers import Jumping

from robodcn.bus.groups import decode_row, encode_rows
from robodcn.planner import plan
from robodcn.stream import execute
from robodcn.stream.compensation import compensated_ticks, max_steps
from robodcn.stream.step_guard import StepGuard

MOVE = [(0.25, 0.10, 0.0), (0.12, 0.24, math.radians(60))]


def test_a_step_within_the_bound_is_written_as_it_is_and_a_larger_one_is_slewed():
    guard = StepGuard([10.0, 10.0, math.inf], start=[100, 100, 100])
    row = encode_rows(np.array([[111, 89, 5000]]))[0]
    assert guard.row(0, row) is row and not guard.behind()  # 11 = 10 + 1 tick of rounding
    jump = encode_rows(np.array([[150, 89, -5000]]))[0]
    assert decode_row(guard.row(1, jump)) == [122, 89, -5000]
    assert guard.behind() and guard.lag() == [28, 0, 0]
    written = [decode_row(guard.catch_up(2 + k)) for k in range(3)]
    assert written == [[133, 89, -5000], [144, 89, -5000], [150, 89, -5000]]
    assert not guard.behind() and guard.lag() is None and guard.slewed == 3


def test_the_loop_slews_a_source_step_and_ends_on_the_source_s_last_goal():
    traj = plan(ARM3R, MOVE, duration="auto")
    rate = traj.rate_hz
    delta = np.floor(max_steps(ARM3R, ARM3R.servos, 1.0 / rate, 3)) + 1
    sources = []

    def swap_in(stream):
        sources.append(Jumping(stream.source, sa.bus, len(traj.t) // 2, 120))
        stream.swap(sources[0])

    # On virtual time (conftest.lockstep_arm): the slewing is the loop's logic; in real time
    # a loaded host sent the late samples in a burst the physics lagged behind and then
    # chased, a current the collision stop took for an obstacle.
    with lockstep_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as (sa, clock):
        since = {i: len(sa.sim.goal_history(i)) for i in ARM3R.servo_ids}
        report = execute(traj, sa.bus, tracking_limit=None, skip_late=False, settle=0.3,
                         attach=swap_in, clock=clock)
        history = [np.array(sa.sim.goal_history(i)[since[i] - 1:]) for i in ARM3R.servo_ids]
    assert report.stop_reason == "completed", report.message
    for j, h in enumerate(history):
        assert np.abs(np.diff(h)).max() <= delta[j], (j, np.abs(np.diff(h)).max(), delta[j])
    # the step was there to slew (120 ticks is several periods' worth) ...
    assert 120 > 3 * delta[0]
    # ... and the move still ends on the source's last goal
    assert [int(h[-1]) for h in history] == list(sources[0].sent[-1])


def test_a_tail_led_from_the_goal_before_its_switch_starts_within_the_bound():
    """compensated_ticks(first=m): rows before m only give the differences; the step into
    row m is limited from ``start_goal`` (an online tail led from the goal last sent)."""
    traj = plan(ARM3R, MOVE, duration="auto")
    period = 1.0 / traj.rate_hz
    servos, limits = ARM3R.servos, np.array([[0, 4095]] * 3)
    whole = compensated_ticks(traj.joints, period, servos, limits, arm=ARM3R)
    mid = len(traj.t) // 2
    held = whole[mid - 1] + np.array([60, -60, 0])       # a goal far from the tail's lead
    tail = compensated_ticks(traj.joints[mid - 2:], period, servos, limits, arm=ARM3R,
                             start_goal=held, first=2)
    delta = max_steps(ARM3R, servos, period, 3)
    assert (np.abs(tail[2] - held) <= np.ceil(delta)).all(), (tail[2], held, delta)
    assert np.abs(tail[1] - held).max() >= 59             # row 1 is led, not limited
    assert (np.abs(np.diff(tail[2:], axis=0)) <= np.ceil(delta)).all()
    assert (tail[-1] == whole[-1]).all()                  # it still ends on the rest goal
