"""Hardware errors: the Alert bit, injected trips and faults with a physical cause.

e-manual "Shutdown(63)" / "Hardware Error Status(70)": an error whose bit is set in
Shutdown turns the torque off; the status stays until a reboot, and every status packet
carries the Alert bit (0x80) meanwhile.
"""

from __future__ import annotations

from firmware_sim import control_table as ct
from firmware_sim.control_table import ALERT_BIT
from firmware_sim.servo.live import configure_drive, refresh
from firmware_sim.servo.state import ServoState


def status_error(st: ServoState, code: int) -> int:
    """ERR byte for a status packet: ``code`` plus the alert bit while Hardware Error
    Status is non-zero."""
    return code | ALERT_BIT if st.table.get(ct.HARDWARE_ERROR_STATUS) else code


def trip(st: ServoState, bits: int) -> None:
    """Inject hardware error ``bits``; torque goes off if any is set in Shutdown (63)."""
    t = st.table
    t.set(ct.HARDWARE_ERROR_STATUS, t.get(ct.HARDWARE_ERROR_STATUS) | bits)
    now = st.clock.now()
    if bits & t.get(ct.SHUTDOWN) and t.get(ct.TORQUE_ENABLE):
        t.set(ct.TORQUE_ENABLE, 0)
        st.motion.hold_here(now)
    refresh(st, now)


def physical_fault(st: ServoState, bits: int, t: float) -> None:
    """A fault with a physical cause (overload, overheating, voltage) at time ``t``:
    Hardware Error Status gets ``bits``; Shutdown (63) bits turn the torque off."""
    table = st.table
    old = table.get(ct.HARDWARE_ERROR_STATUS)
    if old & bits == bits and not table.data[ct.TORQUE_ENABLE]:
        return
    table.set(ct.HARDWARE_ERROR_STATUS, old | bits)
    drive = st.motion.drive
    if bits & table.get(ct.SHUTDOWN) and table.data[ct.TORQUE_ENABLE]:
        table.set(ct.TORQUE_ENABLE, 0)
        st.motion.hold_here(t)
        if drive is not None:       # the bridge opens at once
            drive.current = drive.duty = 0.0
    if drive is not None:
        configure_drive(st)
