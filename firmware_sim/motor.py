"""DC motor and gearbox of an X-series servo, parametrised from its datasheet figures.

Output-shaft referred, quasi-static electrics (the winding inductance's L/R of ~0.1 ms is far
below the mechanical time constant, so it is neglected)::

    i     = (u·V − k·ω) / R                    armature current, u = PWM duty in [−1, 1]
    τ_out = η·k·i − b·ω − τ_c·sgn ω            torque at the output shaft
    J     = J_rotor · N²                       rotor inertia seen at the output

Datasheet figures at a rated voltage V₀ (stall torque τ_s, stall current I_s, no-load speed
ω_nl, gear ratio N) fix the five unknowns with two stated assumptions, a no-load current of
``no_load_fraction``·I_s and a Coulomb share ``coulomb_share`` of the no-load friction::

    R = V₀ / I_s
    k = (V₀ − R·i_nl) / ω_nl                   (no load: V₀ = R·i_nl + k·ω_nl)
    η·k = τ_s / (I_s − share·i_nl)              (stall: τ_s = η·k·I_s − τ_c)
    τ_c = share·η·k·i_nl,  b = (1 − share)·η·k·i_nl / ω_nl

so full PWM at V₀ gives exactly the datasheet no-load speed and stall torque.
Sources: ROBOTIS e-manual XM430-W350 / XL430-W250 specifications (12 V figures).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

#: Present/Goal Current unit on the XM430, A (e-manual: 2.69 mA).
CURRENT_UNIT_A = 2.69e-3
#: PWM item value of 100 % duty (e-manual: 885 = 100 %).
PWM_FULL = 885
#: Present Input Voltage unit, V (0.1 V).
VOLTAGE_UNIT_V = 0.1


@dataclass(frozen=True)
class MotorParams:
    """A servo's motor and gearbox, referred to the output shaft (SI units).

    Attributes
    ----------
    resistance : float
        Winding resistance R, Ω.
    k : float
        Back-EMF constant at the output, V·s/rad (= ideal torque constant, N·m/A).
    efficiency : float
        Gearbox efficiency η (torque delivered = η·k·i).
    rotor_inertia : float
        Rotor inertia at the motor, kg·m².
    gear_ratio : float
        N (motor turns per output turn).
    viscous : float
        b, N·m·s/rad at the output.
    coulomb : float
        τ_c, N·m at the output.
    rated_voltage : float
        Voltage of the datasheet figures, V.
    stall_current : float
        Datasheet stall current at the rated voltage, A (Present Load's 100 %).
    thermal_resistance : float
        Winding-to-ambient thermal resistance, K/W.
    thermal_time_constant : float
        First-order thermal time constant, s.
    """

    resistance: float
    k: float
    efficiency: float
    rotor_inertia: float
    gear_ratio: float
    viscous: float
    coulomb: float
    rated_voltage: float
    stall_current: float
    thermal_resistance: float = 8.0
    thermal_time_constant: float = 300.0

    @property
    def inertia(self) -> float:
        """Rotor inertia seen at the output shaft, J_rotor·N², kg·m²."""
        return self.rotor_inertia * self.gear_ratio ** 2

    @property
    def torque_gain(self) -> float:
        """η·k: output torque per ampere, N·m/A."""
        return self.efficiency * self.k

    @property
    def emf_damping(self) -> float:
        """η·k²/R: the back-EMF's viscous torque at full drive, N·m·s/rad."""
        return self.efficiency * self.k * self.k / self.resistance

    def current(self, duty: float, omega: float, voltage: float) -> float:
        """Armature current i = (u·V − k·ω)/R, A."""
        return (duty * voltage - self.k * omega) / self.resistance

    def no_load_speed(self, voltage: float) -> float:
        """Steady speed at full duty with no load, rad/s (friction included)."""
        # η·k·(V − kω)/R = b·ω + τ_c
        return ((self.torque_gain * voltage / self.resistance - self.coulomb)
                / (self.emf_damping + self.viscous))

    def stall_torque(self, voltage: float) -> float:
        """Torque at full duty and ω = 0 (what it can push against), N·m."""
        return self.torque_gain * voltage / self.resistance - self.coulomb


def from_datasheet(stall_torque: float, stall_current: float, no_load_rpm: float,
                   gear_ratio: float, voltage: float, rotor_inertia: float, *,
                   no_load_fraction: float = 0.1, coulomb_share: float = 0.5,
                   thermal_resistance: float = 8.0,
                   thermal_time_constant: float = 300.0) -> MotorParams:
    """Motor parameters that reproduce the datasheet stall and no-load points (module notes).

    Parameters
    ----------
    stall_torque : float
        N·m at the output, at ``voltage``.
    stall_current : float
        A, at ``voltage``.
    no_load_rpm : float
        Output rpm at ``voltage``.
    gear_ratio : float
        N.
    voltage : float
        The datasheet's supply, V.
    rotor_inertia : float
        kg·m² at the motor (not in the datasheet: an estimate for the motor size).
    no_load_fraction, coulomb_share : float
        Assumptions: no-load current as a fraction of the stall current, and the part of
        the no-load friction that is Coulomb rather than viscous.
    """
    resistance = voltage / stall_current
    omega_nl = no_load_rpm * 2 * math.pi / 60
    i_nl = no_load_fraction * stall_current
    k = (voltage - resistance * i_nl) / omega_nl
    eta_k = stall_torque / (stall_current - coulomb_share * i_nl)
    coulomb = coulomb_share * eta_k * i_nl
    viscous = (1 - coulomb_share) * eta_k * i_nl / omega_nl
    return MotorParams(resistance, k, eta_k / k, rotor_inertia, gear_ratio, viscous, coulomb,
                       voltage, stall_current, thermal_resistance, thermal_time_constant)


#: Per model: datasheet figures at 12 V (ROBOTIS e-manual). Rotor inertias are estimates for
#: the motor sizes (a coreless ø13 mm motor in the XM430, a cored one in the XL430).
MOTORS: Mapping[str, MotorParams] = MappingProxyType({
    "xm430-w350": from_datasheet(4.1, 2.3, 46.0, 353.5, 12.0, rotor_inertia=1.0e-7),
    "xl430-w250": from_datasheet(1.5, 1.4, 61.0, 258.5, 12.0, rotor_inertia=6.0e-8),
})
#: Default supply voltage, V (the datasheet figures' 12 V).
DEFAULT_SUPPLY_V = 12.0
