"""firmware_sim Servo: the motion model (profiles, frames, modes) and construction.

The watchdog, hardware errors and maintenance instructions are in test_fw_maintenance.py.

Servo with a VirtualClock, no pty. Durations are checked against the X-series formulas
computed here from the e-manual (t_accel = 64·V/A ms, cruise 64·|Δ|/V ms, triangle
2·sqrt(|Δ|/a) with a = A·214.577 rev/min²), not against numbers from a run.
"""

from __future__ import annotations

import itertools
import math

import pytest
from fw_helpers import PERIOD, make, put, setup_move
from hypothesis import event, given, settings
from hypothesis import strategies as st

from firmware_sim import control_table as ct
from firmware_sim.clock import RealClock, VirtualClock
from firmware_sim.control_table import (
    ERR_DATA_RANGE,
)
from firmware_sim.profile import (
    plan_time_based,
    plan_velocity_based,
    plan_velocity_mode,
)
from firmware_sim.servo import Servo

#: Profile Acceleration unit in pulse/s² (e-manual 214.577 rev/min², 4096 pulse/rev).
A_UNIT = 214.577 * 4096 / 3600.0


def expected_duration_s(delta: int, v: int, a: int) -> float:
    """X-series velocity-based profile time, e-manual formulas (dynamixel-notes §2.1)."""
    delta = abs(delta)
    if v == 0:
        return 0.0
    if a == 0:
        return 0.064 * delta / v
    t_accel = 0.064 * v / a
    if delta >= v * v / a:                       # V is reached: trapezoid
        return t_accel + 0.064 * delta / v
    return 2 * math.sqrt(delta / (a * A_UNIT))   # triangle


def assert_duration(servo: Servo, clock: VirtualClock, goal: int, expected: float) -> None:
    """Goal written now: moving one period before ``expected``, done one period after."""
    t0 = clock.now()
    put(servo, ct.GOAL_POSITION, goal)
    if expected > PERIOD:
        clock.set(t0 + expected - PERIOD)
        assert servo.moving and servo.get(ct.MOVING_STATUS) & ct.MS_PROFILE_ONGOING
    clock.set(t0 + expected + PERIOD)
    assert not servo.moving
    assert servo.present_position == goal and servo.present_velocity == 0
    status = servo.get(ct.MOVING_STATUS)
    assert status & ct.MS_IN_POSITION and not status & ct.MS_PROFILE_ONGOING


# ---- profile types ----------------------------------------------------------------------
def test_step_profile_when_velocity_is_zero():
    servo, _ = make()
    setup_move(servo, 0, 50)
    put(servo, ct.GOAL_POSITION, 3000)
    assert servo.present_position == 3000 and not servo.moving
    assert servo.get(ct.MOVING_STATUS) & 0x30 == 0


def test_rectangle_profile_when_acceleration_is_zero():
    servo, clock = make()
    setup_move(servo, 100, 0)
    t0 = clock.now()
    put(servo, ct.GOAL_POSITION, 1048)
    clock.set(t0 + 0.1)
    assert servo.present_velocity == -100                     # full speed at once
    assert servo.get(ct.MOVING_STATUS) == ct.MS_PROFILE_RECTANGLE | ct.MS_PROFILE_ONGOING
    servo2, clock2 = make()
    setup_move(servo2, 100, 0)
    assert_duration(servo2, clock2, 1048, expected_duration_s(1000, 100, 0))


def test_trapezoid_duration_and_shape():
    servo, clock = make()
    v, a, goal = 120, 15, 2048 + 3000
    setup_move(servo, v, a, mode=ct.MODE_EXTENDED_POSITION)
    t0 = clock.now()
    t_accel = 0.064 * v / a
    put(servo, ct.GOAL_POSITION, goal)
    clock.set(t0 + t_accel / 2)
    assert 0 < servo.present_velocity < v
    assert servo.get(ct.MOVING_STATUS) == ct.MS_PROFILE_TRAPEZOID | ct.MS_PROFILE_ONGOING
    clock.set(t0 + t_accel + 0.1)
    assert servo.present_velocity == v                        # cruising at Profile Velocity
    assert servo.get(ct.VELOCITY_TRAJECTORY) == v
    assert servo.get(ct.POSITION_TRAJECTORY) == servo.present_position
    servo2, clock2 = make()
    setup_move(servo2, v, a, mode=ct.MODE_EXTENDED_POSITION)
    assert_duration(servo2, clock2, goal, expected_duration_s(3000, v, a))


