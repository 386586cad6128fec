"""Retarget semantics (issue 17 §2) on the wire: firmware_sim over a pty on virtual time.

A replacement leaves from the commanded moving state and never visits its first waypoint
(the caller's view of where the arm is, as with a new trajectory sent to ROS's
joint_trajectory_controller): no stop and no turning back unless the goal lies behind. One
waypoint is the goal from the present state. The plan fields are honoured (``duration``
from the switch) or refused naming the field; the new move's counts are its own.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ARM3R
from online_helpers import (
    RATE,
    START,
    V,
    _check_limits,
    _check_wire_steps,
    _fd,
    _move,
    _run_at,
    _sent,
    arm_at_start,
)

from robodcn import kinematics, plan
from robodcn.errors import InputError
from robodcn.planner import PlanRequest

#: a goal a little off the running move's (START → GOAL), ahead of the arm
AHEAD = (0.07, 0.24, math.radians(70))


@pytest.fixture
def sa():
    with arm_at_start() as s:
        yield s


def _pose(q: np.ndarray) -> tuple[float, float, float]:
    return tuple(float(v) for v in kinematics.fk(ARM3R.links, q[None])[0])


def _replace_run(sa, at: float, make_target, **kw):
    """Run a 2 s move, retarget it at the fraction ``at`` with ``make_target(traj)``; the
    execution, the wire, the commanded joints and the first changed sample."""
    traj = _move(sa, duration=2.0)
    i = int(at * len(traj.t)) + 1
    out = {}

    def ops(ex):
        out["first"] = ex.retarget(make_target(traj), **kw)

    report, ex, wire = _run_at(sa, traj, i, ops)
    assert report.stop_reason == "completed", report.headline
    _index, joints, ticks = _sent(ex, wire)
    return traj, ex, report, joints, ticks, out["first"]


def test_a_replacement_never_visits_its_first_waypoint_and_never_turns_back(sa):
    """P = where the arm was 0.4 s before the request (behind it), G ahead: the arm goes on
    to G without stopping or turning back (the old semantics went back to P first)."""
    def target(traj):
        behind = traj.joints[int(0.2 * len(traj.t))]
        return PlanRequest(ARM3R, [_pose(behind), AHEAD], rate_hz=RATE)

    _traj, _ex, _report, joints, ticks, first = _replace_run(sa, 0.4, target)
    _check_limits(joints)
    _check_wire_steps(ticks)
    vel, _ = _fd(joints)
    heading = vel[first - 2] / np.linalg.norm(vel[first - 2])
    along = vel[first - 1:] @ heading
    speed = np.linalg.norm(vel[first - 1:], axis=1)
    # no turning back: the velocity along the heading at the switch never reverses while the
    # arm moves on to G (beyond the rounding of a law at rest)
    moving = speed > 1e-6
    assert (along[moving] > -1e-6).all(), along.min()
    # no stop: the first sample at rest is at the goal
    low = np.flatnonzero(speed < 1e-6)
    rest = int(low[0]) if low.size else len(speed)
    assert speed[0] > 0.2 * V.min() and rest > 0
    end = kinematics.fk(ARM3R.links, joints[min(first + rest, len(joints) - 1)][None])[0]
    assert np.allclose(end[:2], AHEAD[:2], atol=1e-6)
    last = kinematics.fk(ARM3R.links, joints[-1:])[0]
    assert np.allclose(last[:2], AHEAD[:2], atol=1e-6)


def test_one_waypoint_is_the_goal_from_the_present_state(sa):
    _traj, _ex, _report, joints, _ticks, first = _replace_run(sa, 0.4, lambda t: [AHEAD])
    vel, _ = _fd(joints)
    speed = np.linalg.norm(vel[first - 1:], axis=1)
    assert speed.min(initial=1.0) >= 0.0 and speed[0] > 0.2 * V.min()
    end = kinematics.fk(ARM3R.links, joints[-1:])[0]
    assert np.allclose(end[:2], AHEAD[:2], atol=1e-6)
    assert math.isclose(kinematics.wrap(end[2] - AHEAD[2]), 0.0, abs_tol=1e-6)


@pytest.mark.parametrize("duration", [2.5, 4.0])
def test_a_replacement_runs_its_duration_from_the_switch(sa, duration):
    def target(traj):
        here = traj.joints[int(0.3 * len(traj.t))]
        return PlanRequest(ARM3R, [_pose(here), AHEAD], rate_hz=RATE, duration=duration)

    _traj, ex, _report, joints, ticks, first = _replace_run(sa, 0.3, target)
    _check_limits(joints)
    _check_wire_steps(ticks)
    took = (len(joints) - first) / RATE
    assert abs(took - duration) <= max(0.01 * duration, 3 / RATE), took
    # the new move's own counts: its samples, all sent (virtual time: none late)
    own = ex.report_from(first)
    assert own.samples_total == len(joints) - first == len(ex.remaining(first).t)
    assert own.samples_sent == own.samples_total and own.skipped == 0
    assert own.headline == f"completed: all {own.samples_total} samples sent"
    assert ex.report.samples_total == len(joints)  # the stream's report counts them all


def test_a_replacement_at_a_speed_scale_runs_its_duration_slower_by_it(sa):
    traj = _move(sa, duration=2.0)
    out = {}

    def ops(ex):
        ex.set_speed(0.5)
        here = traj.joints[int(0.3 * len(traj.t))]
        out["first"] = ex.retarget(PlanRequest(ARM3R, [_pose(here), AHEAD], rate_hz=RATE,
                                               duration=3.0))

    _report, ex, wire = _run_at(sa, traj, int(0.3 * len(traj.t)) + 1, ops)
    _index, joints, _ticks = _sent(ex, wire)
    took = (len(joints) - out["first"]) / RATE
    assert abs(took - 6.0) <= 0.06, took


@pytest.mark.parametrize(("fields", "name"), [
    ({"profile": "quintic"}, "profile"),
    ({"rate_hz": 200.0}, "rate_hz"),
    ({"duration": 0.05}, "duration"),
])
def test_a_field_a_replacement_cannot_honour_is_refused_by_name(sa, fields, name):
    traj = _move(sa, duration=2.0)

    def ops(ex):
        here = traj.joints[int(0.3 * len(traj.t))]
        with pytest.raises(InputError) as err:
            ex.retarget(PlanRequest(ARM3R, [_pose(here), AHEAD], **{"rate_hz": RATE,
                                                                     **fields}))
        assert err.value.field == name

    report, ex, wire = _run_at(sa, traj, int(0.3 * len(traj.t)) + 1, ops)
    _index, _joints, ticks = _sent(ex, wire)
    assert report.outcome == "done" and not ex.switches
    assert np.array_equal(ticks, traj.ticks), "nothing changed"


@pytest.mark.parametrize("fields", [{"method": "seplerp"},
                                    {"method": "kenlerp", "beta": 4.0}])
def test_a_replacement_keeps_its_method_and_beta(sa, fields):
    """The new path is the request's method's geometry from the switch pose (SEP-LERP and
    KenLERP β = 4 lie millimetres off ScLERP there): after the blend-out the commanded
    poses lie on it, not on ScLERP's."""
    def target(traj):
        return PlanRequest(ARM3R, [START, AHEAD], rate_hz=RATE, **fields)

    _traj, _ex, _report, joints, _ticks, first = _replace_run(sa, 0.5, target)
    here = joints[first - 1]
    tail = kinematics.fk(ARM3R.links, joints[first + (len(joints) - first) // 2:])
    gaps = []
    for kw in (fields, {"method": "sclerp"}):
        ref = plan(ARM3R, [_pose(here), AHEAD], rate_hz=RATE, start_joints=tuple(here),
                   profile="quintic", duration=4.0, **kw)
        gap = max(float(np.min(np.linalg.norm(ref.poses[:, :2] - p[:2], axis=1)))
                  for p in tail[::25])
        gaps.append(gap)
    assert gaps[0] < 0.1 * gaps[1], gaps
