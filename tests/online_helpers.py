"""Shared pieces of the online-execution tests (test_online: real time, serial;
test_online_virtual: the same operations on virtual time): the simulated arm fixture
``sa``, moves, runners, and the checks on the commanded joints and the wire goals."""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
from conftest import ARM3R

from robodcn import kinematics, plan, servo_units
from robodcn.path_timing import max_start_speed
from robodcn.simulated import simulated_arm
from robodcn.stream import Execution, VirtualClock, start
from robodcn.stream.online_path import JointPath

RATE = 1000.0
V = np.array([j.max_velocity for j in ARM3R.joints])
A = np.array([j.max_acceleration for j in ARM3R.joints])
TICK = np.array([2 * math.pi / s.ticks_per_turn for s in ARM3R.servos])
START = (0.25, 0.10, 0.0)
GOAL = (0.05, 0.25, math.radians(80))
#: finite differences of a law sampled at the stream rate land within this of the limit
SLACK = 1e-6
#: samples after a switch left out of "the loop's own lateness" (a late swap delays them too)
SWITCH_SETTLE = 20


def arm_at_start():
    """The simulated arm (kinematic) at START: the fixture ``sa`` of the online tests."""
    return simulated_arm(ARM3R, timing="fast", dynamics=False,
                         start_joints=kinematics.ik(ARM3R.links, np.array([START]))[0])


def _present(sa) -> np.ndarray:
    return servo_units.ticks_to_radians(sa.bus.read_positions()[None], ARM3R.servos)[0]


def _move(sa, goal=GOAL, **kw):
    q0 = _present(sa)
    pose = tuple(kinematics.fk(ARM3R.links, q0[None])[0])
    return plan(ARM3R, [pose, goal], rate_hz=RATE, start_joints=q0, **kw)


def _run(sa, trajectory, ops, timeout=30.0, compensation=False):
    """Start, run ``ops(execution)``, wait; the report, the execution and the wire goals."""
    sa.sim.clear_log()
    before = len(sa.sim.goal_history(ARM3R.servo_ids[0]))
    ex = start(trajectory, sa.bus, skip_late=False, compensation=compensation)
    ops(ex)
    report = ex.wait(timeout)
    assert report is not None and ex.done
    wire = np.array([sa.sim.goal_history(i)[before:] for i in ARM3R.servo_ids]).T
    return report, ex, wire


def hold_before(clock: VirtualClock, ex: Execution, at: int) -> None:
    """Hold the virtual-time loop of ``ex`` halfway to sample ``at`` (the stream's rate), once
    it has sent samples 0 … ``at`` − 1: an operation run then is placed at sample ``at``."""
    clock.hold(ex.stream.t_start + (at - 0.5) / ex.stream.rate_hz)
    assert clock.wait_parked()
    assert ex.sample == at - 1


def drive_held(clock: VirtualClock, ex: Execution, steps, timeout: float = 60.0):
    """Drive ``ex``, started on ``clock`` held at 0 (parked before sample 0): for each
    (sample, op) of ``steps`` hold the loop before that sample (:func:`hold_before`; sample 0
    is where it is parked) and run ``op(execution)``; release, wait. The report."""
    try:
        assert clock.wait_parked(), ex.error
        for at, op in steps:
            if at > 0:
                hold_before(clock, ex, at)
            op(ex)
    finally:
        clock.release()
    report = ex.wait(timeout)
    assert report is not None and ex.done
    return report


def _run_at(sa, trajectory, at: int, ops, timeout=60.0, compensation=False, **options):
    """On virtual time: start, let the loop send samples 0 … ``at`` − 1 and hold it there,
    run ``ops(execution)``, release it, wait; the report, the execution and the wire goals.
    The operation is placed at a known sample whatever the host does (the Bus Watchdog,
    a real-time guard, is off: the loop waits on the test while held)."""
    return _run_steps(sa, trajectory, [(at, ops)], timeout, compensation, **options)


