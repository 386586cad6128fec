"""Current: Goal Current (102) writes, Present Current (126) reads, the Current Limit (38).

Units (e-manual, XM430-W350 control table): Goal Current, Present Current and Current
Limit count 2.69 mA a unit (the model record's
:attr:`~robodcn.servo_models.ServoModel.goal_current_unit`);
Goal Current is signed and "can not be set larger than the Current Limit(38)" — a servo
answers such a write with a Data Range Error, so it is refused here first, naming the
servo, the current and the limit. The XL430-W250 has no current items (Present Load
instead, shown as the current it stands for by :func:`robodcn.bus.feedback.current_units`).

In current control (Operating Mode 0) Goal Current is the goal; in current-based position
control (mode 5) its magnitude limits the current of the position loop, so a gripper
squeezing an object pushes with that current and no more (no overload alert).

:meth:`Currents.write_goal_currents` is one Sync Write for a set of the bus's servos (the
float-teach loop's hot path), :meth:`Currents.write_goal_current` one WRITE to one servo,
which may be a servo of the wire that is not a joint (:mod:`robodcn.bus.single`).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from dynamixel_sdk import COMM_SUCCESS, GroupSyncWrite, PortHandler
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn.bus.control_table import (
    ADDR_CURRENT_LIMIT,
    ADDR_GOAL_CURRENT,
    ADDR_PRESENT_CURRENT,
)
from robodcn.bus.feedback import current_units
from robodcn.bus.reads import Reads
from robodcn.bus.single import Servo, Single
from robodcn.config import ServoSpec
from robodcn.errors import CommError, InputError
from robodcn.servo_models import SERVO_SPECS


def current_unit(spec: ServoSpec) -> float:
    """Amperes a Goal Current unit of ``spec``'s model; InputError for a model without
    current control (field "servo", value its id)."""
    model = SERVO_SPECS.get(spec.model)
    unit = None if model is None else model.goal_current_unit
    if unit is None:
        raise InputError(f"servo {spec.id} ({spec.model}) has no Goal Current (no current "
                         "control)", field="servo", value=spec.id)
    return unit


class Currents(Reads, Single):
    """Goal Current, Present Current and the Current Limit (module docstring)."""

    def current_limit(self, servo: Servo) -> float:
        """The servo's Current Limit (38), A: the largest Goal Current it accepts."""
        spec = self.spec_of(servo)
        unit = current_unit(spec)
        cached = self._current_limit_a.get(spec.id)
        if cached is None:
            cached = self._read_int(spec.id, ADDR_CURRENT_LIMIT, 2) * unit
            self._current_limit_a[spec.id] = cached
        return cached

    def goal_current_units(self, servo: Servo, current_a: float) -> int:
        """``current_a`` (A, signed) in the servo's Goal Current units, rounded.

        Raises InputError (field ``servo[ID].goal_current``, value the current in A) for a
        non-finite current or one whose magnitude exceeds the Current Limit.
        """
        spec = self.spec_of(servo)
        field = f"servo[{spec.id}].goal_current"
        if not _checks.is_finite_real(current_a):
            raise InputError(f"servo {spec.id}: goal current must be a finite number of "
                             f"amperes, got {_checks.show(current_a)}", field=field,
                             value=current_a)
        unit = current_unit(spec)
        limit = self.current_limit(spec)
        units = round(float(current_a) / unit)
        if abs(units) > round(limit / unit):
            raise InputError(f"servo {spec.id}: goal current {float(current_a):.3f} A is above "
                             f"its Current Limit {limit:.3f} A", field=field,
                             value=float(current_a))
        return units

    def write_goal_current(self, servo: Servo, current_a: float) -> int:
        """WRITE Goal Current (102) of one servo (A, signed); returns the units written."""
        spec = self.spec_of(servo)
        units = self.goal_current_units(spec, current_a)
        self._write_int(spec.id, ADDR_GOAL_CURRENT, units, 2)
        return units

    def read_present_current(self, servo: Servo) -> float:
        """Present Current (126) of one servo, A (signed; the XL430's Present Load as the
        current it stands for)."""
        spec = self.spec_of(servo)
        raw = self._read_int(spec.id, ADDR_PRESENT_CURRENT, 2, signed=True)
        return raw * float(current_units([spec.model])[0])

    def read_currents(self, ids: Iterable[int] | None = None) -> NDArray[np.float64]:
        """Present Current of every servo (or of ``ids`` of this bus) in one (Fast) Sync
        Read, A, in bus (``ids``) order."""
        chosen = self._bus_ids(ids)
        raw = self.sync_read(ADDR_PRESENT_CURRENT, 2, chosen)
        units = current_units([self.spec_of(i).model for i in chosen])
        return np.frombuffer(b"".join(raw), dtype="<i2").astype(np.float64) * units

    def _current_group(self, ids: tuple[int, ...]) -> GroupSyncWrite:
        def make(port: PortHandler) -> GroupSyncWrite:
            group = GroupSyncWrite(port, self._packet, ADDR_GOAL_CURRENT, 2)
            for servo_id in ids:
                group.addParam(servo_id, [0, 0])
            return group

        return self._bound(("goal current", ids), make)

    def write_goal_currents(self, currents_a: ArrayLike,
                            ids: Iterable[int] | None = None) -> NDArray[np.int64]:
        """One Sync Write of Goal Current to every servo (or to ``ids`` of this bus).

        ``currents_a`` (A, signed) has one value per servo in bus (``ids``) order; every
        value is checked against its servo's Current Limit before anything is sent
        (:meth:`goal_current_units`). Returns the units written.
        """
        chosen = self._bus_ids(ids)
        values = _checks.as_float_array("currents_a", currents_a)
        if values.shape != (len(chosen),):
            raise InputError(f"currents_a must have shape ({len(chosen)},) (one per servo "
                             f"{list(chosen)}), got shape {values.shape}", field="currents_a",
                             value=values)
        units = np.array([self.goal_current_units(i, a)
                          for i, a in zip(chosen, values.tolist(), strict=True)],
                         dtype=np.int64)
        with self.claim():
            group = self._current_group(chosen)
            for servo_id, value in zip(chosen, units.tolist(), strict=True):
                group.changeParam(servo_id, list(int(value).to_bytes(2, "little", signed=True)))
            result = group.txPacket()
            if result != COMM_SUCCESS:
                raise CommError(f"sync write of goal current: "
                                f"{self._packet.getTxRxResult(result)}", field="bus",
                                value=result)
        return units


__all__ = ["Currents", "current_unit"]
