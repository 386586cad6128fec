"""The Bus Watchdog (98): with torque on, no instruction for value × 20 ms stops the servo.

e-manual "Bus Watchdog(98)": the stop treats the profile as 0/0 (both profile items read
0 afterwards), the item reads −1, and the goal items refuse writes (Data Range Error)
until it is written 0.
"""

from __future__ import annotations

from firmware_sim import control_table as ct
from firmware_sim.control_table import ControlTable
from firmware_sim.profile import hold
from firmware_sim.servo.motion import Motion
from firmware_sim.servo.words import S8

#: Bus Watchdog unit, s (e-manual: 20 ms).
WATCHDOG_UNIT_S = 0.020


class BusWatchdog:
    """Feeding and expiry of one servo's Bus Watchdog."""

    def __init__(self, now: float) -> None:
        self.last_instruction = now
        self.armed_at = now
        self.tripped = False

    def feed(self, now: float) -> None:
        """An instruction addressed to the servo arrived."""
        self.last_instruction = now

    def restart(self, now: float) -> None:
        """Reboot: not tripped, fed now."""
        self.tripped = False
        self.last_instruction = self.armed_at = now

    def deadline(self, table: ControlTable) -> float | None:
        """When the watchdog expires unless fed, or None (off, tripped, torque off)."""
        data = table.data
        wd = S8.unpack_from(data, ct.BUS_WATCHDOG)[0]
        if self.tripped or wd <= 0 or not data[ct.TORQUE_ENABLE]:
            return None
        return max(self.last_instruction, self.armed_at) + wd * WATCHDOG_UNIT_S

    def expire(self, table: ControlTable, motion: Motion, now: float) -> None:
        """Trip if the deadline has passed: the servo stops where the profile was then."""
        deadline = self.deadline(table)
        if deadline is None or deadline > now:
            return
        p, _ = motion.profile.state(deadline)
        motion.profile = hold(deadline, p)
        self.tripped = True
        table.set(ct.BUS_WATCHDOG, -1)
        # e-manual Bus Watchdog example: on the stop both profile items become 0
        table.set(ct.PROFILE_VELOCITY, 0)
        table.set(ct.PROFILE_ACCELERATION, 0)

    def written(self, table: ControlTable, now: float) -> None:
        """The host wrote (98): 0 clears a trip; any write re-arms from now."""
        if table.get(ct.BUS_WATCHDOG) == 0:
            self.tripped = False
        self.armed_at = now
