"""The physics model through the real dynamixel-sdk over the pty, on a virtual clock.

Acceptance (issue 11 §1): with default gains and no load, a 1024-pulse goal step's time to
within 20 pulses and the steady lag behind a constant-velocity ramp of goals match a
datasheet DC-motor model of the same servo within 25 %; Present Current rises while
accelerating and against an obstacle; overload trips, shuts the torque off and clears on
Reboot. The reference model here is the linear datasheet torque-speed line
τ = u·τ_s − (τ_s/ω_nl)·ω with the rotor inertia and the P loop KPP = P/128, integrated by
scipy: no friction split, no efficiency, none of firmware_sim's code.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from dynamixel_sdk import COMM_SUCCESS
from scipy.integrate import solve_ivp

from firmware_sim import control_table as ct
from firmware_sim.bus import SimBus
from firmware_sim.clock import VirtualClock
from firmware_sim.drive import OVERLOAD_TIME_S
from firmware_sim.motor import MOTORS
from tests.fw_helpers import PH, s32, sdk_port

DATASHEET = {  # stall torque N·m, no-load rpm, default Position P and D Gains (e-manual, 12 V)
    "xm430-w350": (4.1, 46.0, 800, 0),
    "xl430-w250": (1.5, 61.0, 640, 4000),
}
PPR = 4096 / (2 * math.pi)


def _reference_step(model: str, step: float, within: float) -> float:
    """Datasheet model: time for a P-controlled linear DC motor to come within ``within``."""
    stall, rpm, p_gain, d_gain = DATASHEET[model]
    w_nl = rpm * 2 * math.pi / 60
    inertia = MOTORS[model].inertia          # the one figure not on the datasheet

    def rhs(t, y):
        x, w = y          # KPD acts on the error's change per ms (controller.py's units)
        u = max(-1.0, min(1.0, (p_gain / 128 * (step - x) - d_gain / 16 * w * PPR / 1000)
                          / 885))
        return [w * PPR, (u * stall - stall / w_nl * w) / inertia]

    def near(t, y):
        return abs(step - y[0]) - within
    near.terminal = True
    near.direction = -1
    sol = solve_ivp(rhs, (0, 3), [0.0, 0.0], events=near, max_step=1e-3, rtol=1e-8)
    return float(sol.t_events[0][0])


def _reference_lag(model: str, speed: float) -> float:
    """Datasheet model: steady lag (pulses) behind goals moving at ``speed`` pulse/s."""
    _, rpm, p_gain, _ = DATASHEET[model]
    w_nl = rpm * 2 * math.pi / 60
    return 885 * (speed / PPR) / w_nl / (p_gain / 128)


def _sim(model: str, **kw) -> tuple[SimBus, VirtualClock]:
    clock = VirtualClock()
    return SimBus([1], model, clock=clock, dynamics=True, **kw), clock


def _torque_on(port) -> int:
    assert PH.write1ByteTxRx(port, 1, ct.TORQUE_ENABLE, 1)[0] == COMM_SUCCESS
    pos, result, _ = PH.read4ByteTxRx(port, 1, ct.PRESENT_POSITION)
    assert result == COMM_SUCCESS
    return s32(pos)


#: How long every status packet is awaited (ms of wall time). These tests move a virtual
#: clock themselves, so a reply's lateness costs nothing; the SDK's own ~34 ms deadline
#: expired on a loaded machine while the in-process server thread waited for the CPU, and
#: the late status then answered the next request (a write's status read as a read's: the
#: SDK's IndexError).
REPLY_WAIT_MS = 2000.0


@contextlib.contextmanager
def _port(bus: SimBus) -> Iterator[Any]:
    """:func:`sdk_port` whose every transaction waits :data:`REPLY_WAIT_MS` for its status."""
    with sdk_port(bus) as port:
        port.setPacketTimeout = lambda _length: port.setPacketTimeoutMillis(REPLY_WAIT_MS)
        yield port


def _read(port, address: int, size: int) -> int:
    """One register of servo 1 (signed)."""
    if size == 4:
        value, result, _ = PH.read4ByteTxRx(port, 1, address)
        value = s32(value)
    else:
        value, result, _ = PH.read2ByteTxRx(port, 1, address)
        value = value - 65536 if value & 0x8000 else value
    assert result == COMM_SUCCESS
    return value


@pytest.mark.parametrize("model", ["xm430-w350", "xl430-w250"])
def test_step_time_matches_datasheet_model(model):
    bus, clock = _sim(model)
    with bus, _port(bus) as port:
        start = _torque_on(port)
        PH.write4ByteTxRx(port, 1, ct.GOAL_POSITION, start + 1024)
        t, dt, reached = 0.0, 0.002, None
        currents, positions = [], []
        while t < 2.0:
            clock.advance(dt)
            t += dt
            pos = _read(port, ct.PRESENT_POSITION, 4)
            currents.append(abs(_read(port, ct.PRESENT_CURRENT, 2)))
            positions.append(pos)
            if reached is None and abs(start + 1024 - pos) <= 20:
                reached = t
        assert reached is not None, f"never within 20 pulses; ended at {positions[-1]}"
        # settled, not passing through: it stays within 20 pulses
        assert all(abs(start + 1024 - p) <= 20 for p in positions[int(reached / dt) + 5:])
    ref = _reference_step(model, 1024, 20)
    assert abs(reached / ref - 1) <= 0.25, (reached, ref)
    # Present Current rises while accelerating: the first 10 ms draw far more than cruising
    cruise = currents[int(0.12 / dt)]
    assert max(currents[:5]) > 3 * cruise > 0


@pytest.mark.parametrize("model", ["xm430-w350", "xl430-w250"])
def test_ramp_lag_matches_datasheet_model(model):
    speed = 1500.0                      # pulse/s ≈ 22 rpm, about half the no-load speed
    bus, clock = _sim(model)
    with bus, _port(bus) as port:
        start = _torque_on(port)
        dt = 0.001
        lags = []
        for k in range(1, 601):
            goal = start + round(speed * k * dt)
            PH.write4ByteTxRx(port, 1, ct.GOAL_POSITION, goal)
            clock.advance(dt)
            if k > 300:                 # after the start transient (τ ≈ 50 ms)
                lags.append(goal - _read(port, ct.PRESENT_POSITION, 4))
    lag = float(np.mean(lags))
    ref = _reference_lag(model, speed)
    assert abs(lag / ref - 1) <= 0.25, (lag, ref)
    assert np.std(lags) < 0.1 * lag            # steady: a constant lag, not a drift


def test_obstacle_raises_current_then_overload_trips_and_reboot_clears():
    bus, clock = _sim("xm430-w350")
    with bus, _port(bus) as port:
        start = _torque_on(port)
        bus.servo(1).set_obstacle(20.0)         # joint 0° at tick 2048: the wall at +20°
        PH.write4ByteTxRx(port, 1, ct.GOAL_POSITION, start + 1024)
        clock.advance(0.3)
        pos = _read(port, ct.PRESENT_POSITION, 4)
        current = _read(port, ct.PRESENT_CURRENT, 2)
        assert pos == round(2048 + 20 * 4096 / 360)          # held at the wall
        stall_units = 12.0 / MOTORS["xm430-w350"].resistance / 2.69e-3
        assert current > 0.9 * stall_units                   # pushing at the stall current
        assert _read(port, ct.HARDWARE_ERROR_STATUS, 1) & 0xFF == 0
        clock.advance(OVERLOAD_TIME_S)
        hw, result, error = PH.read1ByteTxRx(port, 1, ct.HARDWARE_ERROR_STATUS)
        assert result == COMM_SUCCESS and hw == ct.HW_OVERLOAD and error & 0x80
        assert PH.read1ByteTxRx(port, 1, ct.TORQUE_ENABLE)[0] == 0
        assert _read(port, ct.PRESENT_CURRENT, 2) == 0
        # torque cannot come back without a reboot
        refused = PH.write1ByteTxRx(port, 1, ct.TORQUE_ENABLE, 1)[1]
        assert refused == ct.ALERT_BIT | ct.ERR_RESULT_FAIL
        assert PH.reboot(port, 1)[0] == COMM_SUCCESS
        clock.advance(0.05)
        assert PH.read1ByteTxRx(port, 1, ct.HARDWARE_ERROR_STATUS)[0] == 0
        assert PH.write1ByteTxRx(port, 1, ct.TORQUE_ENABLE, 1)[0] == COMM_SUCCESS


def test_overheating_shuts_down():
    bus, clock = _sim("xm430-w350")
    with bus, _port(bus) as port:
        start = _torque_on(port)
        servo = bus.servo(1)
        servo.motion.drive.overload_s = -1e9          # keep the overload timer out of this test
        servo.set_obstacle(10.0)
        PH.write4ByteTxRx(port, 1, ct.GOAL_POSITION, start + 1024)
        temps = []
        for _ in range(40):
            clock.advance(5.0)
            temps.append(_read(port, ct.PRESENT_TEMPERATURE, 1) & 0xFF)
            if PH.read1ByteTxRx(port, 1, ct.TORQUE_ENABLE)[0] == 0:
                break
        assert temps == sorted(temps) and temps[0] > 30           # heating up
        assert PH.read1ByteTxRx(port, 1, ct.HARDWARE_ERROR_STATUS)[0] == ct.HW_OVERHEATING
        assert temps[-1] >= 80


def test_backdrive_and_push_with_torque_off():
    bus, clock = _sim("xm430-w350")
    with bus, _port(bus) as port:
        servo = bus.servo(1)
        servo.backdrive(3000)
        assert _read(port, ct.PRESENT_POSITION, 4) == 3000
        clock.advance(0.5)
        assert _read(port, ct.PRESENT_POSITION, 4) == 3000        # stays: friction holds it
        servo.push(0.1)                  # below the gearbox's Coulomb friction: nothing
        clock.advance(0.2)
        assert _read(port, ct.PRESENT_POSITION, 4) == 3000
        servo.push(1.0)
        clock.advance(0.2)
        moved = _read(port, ct.PRESENT_POSITION, 4)
        assert moved > 3010 and _read(port, ct.PRESENT_VELOCITY, 4) > 0
        servo.push(0.0)
        clock.advance(0.5)
        assert _read(port, ct.PRESENT_VELOCITY, 4) == 0
        _torque_on(port)
        with pytest.raises(RuntimeError, match="torque is on"):
            servo.backdrive(100)


def test_backdrive_works_in_the_kinematic_model_too():
    with SimBus([1, 2]) as bus, _port(bus) as port:
        bus.servo(2).backdrive(1234)
        value, result, _ = PH.read4ByteTxRx(port, 2, ct.PRESENT_POSITION)
        assert result == COMM_SUCCESS and value == 1234


def test_present_items_follow_the_supply_voltage():
    bus, clock = _sim("xm430-w350", supply_voltage=11.1)
    with bus, _port(bus) as port:
        assert _read(port, ct.PRESENT_INPUT_VOLTAGE, 2) == 111
        start = _torque_on(port)
        PH.write4ByteTxRx(port, 1, ct.GOAL_POSITION, start + 2000)
        clock.advance(0.2)
        low = _read(port, ct.PRESENT_VELOCITY, 4)
        bus.servo(1).supply_voltage = 14.8
        clock.advance(0.1)
        assert _read(port, ct.PRESENT_INPUT_VOLTAGE, 2) == 148
        assert _read(port, ct.PRESENT_VELOCITY, 4) > low * 1.2       # faster on more volts
        assert _read(port, ct.PRESENT_PWM, 2) == 885


@pytest.mark.parametrize("mode", [ct.MODE_VELOCITY, ct.MODE_PWM, ct.MODE_CURRENT,
                                  ct.MODE_EXTENDED_POSITION, ct.MODE_CURRENT_POSITION])
def test_operating_modes_drive_the_motor(mode):
    bus, clock = _sim("xm430-w350")
    with bus, _port(bus) as port:
        assert PH.write1ByteTxRx(port, 1, ct.OPERATING_MODE, mode)[0] == COMM_SUCCESS
        start = _torque_on(port)
        if mode == ct.MODE_VELOCITY:
            PH.write4ByteTxRx(port, 1, ct.GOAL_VELOCITY, 100)
        elif mode == ct.MODE_PWM:
            PH.write2ByteTxRx(port, 1, ct.GOAL_PWM, 442)
        elif mode == ct.MODE_CURRENT:
            PH.write2ByteTxRx(port, 1, ct.GOAL_CURRENT, 150)
        else:
            PH.write2ByteTxRx(port, 1, ct.GOAL_CURRENT, 200)
            PH.write4ByteTxRx(port, 1, ct.GOAL_POSITION, start + 6000)
        clock.advance(0.5)
        velocity = _read(port, ct.PRESENT_VELOCITY, 4)
        current = _read(port, ct.PRESENT_CURRENT, 2)
        if mode == ct.MODE_VELOCITY:
            assert abs(velocity - 100) <= 5        # the PI loop's integrator settling
        elif mode == ct.MODE_PWM:
            assert 80 < velocity < 110 and _read(port, ct.PRESENT_PWM, 2) == 442
        elif mode == ct.MODE_CURRENT:
            assert velocity > 150       # 0.4 A beats the friction: it spins up
            assert abs(current - 150) <= 15 or velocity > 190
        elif mode == ct.MODE_CURRENT_POSITION:
            assert abs(current) <= 200 + 2     # the current stays within Goal Current
            assert velocity > 0
        else:
            assert velocity > 190       # 6000 pulses away: full speed, beyond one turn
