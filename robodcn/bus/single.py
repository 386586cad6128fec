"""One servo by id or by spec: the servos a bus drives, and the others on the same wire.

A :class:`~robodcn.bus.ServoBus` streams to the arm's joints (its ``servos``), but the wire
may carry more: the OpenMANIPULATOR-X's gripper (id 15) sits on the joints' bus without
being one of them. The unicast methods here take either a joint's id (its spec is the
bus's) or the :class:`~robodcn.config.ServoSpec` of another servo on the wire (a
``[gripper]`` servo), so one open port serves both without a second bus on the device.

Goal Position writes are checked against the servo's tick limits (for a joint: the limits
:meth:`ServoBus.verify` read; for another servo: its spec's ``min_tick``/``max_tick``)
before anything is sent: a servo refuses rather than clamps a goal outside them.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from robodcn import _checks
from robodcn.bus.control_table import (
    ADDR_BAUD_RATE,
    ADDR_GOAL_POSITION,
    ADDR_HARDWARE_ERROR,
    ADDR_ID,
    ADDR_OPERATING_MODE,
    ADDR_PRESENT_INPUT_VOLTAGE,
    ADDR_PRESENT_POSITION,
    ADDR_PRESENT_TEMPERATURE,
    ADDR_TORQUE_ENABLE,
)
from robodcn.bus.transactions import Transactions
from robodcn.config import ServoSpec
from robodcn.errors import InputError, TickLimitError

#: A servo named by its id on the bus or by its spec (a servo of the wire, not a joint).
Servo = int | ServoSpec


class Single(Transactions):
    """Unicast reads and writes of one servo, named by id or spec (module docstring)."""

    #: Position limits (ticks) per servo, shape (k, 2), bus order (ServoBus; ``verify``).
    limits: NDArray[np.int64]

    def spec_of(self, servo: Servo) -> ServoSpec:
        """The spec of ``servo``: a bus id's spec, or the given spec of another servo.

        Raises InputError for an id not on this bus (pass the servo's spec instead) or a
        spec whose id is a joint's with another spec.
        """
        if isinstance(servo, ServoSpec):
            if servo.id in self.ids and servo != self.servos[self.ids.index(servo.id)]:
                raise InputError(f"servo {servo.id} is a joint of this bus with another "
                                 "spec; name it by its id", field="servo", value=servo.id)
            return servo
        if not _checks.is_int(servo) or int(servo) not in self.ids:
            raise InputError(f"servo {servo!r} is not on this bus (ids {list(self.ids)}); "
                             "give the spec of a servo that is not a joint",
                             field="servo", value=servo)
        return self.servos[self.ids.index(int(servo))]

    def tick_limits(self, servo: Servo) -> tuple[int, int]:
        """[min, max] Goal Position (ticks) of ``servo``: a joint's verified limits, another
        servo's spec limits."""
        spec = self.spec_of(servo)
        if spec.id in self.ids:
            low, high = self.limits[self.ids.index(spec.id)]
            return int(low), int(high)
        return spec.min_tick, spec.max_tick

    def read_position(self, servo: Servo) -> int:
        """Present Position (132) of one servo, ticks (signed)."""
        spec = self.spec_of(servo)
        return self._read_int(spec.id, ADDR_PRESENT_POSITION, 4, signed=True)

    def read_goal_position(self, servo: Servo) -> int:
        """Goal Position (116) of one servo, ticks (signed): where it is sent."""
        spec = self.spec_of(servo)
        return self._read_int(spec.id, ADDR_GOAL_POSITION, 4, signed=True)

    def read_torque_enabled(self, servo: Servo) -> bool:
        """Torque Enable (64) of one servo."""
        spec = self.spec_of(servo)
        return bool(self._read_int(spec.id, ADDR_TORQUE_ENABLE, 1))

    def write_torque_enabled(self, servo: Servo, on: bool) -> None:
        """Torque Enable (64) of one servo, on this bus's wire or not (a gripper): off lets
        a hand move it."""
        spec = self.spec_of(servo)
        self._write_int(spec.id, ADDR_TORQUE_ENABLE, 1 if on else 0, 1)

    def write_goal_position(self, servo: Servo, tick: int) -> None:
        """Goal Position (116) of one servo, after the check against :meth:`tick_limits`.

        Raises InputError for a tick that is not an integer, TickLimitError (field "ticks",
        value the tick) outside the limits; nothing is sent then.
        """
        spec = self.spec_of(servo)
        if not _checks.is_int(tick):
            raise InputError(f"servo {spec.id}: a goal position must be an integer tick, got "
                             f"{_checks.show(tick)}", field="ticks", value=tick)
        low, high = self.tick_limits(spec)
        if not low <= int(tick) <= high:
            raise TickLimitError(f"servo {spec.id} goal {int(tick)} is outside its limits "
                                 f"[{low}, {high}] ticks", field="ticks", value=int(tick))
        self._write_int(spec.id, ADDR_GOAL_POSITION, int(tick), 4)

    def hold_in_place(self, servo: Servo) -> int:
        """Goal Position (116) := Present Position (132) of one servo, so torque-on (or an
        overload recovery) holds it where it is instead of jumping to a stale goal. Not
        checked against the tick limits: the servo is at that tick already. Returns it."""
        spec = self.spec_of(servo)
        present = self._read_int(spec.id, ADDR_PRESENT_POSITION, 4, signed=True)
        self._write_int(spec.id, ADDR_GOAL_POSITION, present, 4)
        return present

    def read_operating_mode(self, servo: Servo) -> int:
        """Operating Mode (11) of one servo (:data:`robodcn.servo_models.OPERATING_MODE_NAMES`)."""
        return self._read_int(self.spec_of(servo).id, ADDR_OPERATING_MODE, 1)

    def read_hardware_error(self, servo: Servo) -> int:
        """Hardware Error Status (70) bits of one servo (0: none)."""
        return self._read_int(self.spec_of(servo).id, ADDR_HARDWARE_ERROR, 1)

    def read_input_voltage(self, servo: Servo) -> float:
        """Present Input Voltage (144) of one servo, V (0.1 V a unit)."""
        return self._read_int(self.spec_of(servo).id, ADDR_PRESENT_INPUT_VOLTAGE, 2) / 10.0

    def read_temperature(self, servo: Servo) -> int:
        """Present Temperature (146) of one servo, °C."""
        return self._read_int(self.spec_of(servo).id, ADDR_PRESENT_TEMPERATURE, 1)

    def write_id(self, servo: Servo, new_id: int) -> None:
        """ID (7, EEPROM) of one servo := ``new_id``; its torque must be off (EEPROM lock).
        The caller checks that ``new_id`` is free and that the servo answers at it after."""
        self._write_int(self.spec_of(servo).id, ADDR_ID, int(new_id), 1)

    def write_baud_index(self, servo: Servo, index: int) -> None:
        """Baud Rate (8, EEPROM) of one servo := item value ``index``
        (:data:`~robodcn.bus.control_table.BAUD_INDEX`); its torque must be off. The servo
        answers at the new rate from then on."""
        self._write_int(self.spec_of(servo).id, ADDR_BAUD_RATE, int(index), 1)


__all__ = ["Servo", "Single"]
