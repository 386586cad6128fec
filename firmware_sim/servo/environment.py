"""The world outside the servo (physics model): a hand on the shaft, an external torque,
an obstacle, the supply voltage.

Obstacles are in joint degrees when an arm file maps the servo to a joint (its
zero_offset and direction); otherwise in the servo's own angle, tick 2048 = 0°.
"""

from __future__ import annotations

import math

from firmware_sim import control_table as ct
from firmware_sim.servo.state import ServoState


def check_supply(volts: float) -> float:
    """``volts`` as a float, or ValueError outside (0, 30] V."""
    if not (math.isfinite(volts) and 0 < volts <= 30):
        raise ValueError(f"supply_voltage must be in (0, 30] V, got {volts!r}")
    return float(volts)


def set_supply(st: ServoState, volts: float) -> None:
    """The supply voltage, V."""
    volts = check_supply(volts)
    if st.motion.drive is None:
        raise RuntimeError("supply_voltage needs the physics model (dynamics=True)")
    st.motion.drive.supply_voltage = volts


def backdrive(st: ServoState, servo_id: int, ticks: int) -> None:
    """Move the output shaft by hand so Present Position reads ``ticks`` (torque off).

    Raises
    ------
    RuntimeError
        While torque is on (the servo would fight the hand).
    """
    if st.table.data[ct.TORQUE_ENABLE]:
        raise RuntimeError(f"servo {servo_id}: torque is on; turn it off before "
                           "moving the shaft by hand")
    if not -(1 << 31) <= int(ticks) < (1 << 31):
        raise ValueError(f"ticks must fit Present Position (int32), got {ticks!r}")
    st.motion.place(st.clock.now(), int(ticks))


def push(st: ServoState, torque_nm: float) -> None:
    """External torque on the output shaft, N·m, in the present frame's positive sense."""
    if not math.isfinite(torque_nm):
        raise ValueError(f"torque_nm must be finite, got {torque_nm!r}")
    if st.motion.drive is None:
        raise RuntimeError("push needs the physics model (dynamics=True)")
    st.motion.drive.external_torque = st.motion.sign() * float(torque_nm)


def set_obstacle(st: ServoState, degrees: float | None) -> None:
    """Block the joint beyond ``degrees`` on the far side from where it is now (module
    notes for the angle); None removes the obstacle."""
    if degrees is not None and not math.isfinite(degrees):
        raise ValueError(f"obstacle angle must be finite degrees, got {degrees!r}")
    plant = st.motion.plant
    if plant is None:
        raise RuntimeError("obstacles need the physics model (dynamics=True)")
    plant.set_obstacle(st.motion.joint, degrees)
