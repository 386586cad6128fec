"""Configuration before streaming: operating mode, Return Delay Time, profile, the indirect
feedback map, and the check that the map took.

The map (:mod:`robodcn.bus.feedback`) points Indirect Address 29.. at the feedback items so
one group read of Indirect Data 29.. returns them all. A servo that acknowledges the map's
WRITE but does not serve it (an older firmware, a clone) would make every feedback read
return zeros or stale bytes, and the stream would report a tracking error of hundreds of
degrees (issue 17 §4). So :meth:`Configuration.configure` reads the map back and compares
one feedback read through it with Present Position read directly; a difference is a
:class:`~robodcn.errors.FeedbackMapError` naming the servo (CLI exit 4, HTTP 503).
"""

from __future__ import annotations

import logging

import numpy as np

from robodcn.bus.control_table import (
    ADDR_BUS_WATCHDOG,
    ADDR_CURRENT_LIMIT,
    ADDR_GOAL_POSITION,
    ADDR_OPERATING_MODE,
    ADDR_POSITION_D_GAIN,
    ADDR_POSITION_I_GAIN,
    ADDR_POSITION_P_GAIN,
    ADDR_PRESENT_POSITION,
    ADDR_PROFILE_ACCELERATION,
    ADDR_PROFILE_VELOCITY,
    ADDR_RETURN_DELAY_TIME,
    ADDR_TORQUE_ENABLE,
)
from robodcn.bus.feedback import (
    ADDR_FEEDBACK,
    ADDR_INDIRECT_ADDRESS_29,
    FEEDBACK_LENGTH,
    decode_feedback,
    indirect_map,
)
from robodcn.bus.reads import Reads
from robodcn.bus.records import StreamProfile
from robodcn.errors import CommError, FeedbackMapError
from robodcn.servo_models import OPERATING_MODE_POSITION, SERVO_SPECS, XL430_W250

log = logging.getLogger("robodcn.bus")

#: Ticks a position read through the feedback map may lie outside the direct reads taken
#: just before and after it (encoder jitter of a holding servo); the failure it guards
#: against is off by hundreds of ticks (zeros, a stale block).
MAP_CHECK_SLACK_TICKS = 4
#: What to do about a servo that does not serve the map.
_MAP_ADVICE = ("robodcn streams feedback through Indirect Address 29–39, which X-series "
               "firmware serves: update the servo's firmware (DYNAMIXEL Wizard) or use a "
               "genuine X-series servo")


def map_addresses(data: bytes | list[int]) -> list[int]:
    """The target address of each Indirect Address entry in ``data`` (2 bytes an entry)."""
    raw = bytes(data)
    return [int.from_bytes(raw[i:i + 2], "little") for i in range(0, len(raw) - 1, 2)]


