"""Group reads (the streaming hot path's read side): (Fast) Sync Read of one item from every
servo, and the readings built on it (positions, feedback, hardware errors, watchdog).

Fast Sync Read (0x8A) when every servo's firmware has it, plain Sync Read (0x82)
otherwise. The SDK's fast-sync-read parser ignores the per-servo ERR byte, hiding the Alert
bit (dynamixel-notes §1.7), so the blocks are decoded here
(:func:`robodcn.bus.groups.fast_sync_read_blocks`); every servo's ERR byte and data length
are checked before anything is decoded.

Status packets carry no sequence number: a late reply to an earlier read of the same size
passes every check of the SDK's and ours. So no two kinds of read share a size where a
mix-up could stop the arm: Hardware Error Status is read as the 3 bytes from Status Return
Level (68, 69, 70), whose first two bytes can only be 1–2 and 0–1, never as the 1 byte at 70
that a Bus Watchdog poll's straggler (1 byte at 98: 13 for 250 ms) would answer in its place
— the misread that once ended a move with "hardware error 13" on every servo. Goal Position
likewise is read with Profile Velocity before it (112..119, 8 bytes), never as the 4 bytes a
Present Position read's straggler (the positions at the start of a move) would answer: a
hold written from those would send the arm back.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from dynamixel_sdk import COMM_SUCCESS, GroupSyncRead, PortHandler
from numpy.typing import NDArray

from robodcn.bus.control_table import (
    ADDR_BUS_WATCHDOG,
    ADDR_GOAL_POSITION,
    ADDR_HARDWARE_ERROR,
    ADDR_POSITION_I_GAIN,
    ADDR_PRESENT_POSITION,
    ADDR_PROFILE_VELOCITY,
    ADDR_STATUS_RETURN_LEVEL,
    ADDR_TORQUE_ENABLE,
)
from robodcn.bus.feedback import ADDR_FEEDBACK, FEEDBACK_LENGTH, Feedback, decode_feedback
from robodcn.bus.groups import fast_sync_read_blocks
from robodcn.bus.transactions import Transactions
from robodcn.errors import BusError, CommError, InputError


class Reads(Transactions):
    """(Fast) Sync Reads with bounded retries, and what is read through them."""

    #: Fast Sync Read for group reads (ServoBus; decided by ``verify`` when None).
    fast_read: bool | None
    #: Ids whose last status packet carried the Alert bit (hardware error present).
    last_alert_ids: tuple[int, ...]
    #: Amperes per Present Current unit, bus order (:func:`robodcn.bus.feedback.current_units`).
    _current_units: NDArray[np.float64]

    def _group(self, address: int, length: int, ids: tuple[int, ...]) -> GroupSyncRead:
        def make(port: PortHandler) -> GroupSyncRead:
            group = GroupSyncRead(port, self._packet, address, length)
            for servo_id in ids:
                group.addParam(servo_id)
            return group

        return self._bound(("sync read", address, length, ids), make)

    def _bus_ids(self, ids: Iterable[int] | None) -> tuple[int, ...]:
        """``ids`` (default: every servo) in the order given; InputError for an id not on
        this bus or given twice."""
        if ids is None:
            return self.ids
        chosen = tuple(ids)
        unknown = [i for i in chosen if i not in self.ids]
        if unknown or not chosen or len(set(chosen)) != len(chosen):
            raise InputError(f"servo ids must be distinct ids of this bus ({list(self.ids)}), "
                             f"got {list(chosen)}", field="ids", value=list(chosen))
        return chosen

    def _sync_read_once(self, group: GroupSyncRead, length: int,
                        ids: tuple[int, ...]) -> list[bytes]:
        """One (Fast) Sync Read; raw data per servo in ``ids`` order, ERR/length checked."""
        port = self._port()
        fast = bool(self.fast_read)
        result = group.fastSyncReadTxPacket() if fast else group.txPacket()
        if result != COMM_SUCCESS:
            raise CommError(f"sync read: {self._packet.getTxRxResult(result)}", field="bus",
                            value=result)
        if self.rx_timeout_ms is not None:
            port.setPacketTimeoutMillis(self.rx_timeout_ms)
        alerts = []
        out: list[bytes] = []
        if fast:
            raw, result, _ = self._packet.fastSyncReadRx(port, 0xFE,
                                                         (length + 4) * len(ids))
            if result != COMM_SUCCESS:
                raise CommError(f"fast sync read: {self._packet.getTxRxResult(result)}",
                                field="bus", value=result)
            blocks = fast_sync_read_blocks(raw, ids, length)
            for servo_id, (error, data) in zip(ids, blocks, strict=True):
                if self._status(servo_id, "fast sync read", COMM_SUCCESS, error):
                    alerts.append(servo_id)
                out.append(data)
        else:
            for servo_id in ids:
                data, result, error = self._packet.readRx(port, servo_id, length)
                if self._status(servo_id, "sync read", result, error):
                    alerts.append(servo_id)
                if len(data) != length:
                    raise CommError(f"servo {servo_id}: sync read returned {len(data)} "
                                    f"byte(s), expected {length}", field=f"servo[{servo_id}]",
                                    value=len(data))
                out.append(bytes(data))
        self.last_alert_ids = tuple(alerts)
        return out

    def sync_read(self, address: int, length: int,
                  ids: Iterable[int] | None = None) -> list[bytes]:
        """(Fast) Sync Read of one item from every servo (or from ``ids`` of this bus), with
        bounded retries.

        Returns raw bytes per servo in bus order (``ids`` order); :attr:`last_alert_ids`
        lists the servos whose status carried the Alert bit.
        """
        chosen = self._bus_ids(ids)
        with self.claim():
            group = self._group(address, length, chosen)
            what = ("fast sync read" if self.fast_read else "sync read") + \
                f" {length} byte(s) at {address}"
            return self._retry(what, None,
                               lambda: self._sync_read_once(group, length, chosen))

    def read_positions(self) -> NDArray[np.int64]:
        """Present Position of every servo (ticks, signed), shape (k,) in bus order."""
        raw = self.sync_read(ADDR_PRESENT_POSITION, 4)
        return np.frombuffer(b"".join(raw), dtype="<i4").astype(np.int64)

    def read_feedback(self) -> Feedback:
        """Present Position, Velocity, Current and Hardware Error Status of every servo in
        one (Fast) Sync Read of the Indirect Data block (needs ``configure()``)."""
        if not self.feedback_mapped:
            raise BusError("read_feedback needs configure() first (the feedback map)",
                           field="bus", value=self.port)
        return decode_feedback(self.sync_read(ADDR_FEEDBACK, FEEDBACK_LENGTH),
                               self._current_units)

    def hardware_errors(self) -> dict[int, int]:
        """Hardware Error Status (address 70) per servo id; 0 means healthy.

        Read with Status Return Level and Registered Instruction before it (68..70, a size
        no other read has: module notes), and a reply whose first two bytes are not a
        level (1 or 2: a servo that answers reads) and a flag (0 or 1) is not this read's
        (CommError: a straggler of another read, retried as any failed read)."""
        what = f"hardware error read 3 byte(s) at {ADDR_STATUS_RETURN_LEVEL}"
        raw = self._retry(what, None, lambda: self._hardware_once())
        at = ADDR_HARDWARE_ERROR - ADDR_STATUS_RETURN_LEVEL
        return {servo_id: data[at] for servo_id, data in zip(self.ids, raw, strict=True)}

    def _hardware_once(self) -> list[bytes]:
        with self.claim():
            raw = self._sync_read_once(self._group(ADDR_STATUS_RETURN_LEVEL, 3, self.ids), 3,
                                       self.ids)
        for servo_id, data in zip(self.ids, raw, strict=True):
            if data[0] not in (1, 2) or data[1] not in (0, 1):
                raise CommError(f"servo {servo_id}: the hardware error read's reply starts "
                                f"{data[0]}, {data[1]} (Status Return Level, Registered "
                                "Instruction): a reply to another read",
                                field=f"servo[{servo_id}]", value=list(data))
        return raw

    def read_goals(self) -> NDArray[np.int64]:
        """Goal Position of every servo (ticks, signed), shape (k,) in bus order.

        Read with Profile Velocity before it (112..119, a size no other read has: module
        notes); a reply whose Profile Velocity is not 0..32767 is not this read's
        (CommError, retried)."""
        what = f"goal read 8 byte(s) at {ADDR_PROFILE_VELOCITY}"
        raw = self._retry(what, None, lambda: self._goals_once())
        rows = np.frombuffer(b"".join(raw), dtype="<i4").reshape(len(self.ids), 2)
        at = (ADDR_GOAL_POSITION - ADDR_PROFILE_VELOCITY) // 4
        return rows[:, at].astype(np.int64)

    def _goals_once(self) -> list[bytes]:
        with self.claim():
            raw = self._sync_read_once(self._group(ADDR_PROFILE_VELOCITY, 8, self.ids), 8,
                                       self.ids)
        for servo_id, data in zip(self.ids, raw, strict=True):
            velocity = int.from_bytes(data[:4], "little", signed=True)
            if not 0 <= velocity <= 32767:
                raise CommError(f"servo {servo_id}: the goal read's reply starts with "
                                f"{velocity} as Profile Velocity (0..32767): a reply to "
                                "another read", field=f"servo[{servo_id}]", value=velocity)
        return raw

    def read_position_i_gains(self) -> tuple[int, ...]:
        """Position I Gain (82) of every servo, bus order (one Sync Read; a configured bus
        has them as ``position_i_gains`` already)."""
        raw = self.sync_read(ADDR_POSITION_I_GAIN, 2)
        return tuple(int.from_bytes(data, "little") for data in raw)

    def watchdog_status(self) -> dict[int, int]:
        """Bus Watchdog (address 98) per servo id, signed: -1 means it expired."""
        raw = self.sync_read(ADDR_BUS_WATCHDOG, 1)
        return {servo_id: int.from_bytes(data, "little", signed=True)
                for servo_id, data in zip(self.ids, raw, strict=True)}

    def torque_enabled(self) -> dict[int, bool]:
        """Torque Enable (address 64) per servo id."""
        return {servo_id: bool(self._read_int(servo_id, ADDR_TORQUE_ENABLE, 1))
                for servo_id in self.ids}


__all__ = ["Reads"]
