"""Issue 17 §7: a goal the loop slews after a host stall is not a collision, and a move whose
last goals were slewed ends with the arm on them (virtual time: the loop's logic and the
simulator's physics, the same on a loaded machine as on an idle one)."""

from __future__ import annotations

import math

import numpy as np
from conftest import ARM3R, lockstep_arm
from stream_helpers import Jumping

from robodcn.planner import plan
from robodcn.stream import execute
from robodcn.stream.collision import SLEW_QUIET_S
from robodcn.stream.compensation import max_steps
from robodcn.stream.finish import CATCH_UP_SETTLE_S

MOVE = [(0.25, 0.10, 0.0), (0.12, 0.24, math.radians(60))]


def _run(jump_at, jump: int, **kw):
    traj = plan(ARM3R, MOVE, duration="auto")
    n = len(traj.t)
    at = jump_at(n)

    sources = []

    def swap_in(stream):
        sources.append(Jumping(stream.source, sa.bus, at, jump))
        stream.swap(sources[0])

    with lockstep_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as (sa, clock):
        report = execute(traj, sa.bus, tracking_limit=None, skip_late=False, attach=swap_in,
                         clock=clock, feedback_every=1, **kw)
    return traj, report, sources[0]


def test_a_slewed_goal_is_not_taken_for_a_collision() -> None:
    # a step of 400 ticks on the shoulder mid-move: the loop slews it at the velocity limit
    # for many periods, the servo chases it at full PWM
    traj, report, _ = _run(lambda n: n // 2, 400)
    steps = int(np.ceil(400 / (np.floor(max_steps(ARM3R, ARM3R.servos, 1 / traj.rate_hz,
                                                  3))[0] + 1)))
    assert steps * (1 / traj.rate_hz) < SLEW_QUIET_S * 4  # the quiet spans the chase's reads
    assert report.stop_reason == "completed", report.message
    # the stop is still armed outside the slew: a threshold below the plan's own current
    # (0.01 A) stops the same move as a collision
    _, stopped, _ = _run(lambda n: n // 2, 400, collision_current=[0.01, 0.01, 0.01])
    assert stopped.stop_reason == "collision", stopped.message
    assert stopped.collision["sample"] < len(traj.t) // 2


def test_a_move_ending_on_slewed_goals_settles_on_its_last_goal() -> None:
    # the last sample steps 150 ticks: the loop writes slewed goals after the source's end,
    # and the move's end waits for the arm (settle 0 asked, CATCH_UP_SETTLE_S given)
    _, report, _ = _run(lambda n: n - 1, 150, settle=0.0)
    _, still, _ = _run(lambda n: n - 1, 0, settle=0.0)  # the same move without the step
    assert report.stop_reason == still.stop_reason == "completed", report.message
    assert CATCH_UP_SETTLE_S > 0
    assert report.final_positions is not None and still.final_positions is not None
    arrived = np.asarray(report.final_positions) - np.asarray(still.final_positions)
    # within a P loop's overshoot at speed (without the settle: 10 of the 150 ticks)
    assert np.abs(arrived - [150, 0, 0]).max() <= 8, arrived
