"""Everything a simulated servo remembers, in one record the behaviour modules share."""

from __future__ import annotations

from dataclasses import dataclass

from firmware_sim.clock import Clock
from firmware_sim.control_table import ControlTable, ModelSpec
from firmware_sim.servo.motion import Motion
from firmware_sim.servo.watchdog import BusWatchdog


@dataclass
class ServoState:
    """One servo's state.

    Attributes
    ----------
    table, spec : the control table and its model's item metadata
    clock : the time source
    motion : profile, drive and shaft (:class:`~firmware_sim.servo.motion.Motion`)
    watchdog : the Bus Watchdog
    firmware : Firmware Version (6), restored by a factory reset
    boot_delay_s : how long the servo ignores the bus after a reboot, s
    boot_time, boot_until : Realtime Tick origin and the end of the boot, s
    registered : a REG_WRITE waiting for ACTION, (address, data)
    backup : the CONTROL_TABLE_BACKUP copy, address → raw bytes
    indirect : how the firmware treats the Indirect Address map (:mod:`.indirect`)
    """

    table: ControlTable
    spec: ModelSpec
    clock: Clock
    motion: Motion
    watchdog: BusWatchdog
    firmware: int
    boot_delay_s: float
    boot_time: float
    boot_until: float
    registered: tuple[int, bytes] | None = None
    backup: dict[int, bytes] | None = None
    indirect: str = "on"