def test_triangle_when_velocity_cannot_be_reached():
    servo, clock = make()
    v, a = 300, 10          # V²/A = 9000 pulses > the move
    setup_move(servo, v, a)
    put(servo, ct.TORQUE_ENABLE, 0)
    put(servo, ct.VELOCITY_LIMIT, 1023)
    put(servo, ct.TORQUE_ENABLE, 1)
    t0 = clock.now()
    put(servo, ct.GOAL_POSITION, 3548)
    clock.set(t0 + 0.05)
    assert servo.get(ct.MOVING_STATUS) == ct.MS_PROFILE_TRIANGLE | ct.MS_PROFILE_ONGOING
    half = math.sqrt(1500 / (a * A_UNIT))
    clock.set(t0 + half)
    assert abs(servo.present_position - (2048 + 750)) <= 2     # symmetric: halfway at half time
    assert servo.present_velocity < v
    servo2, clock2 = make()
    setup_move(servo2, v, a)
    put(servo2, ct.TORQUE_ENABLE, 0)
    put(servo2, ct.VELOCITY_LIMIT, 1023)
    put(servo2, ct.TORQUE_ENABLE, 1)
    assert_duration(servo2, clock2, 3548, expected_duration_s(1500, v, a))


@settings(max_examples=80, deadline=None)
@given(delta=st.one_of(st.integers(-1_000_000, 1_000_000), st.integers(-3000, 3000))
       .filter(lambda d: d != 0),
       v=st.integers(1, 1023), a=st.one_of(st.integers(0, 32767), st.integers(0, 50)))
def test_profiled_move_duration_matches_xseries_formula(delta, v, a):
    event("rectangle" if a == 0 else "trapezoid" if abs(delta) >= v * v / a else "triangle")
    servo, clock = make()
    setup_move(servo, v, a, mode=ct.MODE_EXTENDED_POSITION)
    put(servo, ct.TORQUE_ENABLE, 0)
    put(servo, ct.VELOCITY_LIMIT, 1023)
    put(servo, ct.TORQUE_ENABLE, 1)
    goal = servo.present_position + delta
    if abs(goal) > ct.EXTENDED_POSITION_RANGE:
        goal = servo.present_position - delta
    assert_duration(servo, clock, goal, expected_duration_s(delta, v, a))


def test_velocity_limit_caps_profile_velocity():
    servo, clock = make()
    setup_move(servo, 500, 0)                   # Velocity Limit default 200 on the XM430
    limit = servo.get(ct.VELOCITY_LIMIT)
    assert limit == 200
    assert_duration(servo, clock, 2048 + 2000, expected_duration_s(2000, limit, 0))


def test_time_based_profile():
    for accel_ms, kind in ((300, ct.MS_PROFILE_TRAPEZOID), (700, ct.MS_PROFILE_TRIANGLE),
                           (0, ct.MS_PROFILE_RECTANGLE)):
        servo, clock = make()
        setup_move(servo, 1000, accel_ms, drive_mode=ct.DRIVE_TIME_BASED)
        t0 = clock.now()
        put(servo, ct.GOAL_POSITION, 2048 + 1200)
        clock.set(t0 + 0.01)
        assert servo.get(ct.MOVING_STATUS) & 0x30 == kind
        t1 = min(accel_ms, 500) / 1000
        if t1:
            peak = 1200 / (1.0 - t1)             # Δ = vp·(t3 - t1)
            clock.set(t0 + t1)
            assert abs(servo.present_position - (2048 + peak * t1 / 2)) <= 1
        clock.set(t0 + 0.5)                      # symmetric profile: halfway at half time
        assert abs(servo.present_position - (2048 + 600)) <= 1
        clock.set(t0 + 1.0 - PERIOD)
        assert servo.moving
        clock.set(t0 + 1.0 + PERIOD)
        assert not servo.moving and servo.present_position == 2048 + 1200
    servo, clock = make()
    setup_move(servo, 0, 0, drive_mode=ct.DRIVE_TIME_BASED)
    put(servo, ct.GOAL_POSITION, 100)
    assert servo.present_position == 100          # total time 0: step