def _run_steps(sa, trajectory, steps, timeout=60.0, compensation=False, **options):
    """:func:`_run_at` for several (sample, ops) in turn (:func:`drive_held`)."""
    clock = VirtualClock()
    clock.hold(0.0)
    sa.sim.clear_log()
    before = len(sa.sim.goal_history(ARM3R.servo_ids[0]))
    ex = start(trajectory, sa.bus, skip_late=False, compensation=compensation, clock=clock,
               watchdog_ms=0, **options)
    report = drive_held(clock, ex, steps, timeout)
    assert report.lateness_max_s == 0.0, "virtual time: every sample on time"
    wire = np.array([sa.sim.goal_history(i)[before:] for i in ARM3R.servo_ids]).T
    return report, ex, wire


def _sent(ex: Execution, wire: np.ndarray):
    index, _, joints = ex.sent()
    assert (np.diff(index) == 1).all(), "every sample sent once, in order"
    ticks = servo_units.radians_to_ticks(joints, ARM3R.servos)
    # the wire carries exactly the commanded samples (a hold write may follow them)
    assert np.array_equal(wire[:len(ticks)], ticks)
    return index, joints, ticks


def _fd(q: np.ndarray):
    v = np.diff(q, axis=0) * RATE
    return v, np.diff(v, axis=0) * RATE


def _wait_sample(ex: Execution, i: int, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while ex.sample < i and not ex.done and time.monotonic() < deadline:
        time.sleep(0.002)


def _check_limits(joints: np.ndarray, v=V, a=A) -> None:
    vel, acc = _fd(joints)
    assert (np.abs(vel) <= v * (1 + SLACK)).all(), np.abs(vel).max(0) / v
    bad = np.flatnonzero((np.abs(acc) > a * (1 + SLACK)).any(axis=1))
    assert not bad.size, (bad[:10], np.abs(acc).max(0) / a)


def _check_wire_steps(ticks: np.ndarray) -> None:
    """No step of the wire velocity larger than one sample of maximum acceleration plus
    tick quantisation (each goal is rounded by ≤ ½ tick: ≤ 2 ticks on a second difference)."""
    q = ticks * TICK
    dv = np.abs(np.diff(np.diff(q, axis=0), axis=0)) * RATE
    assert (dv <= A / RATE + 2 * TICK * RATE + 1e-12).all()


def _distance_to_polyline(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Per-joint |difference| to the nearest point of the joint polyline (max-norm)."""
    a, b = poly[:-1], poly[1:]
    d = b - a
    out = np.empty_like(points)
    for n, p in enumerate(points):
        t = np.clip(np.einsum("ij,ij->i", p - a, d) / np.maximum(
            np.einsum("ij,ij->i", d, d), 1e-300), 0.0, 1.0)
        near = a + t[:, None] * d
        k = int(np.argmin(np.abs(near - p).max(axis=1)))
        out[n] = np.abs(near[k] - p)
    return out


def _braking_distance(path: JointPath, sigma: float, sd: float) -> float:
    """The time-optimal braking distance along the path from (σ, σ̇): the shortest stretch
    over which that state is still in TOPP-RA's controllable set of a stop at its end."""
    lo, hi = 1e-9, path.length - sigma
    q_of = path.at
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        s = np.linspace(sigma, sigma + mid, 400)
        if max_start_speed(q_of(s), s, V, A) >= sd:
            hi = mid
        else:
            lo = mid
    return hi


# -- jerk limits ------------------------------------------------------------------------

JERK_ARM = dataclasses.replace(ARM3R, joints=tuple(
    dataclasses.replace(j, max_jerk=20.0 * j.max_acceleration) for j in ARM3R.joints))
J = np.array([j.max_jerk for j in JERK_ARM.joints])


def _check_jerk(joints: np.ndarray, v=V, a=A, j=J) -> None:
    """Velocity, acceleration and jerk of the commanded joints (finite differences at the
    stream rate, from rest before the first sample and to rest after the last)."""
    q = np.vstack([joints[:1], joints[:1], joints, joints[-1:], joints[-1:]])
    _check_limits(q, v, a)
    _, acc = _fd(q)
    jerk = np.abs(np.diff(acc, axis=0)) * RATE
    bad = np.flatnonzero((jerk > j * (1 + SLACK)).any(axis=1))
    assert not bad.size, (bad[:10], jerk.max(0) / j)


def _jerk_move(sa, goal=GOAL, **kw):
    q0 = _present(sa)
    pose = tuple(kinematics.fk(ARM3R.links, q0[None])[0])
    return plan(JERK_ARM, [pose, goal], rate_hz=RATE, start_joints=q0, **kw)
