"""One servo's electronics in the physics model: controller → PWM → motor → torque.

Each physics step :meth:`Drive.torque` reads the servo's settings (a snapshot of the
control table taken when the plant starts advancing), runs the mode's controller
(:mod:`firmware_sim.controller`) on the profile's trajectory and the shaft's state, limits
the PWM by Goal PWM and, in current-based modes, the current by Goal Current, and returns
the motor's output torque split as τ = τ₀ − c·ω (the plant treats c implicitly, so the
back-EMF's stiff damping stays stable at any step). It also integrates the winding's
temperature (:mod:`firmware_sim.thermal`) and the overload timer.

Faults with physical causes (the firmware's rules, times are this model's choice):

* **Overload** (Hardware Error Status bit 5): |i| ≥ ``OVERLOAD_FRACTION`` of the most the
  servo can draw now (min(Current Limit, V/R)) for ``OVERLOAD_TIME_S`` in total, the timer
  leaking back at the same rate while below; e.g. a stall at full PWM.
* **Overheating** (bit 2): the winding temperature above Temperature Limit (31).
* **Input voltage** (bit 0): the supply outside Min/Max Voltage Limit (32, 34).

A fault's bits go to the ``on_fault(bits, t)`` callback, which applies Shutdown (63).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from firmware_sim import control_table as ct
from firmware_sim.controller import PositionController, VelocityController
from firmware_sim.motor import PWM_FULL, MotorParams
from firmware_sim.profile import ACCELERATION_UNIT, VELOCITY_UNIT, Profile
from firmware_sim.thermal import Thermal

#: Pulses per radian of the output shaft (4096 a turn).
PULSES_PER_RAD = 4096 / (2 * math.pi)
#: Current at or above this fraction of the most the servo can draw counts as overload.
OVERLOAD_FRACTION = 0.9
#: Sustained time at the current limit before the overload error, s.
OVERLOAD_TIME_S = 1.0

_POSITION_MODES = frozenset({ct.MODE_POSITION, ct.MODE_EXTENDED_POSITION,
                             ct.MODE_CURRENT_POSITION})


@dataclass(frozen=True)
class DriveSettings:
    """The control-table values a drive needs, snapshotted once per plant advance."""

    torque_on: bool
    mode: int
    sign: int                 # -1 with Drive Mode bit 0 (reverse)
    homing: int
    kpp: float
    kpi: float
    kpd: float
    kff1: float
    kff2: float
    kvp: float
    kvi: float
    pwm_limit: float          # |Goal PWM|, PWM units
    goal_pwm: float           # signed Goal PWM (PWM mode)
    goal_current: float       # A, signed (current mode; its magnitude limits mode 5)
    current_limit: float      # A (Current Limit; the stall current for models without one)
    profile: Profile
    temperature_limit: float
    voltage_ok: bool


class Drive:
    """Controller, motor, thermal and overload state of one servo.

    Parameters
    ----------
    motor : MotorParams
    on_fault : callable (bits, t)
        Called from inside a step when a physical fault arises.
    supply_voltage : float
        V.
    """

    def __init__(self, motor: MotorParams, on_fault: Callable[[int, float], None],
                 supply_voltage: float) -> None:
        self.motor = motor
        self.on_fault = on_fault
        self.supply_voltage = float(supply_voltage)
        self.position = PositionController()
        self.velocity = VelocityController()
        self.thermal = Thermal(motor.thermal_resistance, motor.thermal_time_constant)
        self.settings: DriveSettings | None = None
        #: What :attr:`settings` was built from (servo.live.configure_drive): the control
        #: table's settings bytes, the profile and the supply voltage.
        self.settings_from: tuple | None = None
        #: Multi-turn counter offset, pulses: actual position = θ·PULSES_PER_RAD − turns.
        self.turns = 0.0
        #: External torque on the output shaft, N·m (Servo.push).
        self.external_torque = 0.0
        self.current = 0.0          # A, actual frame
        self.duty = 0.0             # [-1, 1], actual frame
        self.overload_s = 0.0
        self.error = 0.0            # last position error, pulses
        self.omega_seen = 0.0       # shaft speed the last step's current was computed at

    def reset_controllers(self) -> None:
        self.position.reset()
        self.velocity.reset()

    def max_current(self) -> float:
        """The most current the servo can draw now: min(Current Limit, V/R), A."""
        s = self.settings
        stall = self.supply_voltage / self.motor.resistance
        return stall if s is None else min(s.current_limit, stall)

    def torque(self, t: float, theta: float, omega: float, dt: float) -> tuple[float, float]:
        """(τ₀, c) of the output torque τ = τ₀ − c·ω over the step [t, t + dt]."""
        s = self.settings
        m = self.motor
        self.omega_seen = omega
        if s is None or not s.torque_on:
            self.duty = 0.0
            self.current = 0.0              # torque off: the bridge is open (coasting)
            self._account(0.0, t, dt)
            return self.external_torque, m.viscous
        volts = self.supply_voltage
        mode = s.mode
        sign = s.sign
        dt_ms = dt * 1000.0
        if mode in _POSITION_MODES:
            present = sign * (theta * PULSES_PER_RAD - self.turns) + s.homing
            p_d, v_d, a_d = s.profile.kinematics(t)
            error = p_d - present
            self.error = error
            u = self.position.pwm(s.kpp, s.kpi, s.kpd, s.kff1, s.kff2, error,
                                  v_d / VELOCITY_UNIT, a_d / ACCELERATION_UNIT, dt_ms)
        elif mode == ct.MODE_VELOCITY:
            v_d = s.profile.state(t)[1]
            v = sign * omega * PULSES_PER_RAD
            u = self.velocity.pwm(s.kvp, s.kvi, (v_d - v) / VELOCITY_UNIT, dt_ms)
        elif mode == ct.MODE_PWM:
            u = s.goal_pwm
        else:                                # current mode: an ideal current loop
            u = sign * (s.goal_current * m.resistance + m.k * omega) / volts * PWM_FULL
        limit = s.pwm_limit
        u = limit if u > limit else (-limit if u < -limit else u)
        duty = sign * u / PWM_FULL
        if mode in (ct.MODE_CURRENT_POSITION, ct.MODE_CURRENT):
            # the current loop keeps |i| within |Goal Current|
            i_lim = abs(s.goal_current)
            hi = (i_lim * m.resistance + m.k * omega) / volts
            lo = (-i_lim * m.resistance + m.k * omega) / volts
            duty = hi if duty > hi else (lo if duty < lo else duty)
        self.duty = duty
        current = (duty * volts - m.k * omega) / m.resistance
        self.current = current
        self._account(current, t, dt)
        return (m.torque_gain * volts / m.resistance * duty + self.external_torque,
                m.emf_damping + m.viscous)

    def _account(self, current: float, t: float, dt: float) -> None:
        """Winding heat and the overload timer for one step; report faults."""
        s = self.settings
        temperature = self.thermal.step(current * current * self.motor.resistance, dt)
        if s is None:
            return
        if abs(current) >= OVERLOAD_FRACTION * self.max_current():
            self.overload_s += dt
            if self.overload_s >= OVERLOAD_TIME_S:
                self.overload_s = 0.0
                self.on_fault(ct.HW_OVERLOAD, t + dt)
        elif self.overload_s > 0.0:
            self.overload_s = max(0.0, self.overload_s - dt)
        if temperature > s.temperature_limit:
            self.on_fault(ct.HW_OVERHEATING, t + dt)

    def steady(self, t: float) -> bool:
        """Nothing in the drive changes while the shaft stays still (lets the plant skip)."""
        s = self.settings
        if self.omega_seen != 0.0:
            return False            # the readings are from a moving shaft: step once more
        if s is None or not s.torque_on:
            return True
        mode = s.mode
        if mode in _POSITION_MODES:
            return not s.profile.ongoing(t) and (s.kpi == 0.0 or self.error == 0.0)
        if mode == ct.MODE_VELOCITY:
            return not s.profile.ongoing(t) and s.profile.state(t)[1] == 0.0
        return True

    def skip(self, dt: float) -> None:
        """Advance heat and the overload timer by ``dt`` of steady state (exactly)."""
        self.thermal.advance(self.current * self.current * self.motor.resistance, dt)
        if self._over():
            self.overload_s += dt
        else:
            self.overload_s = max(0.0, self.overload_s - dt)

    def _over(self) -> bool:
        return abs(self.current) >= OVERLOAD_FRACTION * self.max_current()

    def time_to_overload(self) -> float:
        """Seconds of the present current until the overload error (inf if below)."""
        return max(0.0, OVERLOAD_TIME_S - self.overload_s) if self._over() else math.inf

    def time_to_overheat(self) -> float:
        s = self.settings
        if s is None:
            return math.inf
        return self.thermal.time_to_reach(self.current * self.current * self.motor.resistance,
                                          s.temperature_limit)
