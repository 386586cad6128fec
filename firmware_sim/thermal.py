"""First-order thermal model of a servo's winding: C·dT/dt = i²·R − (T − T_amb)/R_th.

With τ = R_th·C and constant power P the solution is
T(t) = T_∞ + (T₀ − T_∞)·e^(−t/τ), T_∞ = T_amb + P·R_th; :meth:`Thermal.advance` uses it
exactly, so a long quiet stretch costs one call. Present Temperature (146) reads T in °C;
above Temperature Limit (31) the firmware sets the Overheating bit (e-manual).
"""

from __future__ import annotations

import math

#: Ambient temperature, °C (the control table's power-up Present Temperature reading).
AMBIENT_C = 30.0


class Thermal:
    """Winding temperature of one servo.

    Parameters
    ----------
    resistance : float
        Thermal resistance winding → ambient, K/W.
    time_constant : float
        τ, s.
    ambient : float
        °C.
    """

    __slots__ = ("ambient", "resistance", "temperature", "time_constant")

    def __init__(self, resistance: float, time_constant: float,
                 ambient: float = AMBIENT_C) -> None:
        self.resistance = float(resistance)
        self.time_constant = float(time_constant)
        self.ambient = float(ambient)
        self.temperature = float(ambient)

    def step(self, power_w: float, dt: float) -> float:
        """Explicit step (dt ≪ τ); returns the new temperature, °C."""
        t = self.temperature
        self.temperature = t + dt * (power_w * self.resistance - (t - self.ambient)) \
            / self.time_constant
        return self.temperature

    def advance(self, power_w: float, dt: float) -> float:
        """Exact step under constant power; returns the new temperature, °C."""
        final = self.ambient + power_w * self.resistance
        self.temperature = final + (self.temperature - final) * math.exp(-dt / self.time_constant)
        return self.temperature

    def time_to_reach(self, power_w: float, limit: float) -> float:
        """Seconds until T reaches ``limit`` under constant power (inf if never)."""
        final = self.ambient + power_w * self.resistance
        if self.temperature >= limit:
            return 0.0
        if final <= limit:
            return math.inf
        return self.time_constant * math.log((final - self.temperature) / (final - limit))
