"""One simulated X-series servo (:class:`Servo`), split by concept into private modules.

:mod:`.core` is the servo the bus talks to; :mod:`.access` the table's read/write rules,
:mod:`.effects` what accepted writes do, :mod:`.live` the live items, :mod:`.motion` the
profile and position frames, :mod:`.watchdog` the Bus Watchdog, :mod:`.alerts` hardware
errors, :mod:`.maintenance` reboot/reset/clear/backup, :mod:`.environment` the outside
world, :mod:`.coupling` an arm's shared plant, :mod:`.indirect` how far the firmware
serves the Indirect Address map.
"""

from firmware_sim.servo.core import BOOT_DELAY_S, Servo
from firmware_sim.servo.coupling import couple_arm
from firmware_sim.servo.indirect import INDIRECT_MODES, indirect_mode
from firmware_sim.servo.maintenance import (
    BACKUP_MAGIC,
    BACKUP_MIN_FIRMWARE,
    BACKUP_RESTORE,
    BACKUP_STORE,
    CLEAR_MULTI_TURN,
    RESET_ALL,
    RESET_KEEP_ID,
    RESET_KEEP_ID_BAUD,
    STARTUP_RAM_RESTORE,
    STARTUP_TORQUE_ON,
)
from firmware_sim.servo.motion import PULSES_PER_REV
from firmware_sim.servo.watchdog import WATCHDOG_UNIT_S

__all__ = [
    "BACKUP_MAGIC",
    "BACKUP_MIN_FIRMWARE",
    "BACKUP_RESTORE",
    "BACKUP_STORE",
    "BOOT_DELAY_S",
    "CLEAR_MULTI_TURN",
    "INDIRECT_MODES",
    "PULSES_PER_REV",
    "RESET_ALL",
    "RESET_KEEP_ID",
    "RESET_KEEP_ID_BAUD",
    "STARTUP_RAM_RESTORE",
    "STARTUP_TORQUE_ON",
    "WATCHDOG_UNIT_S",
    "Servo",
    "couple_arm",
    "indirect_mode",
]