# ---- re-planning ------------------------------------------------------------------------
@settings(max_examples=30, deadline=None)
@given(first=st.integers(-3000, 3000).filter(lambda d: abs(d) > 50),
       second=st.integers(-3000, 3000), frac=st.floats(0.05, 0.95),
       v=st.integers(50, 200), v2=st.integers(20, 200), a=st.integers(20, 200))
def test_new_goal_replans_with_continuous_velocity(first, second, frac, v, v2, a):
    servo, clock = make()
    setup_move(servo, v, a, mode=ct.MODE_EXTENDED_POSITION)
    t0 = clock.now()
    put(servo, ct.GOAL_POSITION, 2048 + first)
    clock.set(t0 + frac * expected_duration_s(first, v, a))
    before = servo.present_velocity
    put(servo, ct.PROFILE_VELOCITY, v2)             # takes effect with the next goal only
    assert servo.present_velocity == before
    put(servo, ct.GOAL_POSITION, 2048 + second)
    assert servo.present_velocity == before                   # same instant, same velocity
    dt = 0.004
    max_step = a / 64 * dt * 1000 + 1                         # A is V units per 64 ms
    positions, velocities = [servo.present_position], [before]
    while servo.moving and clock.now() < t0 + 60.0:
        clock.advance(dt)
        positions.append(servo.present_position)
        velocities.append(servo.present_velocity)
    assert max(abs(p - q) for p, q in itertools.pairwise(velocities)) <= max_step
    top = max(abs(x) for x in velocities)
    assert top <= max(v, v2)
    assert max(abs(p - q) for p, q in itertools.pairwise(positions)) <= top / 64 * dt * 1000 + 1
    assert servo.present_position == 2048 + second and not servo.moving


def _goal_trace(rewrite: bool) -> list[tuple[int, int]]:
    """(present position, Moving Status) every 10 ms over 2 s of a move to 4000, the same
    goal written again at every step if ``rewrite`` (a streamed duplicate goal)."""
    servo, clock = make()
    setup_move(servo, 100, 10)
    t0 = clock.now()
    put(servo, ct.GOAL_POSITION, 4000)
    trace = []
    for k in range(1, 200):
        clock.set(t0 + 0.01 * k)
        if rewrite:
            put(servo, ct.GOAL_POSITION, 4000)
        trace.append((servo.present_position, servo.get(ct.MOVING_STATUS)))
    return trace


def test_rewriting_the_same_goal_keeps_the_plan():
    trace = _goal_trace(rewrite=True)
    assert trace == _goal_trace(rewrite=False)
    assert trace[-1][0] != trace[0][0]          # the servo moved: the traces are of a move


def test_time_based_replan_restarts_the_clock_with_continuous_velocity():
    servo, clock = make()
    setup_move(servo, 800, 200, drive_mode=ct.DRIVE_TIME_BASED)
    t0 = clock.now()
    put(servo, ct.GOAL_POSITION, 3048)
    clock.set(t0 + 0.4)
    before = servo.present_velocity
    assert before > 0
    put(servo, ct.GOAL_POSITION, 1500)
    assert servo.present_velocity == before
    clock.set(t0 + 0.4 + 0.8 - PERIOD)
    assert servo.moving
    clock.set(t0 + 0.4 + 0.8 + PERIOD)
    assert not servo.moving and servo.present_position == 1500


def test_replan_towards_a_goal_behind_brakes_first():
    servo, clock = make()
    setup_move(servo, 100, 20, mode=ct.MODE_EXTENDED_POSITION)
    t0 = clock.now()
    put(servo, ct.GOAL_POSITION, 2048 + 4000)
    clock.set(t0 + 1.0)
    assert servo.present_velocity == 100
    here = servo.present_position
    put(servo, ct.GOAL_POSITION, here)               # goal already passed at speed
    clock.advance(0.064 * 100 / 20 / 2)
    assert servo.present_position > here and 0 < servo.present_velocity < 100
    clock.advance(5.0)
    assert servo.present_position == here and servo.present_velocity == 0


