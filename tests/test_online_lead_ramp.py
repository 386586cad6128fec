"""The compensation lead of an online tail keeps the goal-step bound (issue 17 §7: no goal
step beyond v_max·T), on virtual time against the simulated arm's physics.

A pause (or any tail that ends at rest) a sample or two into a compensated move: the plan's
goals there still ramp in the lead of the move's first acceleration, the brake is a sample
or two long, and its rest goal carries no such lead. Led on its own, the tail was too short
to ramp from the goal sent before the switch to its rest goal within δ = v_max·T a sample,
so it was led without that start: a goal step of up to twice δ, which the loop's step guard
slewed — at full PWM from rest, the current spike a collision check stops on (the stress
test's "collision at sample 3", then the back-off's jump). Now the tail is led across the
switch (the samples before it give the differences) and lengthened by samples at rest until
the ramp fits: every goal the source sends keeps the bound, the guard slews nothing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ARM3R, lockstep_arm
from online_helpers import drive_held

from robodcn import plan, servo_units
from robodcn.stream import start
from robodcn.stream.compensation import max_steps
from robodcn.stream.online import OnlineSamples
from robodcn.stream.online_path import JointPath
from robodcn.stream.source import PlannedSamples

RATE = 100.0
HOME = tuple(ARM3R.home)
#: the largest goal step a write may make: floor(v_max·T) + 1 tick of rounding
ALLOWED = np.floor(max_steps(ARM3R, ARM3R.servos, 1.0 / RATE, len(ARM3R.servos))) + 1
OPTIONS = {"compensation": True, "tracking_limit": math.radians(15.0), "recover": False,
           "watchdog_ms": 0}


def _run(target, at: int, ops):
    """Stream HOME → ``target`` at 100 Hz with compensation on virtual time, hold the loop
    before sample ``at``, run ``ops(execution)``, release; (report, execution, wire goals
    from the goal held before the stream on)."""
    with lockstep_arm(ARM3R) as (sa, clock):
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], ARM3R.servos)[0]
        traj = plan(ARM3R, [HOME, target], rate_hz=RATE, start_joints=q0)
        before = len(sa.sim.goal_history(ARM3R.servo_ids[0]))
        clock.hold(0.0)
        ex = start(traj, sa.bus, clock=clock, arm=ARM3R, **OPTIONS)
        report = drive_held(clock, ex, [(at, ops)], 60)
        wire = np.array([sa.sim.goal_history(i)[max(0, before - 1):]
                         for i in ARM3R.servo_ids]).T
        return report, ex, wire


def _steps(goals: np.ndarray) -> np.ndarray:
    return np.abs(np.diff(np.asarray(goals, dtype=np.int64), axis=0))


@pytest.mark.parametrize("target", [(0.18, 0.12, 0.6), (0.12, 0.24, 1.0)])
@pytest.mark.parametrize("at", [0, 1])
def test_a_pause_at_a_moves_start_steps_no_goal_beyond_the_limit(target, at) -> None:
    report, ex, wire = _run(target, at, lambda ex: ex.pause())
    assert ex.switches, "the pause was placed"
    src = ex.stream.source
    own = np.array([src.sent_goal(i) for i in range(len(src))])
    # the source's own goals (before the loop's step guard) keep the bound ...
    assert (_steps(own) <= ALLOWED).all(), (np.flatnonzero((_steps(own) > ALLOWED).any(1)),
                                            _steps(own).max(0))
    # ... so the guard slews nothing, and no goal on the wire steps further
    assert ex.stream.guard.slewed == 0
    assert (_steps(wire) <= ALLOWED).all(), _steps(wire).max(0)
    assert report.collision is None, report.headline


@pytest.mark.parametrize("at", [0, 1, 2])
def test_a_speed_change_or_resume_at_a_moves_start_steps_no_goal_beyond_the_limit(at) -> None:
    def ops(ex):
        ex.pause()
        ex.set_speed(0.3)
        ex.resume()

    for each in (lambda ex: ex.set_speed(0.3), ops):
        report, ex, wire = _run((0.12, 0.24, 1.0), at, each)
        assert report.stop_reason == "completed", report.headline
        assert ex.stream.guard.slewed == 0
        assert (_steps(wire) <= ALLOWED).all(), _steps(wire).max(0)


def test_a_short_tail_at_rest_is_lengthened_until_its_lead_ramps_within_the_limit() -> None:
    """A tail of one sample far from the goal before it (``settle``: the last segment of
    an operation, at rest): samples at rest on its last joints are added until every step
    from the goal before it to its own last goal is within δ; that last goal is the lead's
    rest goal of those joints."""
    with lockstep_arm(ARM3R) as (sa, _clock):
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], ARM3R.servos)[0]
        traj = plan(ARM3R, [HOME, (0.12, 0.24, 1.0)], rate_hz=RATE, start_joints=q0)
        planned = PlannedSamples(traj, sa.bus, compensation=True)
        root = OnlineSamples.of_planned(planned, sa.bus)
        switch = len(traj.t) // 2
        before = root.sent_goal(switch - 1)
        short = traj.joints[:1]
        path, sigma = JointPath.of_samples(np.vstack([short, short]))
        node = OnlineSamples(root, switch, short, sigma[:1], path, sa.bus, RATE,
                             traj.joint_names, settle=True)
        step = max_steps(ARM3R, sa.bus.servos, 1.0 / RATE, len(ARM3R.servos))
        assert (np.abs(planned.commanded_for(short)[-1] - before) > 2 * step).any()
        assert len(node) - switch > 2, "lengthened by samples at rest"
        assert np.array_equal(node.joints, np.repeat(short, len(node) - switch, axis=0))
        goals = np.array([node.sent_goal(i) for i in range(switch - 1, len(node))])
        assert (_steps(goals) <= np.floor(step) + 1).all(), _steps(goals).max(0)
        # the last goal is the tail's own, led across the switch (the friction sign of the
        # motion before it) without the start's cone
        from robodcn.stream.online.samples import LEAD_HISTORY
        history = traj.joints[switch - LEAD_HISTORY:switch]
        rest = planned.commanded_for(np.vstack([history, node.joints]), first=LEAD_HISTORY)
        assert np.array_equal(goals[-1], rest[-1])
