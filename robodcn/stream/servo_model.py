"""The motor side of a servo following a planned joint path: a DC-motor model.

Used by the tracking compensation (:mod:`robodcn.stream.compensation`) and by the collision
stop's current prediction (:mod:`robodcn.stream.collision`), both on the joint torques of
the one inverse dynamics, :func:`robodcn.dynamics.inverse_dynamics` of
:func:`robodcn.config.rigid_chain` (links, payload, gravity, the rotor's J_rotor·N²·q̈).
Host-side and independent of the simulator: the datasheet figures of the servo model's
record (:mod:`robodcn.servo_models`); firmware_sim keeps its own.

Motor (output-shaft referred, ROBOTIS e-manual datasheet at 12 V: stall torque τ_s, stall
current I_s, no-load speed ω_nl, gear ratio N; friction from an assumed no-load current
i_nl = 0.1·I_s, half Coulomb, half viscous; rotor inertia an estimate for the motor size)::

    u = (τ + b·q̇ + τ_c·sgn q̇)/τ_0 + q̇/ω_0,   i = (u·V − k·q̇)/R,   τ = J·q̈ + τ_load

with R = V/I_s, k = (V − R·i_nl)/ω_nl, ηk = τ_s/(I_s − i_nl/2), τ_0 = ηk·V/R, ω_0 = V/k,
J = J_rotor·N². u is the PWM duty the motor needs (885 = 100 %); a position loop with only a
P gain outputs PWM = KPP·e (KPP = P/128), so following the plan needs the lag e = 885·u/KPP.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodcn.servo_models import SERVO_SPECS, XM430_W350

#: PWM item value of 100 % duty (e-manual).
PWM_FULL = 885
#: Position P Gain at the factory per model (the records' ``default_p_gain``: e-manual,
#: XM430 800, XL430 640).
DEFAULT_P_GAIN: Mapping[str, int] = {name: m.default_p_gain for name, m in SERVO_SPECS.items()}


@dataclass(frozen=True)
class MotorModel:
    """A servo's motor and gearbox at the output shaft (SI); module equations."""

    resistance: float
    k: float
    eta_k: float
    inertia: float
    viscous: float
    coulomb: float
    voltage: float
    stall_current: float

    @classmethod
    def from_datasheet(cls, stall_torque: float, stall_current: float, no_load_rpm: float,
                       gear_ratio: float, rotor_inertia: float, voltage: float = 12.0,
                       no_load_fraction: float = 0.1) -> MotorModel:
        resistance = voltage / stall_current
        omega_nl = no_load_rpm * 2.0 * math.pi / 60.0
        i_nl = no_load_fraction * stall_current
        k = (voltage - resistance * i_nl) / omega_nl
        eta_k = stall_torque / (stall_current - 0.5 * i_nl)
        return cls(resistance, k, eta_k, rotor_inertia * gear_ratio ** 2,
                   0.5 * eta_k * i_nl / omega_nl, 0.5 * eta_k * i_nl, voltage, stall_current)

    def duty_for(self, qd: NDArray[np.float64], torque: NDArray[np.float64],
                 friction_sign: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """PWM duty u (−1..1 within the motor's reach) that delivers ``torque`` (N·m at the
        output, the rotor's own J·q̈ included) at velocity q̇; the Coulomb term on
        ``friction_sign`` (default sgn q̇)."""
        sign = np.sign(qd) if friction_sign is None else friction_sign
        total = torque + self.viscous * qd + self.coulomb * sign
        return total * self.resistance / (self.eta_k * self.voltage) + qd * self.k / self.voltage

    def current_for(self, qd: NDArray[np.float64],
                    torque: NDArray[np.float64]) -> NDArray[np.float64]:
        """Armature current i = (u·V − k·q̇)/R, A, delivering ``torque`` at q̇."""
        return (self.duty_for(qd, torque) * self.voltage - self.k * qd) / self.resistance

    def duty(self, qd: NDArray[np.float64], qdd: NDArray[np.float64],
             load: NDArray[np.float64]) -> NDArray[np.float64]:
        """PWM duty u for velocity, acceleration and a load torque without the rotor."""
        return self.duty_for(qd, self.inertia * qdd + load)

    def current(self, qd: NDArray[np.float64], qdd: NDArray[np.float64],
                load: NDArray[np.float64]) -> NDArray[np.float64]:
        """Armature current i = (u·V − k·q̇)/R, A (load without the rotor)."""
        return self.current_for(qd, self.inertia * qdd + load)


#: The motor model of each servo model, from its record's datasheet figures.
MOTORS: Mapping[str, MotorModel] = {
    name: MotorModel.from_datasheet(m.stall_torque, m.stall_current,
                                    m.rated_speed * 60.0 / (2.0 * math.pi), m.gear_ratio,
                                    rotor_inertia=m.motor_inertia)
    for name, m in SERVO_SPECS.items()}


def motor_of(model: str) -> MotorModel:
    """The motor model of a servo model name (XM430-W350 figures for unknown models)."""
    return MOTORS.get(model, MOTORS[XM430_W350.name])


def derivatives(joints: NDArray[np.float64],
                period: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Joint velocities and accelerations of sampled joints (central differences)."""
    if len(joints) < 3:
        zero = np.zeros_like(joints)
        return zero, zero
    qd = np.gradient(joints, period, axis=0)
    qdd = np.gradient(qd, period, axis=0)
    return qd, qdd


__all__ = ["DEFAULT_P_GAIN", "MOTORS", "PWM_FULL", "MotorModel", "derivatives", "motor_of"]