# ---- frames, modes, torque ----------------------------------------------------------------
def test_homing_offset_and_reverse():
    servo, clock = make(position=1000)
    assert servo.present_position == 1000
    put(servo, ct.HOMING_OFFSET, 300)
    assert servo.present_position == 1300                     # present = actual + offset
    put(servo, ct.DRIVE_MODE, ct.DRIVE_REVERSE)
    assert servo.present_position == -1000 + 300
    put(servo, ct.OPERATING_MODE, ct.MODE_EXTENDED_POSITION)
    put(servo, ct.PROFILE_VELOCITY, 200)
    put(servo, ct.TORQUE_ENABLE, 1)
    put(servo, ct.GOAL_POSITION, -700 + 500)
    clock.advance(2.0)
    assert servo.present_position == -200
    put(servo, ct.TORQUE_ENABLE, 0)
    # back to the motor's own frame: the actual position moved by -500 (reversed)
    put(servo, ct.DRIVE_MODE, 0)
    put(servo, ct.HOMING_OFFSET, 0)
    assert servo.present_position == 1000 - 500


def test_torque_off_stops_where_it_is_and_goal_alone_does_not_move():
    servo, clock = make()
    put(servo, ct.GOAL_POSITION, 3000)                # torque off: stored, no motion
    clock.advance(2.0)
    assert servo.present_position == 2048 and servo.goal_position == 3000
    setup_move(servo, 100, 10)
    assert servo.goal_position == 2048                # torque on holds the present position
    put(servo, ct.GOAL_POSITION, 3000)
    clock.advance(0.5)
    mid = servo.present_position
    assert 2048 < mid < 3000
    put(servo, ct.TORQUE_ENABLE, 0)
    clock.advance(2.0)
    assert servo.present_position == mid and not servo.moving


def test_torque_on_by_goal_update():
    servo, clock = make()
    put(servo, ct.DRIVE_MODE, ct.DRIVE_TORQUE_ON_BY_GOAL)
    put(servo, ct.GOAL_POSITION, 2500)
    assert servo.torque_enabled
    clock.advance(0.1)
    assert servo.present_position == 2500


def test_velocity_mode_ramps_then_keeps_goal_velocity():
    servo, clock = make()
    setup_move(servo, 0, 20, mode=ct.MODE_VELOCITY)
    t0 = clock.now()
    put(servo, ct.GOAL_VELOCITY, 100)
    ramp = 0.064 * 100 / 20
    clock.set(t0 + ramp / 2)
    assert servo.present_velocity in (49, 50, 51)
    clock.set(t0 + ramp)
    p1 = servo.present_position
    assert servo.present_velocity == 100
    clock.set(t0 + ramp + 1.0)
    assert abs(servo.present_position - p1 - 100 / 0.064) <= 1     # Δ = V·t/64 ms
    assert servo.moving and servo.get(ct.MOVING_STATUS) & ct.MS_PROFILE_ONGOING == 0


def test_realtime_tick_counts_ms_and_wraps():
    servo, clock = make()
    t = servo.get(ct.REALTIME_TICK)
    clock.advance(1.234)
    assert servo.get(ct.REALTIME_TICK) == (t + 1234) % 32768
    clock.advance(32.768)
    assert servo.get(ct.REALTIME_TICK) == (t + 1234) % 32768


# ---- construction -----------------------------------------------------------------------
def test_constructor_validation_and_defaults():
    s = Servo(3)
    assert isinstance(s.clock, RealClock)
    assert (s.id, s.baud_index, s.firmware_version, s.present_position) == (3, 3, 46, 2048)
    assert s.status_return_level == 2 and s.return_delay_us == 500 and not s.booting()
    for kwargs, word in (({"servo_id": 253}, "servo_id"), ({"model": "mx-28"}, "model"),
                         ({"baud_index": 8}, "baud_index"), ({"firmware": 300}, "firmware"),
                         ({"position": 1 << 31}, "position"),
                         ({"boot_delay_s": -1.0}, "boot_delay_s")):
        args = {"servo_id": 1, **kwargs}
        with pytest.raises(ValueError, match=word):
            Servo(**args)


def test_virtual_clock_is_monotonic():
    clock = VirtualClock(5.0)
    clock.advance(1.5)
    assert clock.now() == 6.5
    clock.set(7.0)
    with pytest.raises(ValueError, match="monotonic"):
        clock.set(6.0)
    with pytest.raises(ValueError, match="dt"):
        clock.advance(-1)


