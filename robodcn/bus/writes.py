"""Writes that act on the servos: goals (the streaming hot path's Sync Write), torque,
REBOOT and the Bus Watchdog.

Goals are checked against the servos' position limits before anything is sent (a servo
refuses rather than clamps a goal outside them, dynamixel-notes §2) and encoded once per
trajectory (:func:`robodcn.bus.groups.encode_rows`), so the loop only hands lists to the SDK.

Bus Watchdog: ``configure()`` clears it; :func:`robodcn.stream.execute` arms it for the
duration of a stream (:meth:`Writes.arm_watchdog`) and disarms it afterwards, so servos
stop by themselves if the host dies mid-stream but an idle, holding arm never trips it.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence

import numpy as np
from dynamixel_sdk import COMM_SUCCESS, GroupSyncWrite, PortHandler
from numpy.typing import ArrayLike, NDArray

from robodcn.bus.control_table import (
    ADDR_BUS_WATCHDOG,
    ADDR_GOAL_POSITION,
    ADDR_TORQUE_ENABLE,
    WATCHDOG_MAX,
    WATCHDOG_UNIT_MS,
)
from robodcn.bus.groups import check_ticks, encode_rows
from robodcn.bus.transactions import Transactions
from robodcn.errors import CommError, InputError


class Writes(Transactions):
    """Goal Position by Sync Write, torque on/off, REBOOT, Bus Watchdog."""

    #: Position limits (ticks) per servo, shape (k, 2), bus order (ServoBus; ``verify``).
    limits: NDArray[np.int64]

    # -- goals -------------------------------------------------------------------------------

    def check_ticks(self, ticks: ArrayLike) -> NDArray[np.int64]:
        """``ticks`` (n, k) or (k,) as int64, every value inside :attr:`limits`.

        Raises TickLimitError naming the first sample and servo outside its limits.
        """
        return check_ticks(ticks, self.limits, self.ids)

    def encode_goals(self, ticks: ArrayLike) -> list[list[list[int]]]:
        """Goal ticks (n, k) → per sample, per servo, the 4 little-endian bytes to send.

        Vectorised once per trajectory so the streaming loop only hands lists to the SDK.
        Checks the limits first (:meth:`check_ticks`).
        """
        return encode_rows(self.check_ticks(np.atleast_2d(np.asarray(ticks))))

    def _goal_group(self) -> GroupSyncWrite:
        """The Sync Write of Goal Position (4 bytes) to every servo, on the open handler."""
        def make(port: PortHandler) -> GroupSyncWrite:
            group = GroupSyncWrite(port, self._packet, ADDR_GOAL_POSITION, 4)
            for servo_id in self.ids:
                group.addParam(servo_id, [0, 0, 0, 0])
            return group

        return self._bound("goal", make)

    def write_encoded(self, row: Sequence[Sequence[int]]) -> None:
        """One Sync Write of Goal Position from :meth:`encode_goals` output (one sample)."""
        with self.claim():
            group = self._groups.get("goal")
            if group is None or self.lost:
                group = self._goal_group()     # raises for a lost or closed port
            for servo_id, data in zip(self.ids, row, strict=True):
                group.changeParam(servo_id, data)
            result = group.txPacket()
            if result != COMM_SUCCESS:
                raise CommError(f"sync write: {self._packet.getTxRxResult(result)}",
                                field="bus", value=result)

    def write_goals(self, ticks: ArrayLike) -> None:
        """Sync Write Goal Position (ticks, shape (k,), bus order) after a limit check."""
        self.write_encoded(self.encode_goals(np.asarray(ticks).reshape(1, -1))[0])

    # -- torque and reboot -------------------------------------------------------------------

    def torque(self, on: bool, ids: Iterable[int] | None = None) -> None:
        """Torque Enable on ``ids`` (default: every servo); off releases the arm: it may fall.

        An id not on this bus is an InputError before anything is written.
        """
        if ids is None:
            self._write_all(ADDR_TORQUE_ENABLE, 1 if on else 0, 1)
        else:
            chosen = tuple(ids)
            unknown = [i for i in chosen if i not in self.ids]
            if unknown:
                raise InputError(f"servo id(s) {unknown} are not on this bus (ids "
                                 f"{list(self.ids)})", field="ids", value=unknown)
            for servo_id in chosen:
                self._write_int(servo_id, ADDR_TORQUE_ENABLE, 1 if on else 0, 1)
        if not on:
            self.configured = False

    def reboot(self, servo_ids: Iterable[int] | None = None, *, timeout: float = 2.0) -> None:
        """REBOOT servos (default: all) and wait until each answers a ping again.

        The only way to clear a Hardware Error Status (overload, overheating ...): the servo
        comes back with torque off and RAM at defaults, so ``configure()`` is due again.
        """
        ids = self.ids if servo_ids is None else tuple(servo_ids)
        with self.claim():
            port = self._port()
            for servo_id in ids:
                result, error = self._packet.reboot(port, servo_id)
                self._status(servo_id, "reboot", result, error)
            self._forget_configuration()
            deadline = time.monotonic() + timeout
            for servo_id in ids:
                while True:
                    _, result, _ = self._packet.ping(port, servo_id)
                    if result == COMM_SUCCESS:
                        break
                    if time.monotonic() > deadline:
                        raise CommError(f"servo {servo_id} did not answer within {timeout} s "
                                        "of its reboot", field=f"servo[{servo_id}]",
                                        value=timeout)
                    time.sleep(0.01)

    # -- Bus Watchdog ------------------------------------------------------------------------

    def arm_watchdog(self, timeout_ms: float) -> int:
        """Arm the Bus Watchdog: servos stop if no instruction arrives for ``timeout_ms``.

        Rounded up to the 20 ms unit, within [20, 2540] ms; returns the armed value in ms.
        Writes 0 first, which also clears a tripped watchdog.
        """
        units = int(min(WATCHDOG_MAX, max(1, -(-float(timeout_ms) // WATCHDOG_UNIT_MS))))
        self._write_all(ADDR_BUS_WATCHDOG, 0, 1)
        self._write_all(ADDR_BUS_WATCHDOG, units, 1)
        self.watchdog_ms = units * WATCHDOG_UNIT_MS
        return self.watchdog_ms

    def disarm_watchdog(self) -> None:
        """Bus Watchdog off (0); also makes goals writable again after a trip."""
        self._write_all(ADDR_BUS_WATCHDOG, 0, 1)
        self.watchdog_ms = 0


__all__ = ["Writes"]
