"""The X-series servo's own controllers, as the e-manual's control block diagrams draw them.

Position (Operating Modes 3, 4, 5; e-manual "Position PID Gain(80, 82, 84), Feedforward
1st/2nd Gains(88, 90)")::

    PWM = KPP·e + KPI·Σe + KPD·Δe + KFF1·v_d + KFF2·a_d,     e = x_d − x
    KPP = P/128, KPI = I/65536, KPD = D/16, KFF1 = FF1/4, KFF2 = FF2/4

then limited by Goal PWM (100) (and, in mode 5, the current by Goal Current (102)).
x_d, v_d, a_d are the profile generator's Position/Velocity Trajectory and its acceleration,
so the feedforward is zero when Profile Velocity is 0 (a step has no trajectory).

Velocity (mode 1; "Velocity PI Gain(76, 78)")::

    PWM = KVP·e_v + KVI·Σe_v,   KVP = P/128, KVI = I/65536,   e_v = v_d − v

Units (the e-manual says only that the constants include the sampling time; inference):
e in pulses, Σ accumulates once per millisecond, Δe is the change per millisecond, v_d and
e_v in velocity units (0.229 rpm), a_d in Profile Acceleration units (214.577 rev/min²),
PWM in Goal PWM units (885 = 100 %). The integrators are clamped so that their term alone
cannot exceed the PWM limit (the e-manual's anti-windup gain Ka is not published).
"""

from __future__ import annotations

from dataclasses import dataclass

from firmware_sim.motor import PWM_FULL


@dataclass(frozen=True)
class PositionGains:
    """Control-table gains of the position controller (raw item values)."""

    p: int
    i: int
    d: int
    ff1: int
    ff2: int

    @property
    def kpp(self) -> float:
        return self.p / 128.0

    @property
    def kpi(self) -> float:
        return self.i / 65536.0

    @property
    def kpd(self) -> float:
        return self.d / 16.0

    @property
    def kff1(self) -> float:
        return self.ff1 / 4.0

    @property
    def kff2(self) -> float:
        return self.ff2 / 4.0


class PositionController:
    """PID + feedforward position loop with a clamped integrator (module equations)."""

    __slots__ = ("integral", "last_error")

    def __init__(self) -> None:
        self.integral = 0.0
        self.last_error: float | None = None

    def reset(self) -> None:
        self.integral = 0.0
        self.last_error = None

    def pwm(self, kpp: float, kpi: float, kpd: float, kff1: float, kff2: float,
            error: float, v_d: float, a_d: float, dt_ms: float) -> float:
        """Unlimited PWM output for one sample of ``dt_ms`` milliseconds."""
        last = self.last_error
        de = 0.0 if last is None else (error - last) / dt_ms
        self.last_error = error
        if kpi > 0.0:
            integral = self.integral + error * dt_ms
            bound = PWM_FULL / kpi
            self.integral = bound if integral > bound else (-bound if integral < -bound
                                                            else integral)
        return kpp * error + kpi * self.integral + kpd * de + kff1 * v_d + kff2 * a_d


class VelocityController:
    """PI velocity loop with a clamped integrator (module equations)."""

    __slots__ = ("integral",)

    def __init__(self) -> None:
        self.integral = 0.0

    def reset(self) -> None:
        self.integral = 0.0

    def pwm(self, kvp: float, kvi: float, error: float, dt_ms: float) -> float:
        if kvi > 0.0:
            integral = self.integral + error * dt_ms
            bound = PWM_FULL / kvi
            self.integral = bound if integral > bound else (-bound if integral < -bound
                                                            else integral)
        return kvp * error + kvi * self.integral