def test_secondary_id_and_protocol_type():
    servo, _ = make()
    assert servo.secondary_id is None and servo.protocol_type == 2
    put(servo, ct.SECONDARY_ID, 9)
    assert servo.secondary_id == 9
    assert servo.write(ct.SECONDARY_ID, bytes([253])) == ERR_DATA_RANGE


# ---- the profile generator on its own ------------------------------------------------------
def _check_plan(plan, p0, v0, goal, vmax, amax, tol=1e-6):
    """Invariants: starts at (p0, v0), ends at rest on goal, |a| <= amax, |v| <= max(v0, vmax),
    segments contiguous in time, position and velocity."""
    assert plan.state(plan.start) == pytest.approx((p0, v0), abs=1e-6) or not plan.segments
    t = plan.start
    p, v = p0, v0
    for seg in plan.segments:
        assert seg.t0 == pytest.approx(t, abs=1e-9) and seg.dur > 0
        assert (seg.p0, seg.v0) == pytest.approx((p, v), abs=1e-6 * max(1.0, abs(p)))
        assert abs(seg.a) <= amax * (1 + tol)
        p, v = seg.at(seg.t0 + seg.dur)
        assert abs(seg.v0) <= max(abs(v0), vmax) * (1 + tol) + tol
        t = seg.t0 + seg.dur
    if plan.segments:
        # float error grows with the distance covered (a brake can run far past the goal)
        scale = 1.0 + abs(goal) + abs(p0) + v0 * v0 / amax
        assert (p, v) == pytest.approx((goal, 0.0), abs=1e-9 * scale)
    assert plan.end == pytest.approx(t, abs=1e-9)
    assert plan.state(plan.end + 1.0) == (goal, 0.0)


@settings(max_examples=300)
@given(p0=st.floats(-1e6, 1e6), v0=st.floats(-2e4, 2e4), goal=st.floats(-1e6, 1e6),
       vmax=st.floats(1.0, 2e4), amax=st.floats(1.0, 1e6))
def test_velocity_based_plan_invariants(p0, v0, goal, vmax, amax):
    plan = plan_velocity_based(3.0, p0, v0, goal, vmax, amax)
    _check_plan(plan, p0, v0, goal, vmax, amax)
    # never slower than needed: from rest, the plan takes the textbook minimum time
    if v0 == 0:
        d = abs(goal - p0)
        minimum = (vmax / amax + d / vmax) if d >= vmax * vmax / amax else 2 * math.sqrt(d / amax)
        assert plan.end - plan.start == pytest.approx(minimum, rel=1e-9, abs=1e-9)


@settings(max_examples=200)
@given(p0=st.floats(-1e5, 1e5), v0=st.floats(-5e3, 5e3), goal=st.floats(-1e5, 1e5),
       total=st.floats(0.01, 30.0), accel=st.floats(0.0, 30.0))
def test_time_based_plan_invariants(p0, v0, goal, total, accel):
    plan = plan_time_based(1.0, p0, v0, goal, total, accel)
    assert plan.end == pytest.approx(1.0 + total)
    p, _ = plan.state(1.0 + total - 1e-12)
    assert p == pytest.approx(goal, abs=1e-3 * max(1.0, abs(v0) + abs(goal - p0)))
    assert plan.state(plan.end) == (goal, 0.0)
    if accel >= 1e-6:                              # starts from the present velocity
        assert plan.state(1.0)[1] == pytest.approx(v0)


def test_velocity_mode_plan():
    plan = plan_velocity_mode(0.0, 10.0, 0.0, 500.0, 1000.0)
    assert plan.end == pytest.approx(0.5)
    assert plan.state(0.25) == pytest.approx((10.0 + 0.5 * 1000 * 0.25**2, 250.0))
    p_end = 10.0 + 0.5 * 1000 * 0.5**2
    assert plan.state(2.5) == pytest.approx((p_end + 500.0 * 2.0, 500.0))
    step = plan_velocity_mode(0.0, 0.0, 100.0, -300.0, 0.0)
    assert step.state(1.0) == pytest.approx((-300.0, -300.0))