class Configuration(Reads):
    """:meth:`configure` and the indirect feedback map it writes and checks."""

    #: Per servo, read by :meth:`configure`: Position P, I and D Gains, Current Limit (A;
    #: the stall current where the model has no such item).
    position_p_gains: tuple[int, ...] | None
    position_i_gains: tuple[int, ...] | None
    position_d_gains: tuple[int, ...] | None
    current_limits: tuple[float, ...] | None

    def configure(self, profile: StreamProfile | None = None) -> None:
        """Make the servos ready to stream, without moving them.

        Operating Mode 3 (position) and Return Delay Time live in EEPROM, which is locked
        while torque is on: only when one of them differs is torque switched off, and only
        the differing items are written (sparing the EEPROM and never letting a holding arm
        sag for nothing). Then: Bus Watchdog cleared; Profile Acceleration and Velocity
        (after the mode, whose change resets them); Goal Position := Present Position, so
        torque-on holds where the arm is; the feedback map; torque on; the map checked
        (:meth:`_check_feedback_map`).

        Raises
        ------
        FeedbackMapError when a servo accepted the feedback map but does not serve it; the
        arm is left holding where it is and :attr:`configured` stays False.
        """
        profile = StreamProfile() if profile is None else profile
        rdt = profile.return_delay_us // 2
        with self.claim():
            changes = []
            for servo_id in self.ids:
                if self._read_int(servo_id, ADDR_OPERATING_MODE, 1) != OPERATING_MODE_POSITION:
                    changes.append((servo_id, ADDR_OPERATING_MODE, OPERATING_MODE_POSITION))
                if self._read_int(servo_id, ADDR_RETURN_DELAY_TIME, 1) != rdt:
                    changes.append((servo_id, ADDR_RETURN_DELAY_TIME, rdt))
            if changes:
                self._write_all(ADDR_TORQUE_ENABLE, 0, 1)
                for servo_id, address, value in changes:
                    self._write_int(servo_id, address, value, 1)
            self._write_all(ADDR_BUS_WATCHDOG, 0, 1)
            self.watchdog_ms = 0
            self._write_all(ADDR_PROFILE_ACCELERATION, profile.acceleration, 4)
            self._write_all(ADDR_PROFILE_VELOCITY, profile.velocity, 4)
            for servo_id in self.ids:
                present = self._read_int(servo_id, ADDR_PRESENT_POSITION, 4, signed=True)
                self._write_int(servo_id, ADDR_GOAL_POSITION, present, 4)
            self._read_gains()
            self._map_feedback()
            self._write_all(ADDR_TORQUE_ENABLE, 1, 1)
            if self.feedback_mapped:
                try:
                    self._check_feedback_map()
                except FeedbackMapError:
                    self.feedback_mapped = False
                    raise
            self.configured = True

    def _read_gains(self) -> None:
        """Position P, I and D Gains and the current limit of every servo."""
        gains, i_gains, d_gains, limits = [], [], [], []
        for spec in self.servos:
            gains.append(self._read_int(spec.id, ADDR_POSITION_P_GAIN, 2))
            i_gains.append(self._read_int(spec.id, ADDR_POSITION_I_GAIN, 2))
            d_gains.append(self._read_int(spec.id, ADDR_POSITION_D_GAIN, 2))
            model = SERVO_SPECS.get(spec.model, XL430_W250)
            if model.goal_current_unit is not None:
                limits.append(self._read_int(spec.id, ADDR_CURRENT_LIMIT, 2)
                              * model.goal_current_unit)
            else:
                limits.append(model.stall_current)
        self.position_p_gains = tuple(gains)
        self.position_i_gains = tuple(i_gains)
        self.position_d_gains = tuple(d_gains)
        self.current_limits = tuple(limits)

    def _map_feedback(self) -> None:
        """Indirect Address 29.. → the feedback items (:mod:`robodcn.bus.feedback`).

        A servo that refuses the map (an error status) leaves the plain position reads.
        """
        payload = indirect_map()
        try:
            for servo_id in self.ids:
                self.write(servo_id, ADDR_INDIRECT_ADDRESS_29, payload)
        except CommError as exc:
            log.warning("feedback map refused (%s); reading positions only", exc.message)
            self.feedback_mapped = False
            return
        self.feedback_mapped = True

    def _check_feedback_map(self) -> None:
        """Raise FeedbackMapError unless every servo serves the map it acknowledged.

        Two checks, servo by servo in bus order: the map read back (READ at Indirect
        Address 29) is the map written; one group read of the feedback block, between two
        group reads of Present Position (132) directly, has each servo's position within
        [min, max] of the direct reads ± :data:`MAP_CHECK_SLACK_TICKS` (the arm may move
        meanwhile: the direct reads bracket it).
        """
        payload = indirect_map()
        written = map_addresses(payload)
        for servo_id in self.ids:
            got = map_addresses(self.read(servo_id, ADDR_INDIRECT_ADDRESS_29, len(payload)))
            if got != written:
                entry = next(k for k, (a, b) in enumerate(zip(got, written, strict=True))
                             if a != b)
                raise FeedbackMapError(
                    f"servo {servo_id} does not serve the indirect feedback map: Indirect "
                    f"Address {29 + entry} (address {ADDR_INDIRECT_ADDRESS_29 + 2 * entry}) "
                    f"reads back {got[entry]} where {written[entry]} was written (an older "
                    f"firmware or a clone?); {_MAP_ADVICE}",
                    servo_id=servo_id, item="indirect_address", expected=written, got=got)
        before = self.read_positions()
        through = decode_feedback(self.sync_read(ADDR_FEEDBACK, FEEDBACK_LENGTH),
                                  self._current_units).positions
        after = self.read_positions()
        low = np.minimum(before, after) - MAP_CHECK_SLACK_TICKS
        high = np.maximum(before, after) + MAP_CHECK_SLACK_TICKS
        for servo_id, value, direct, lo, hi in zip(self.ids, through, after, low, high,
                                                   strict=True):
            if not lo <= value <= hi:
                raise FeedbackMapError(
                    f"servo {servo_id}: the indirect feedback map reads Present Position "
                    f"{int(value)} where a direct read gives {int(direct)} ticks (an older "
                    f"firmware or a clone?); {_MAP_ADVICE}",
                    servo_id=servo_id, item="present_position", expected=int(direct),
                    got=int(value))


__all__ = ["MAP_CHECK_SLACK_TICKS", "Configuration", "map_addresses"]
