"""Transactions with one servo: READ and WRITE, checked before anything is decoded.

Defensive decoding (dynamixel-notes §4): the SDK hands back the CRC bytes as "data" when a
servo answers a READ with an error status and no parameters, so every read here checks the
SDK result, the ERR byte (error number and Alert bit) and the data length first
(:meth:`Transactions._status`). Each transaction goes through the one retry helper
(:func:`robodcn.bus.retry.retry`).

Waiting for a status packet sleeps in ``select`` (a 1 ms pyserial read timeout, set by
:func:`robodcn.bus.port.open_handler`) instead of the SDK's busy poll; ``rx_timeout_ms``
replaces the SDK's own status timeout (≥ 34 ms) when given.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TypeVar

from dynamixel_sdk import COMM_SUCCESS, PortHandler

from robodcn.bus.connection import Connection
from robodcn.bus.control_table import ALERT_BIT
from robodcn.bus.retry import retry
from robodcn.errors import CommError

T = TypeVar("T")


def le_bytes(value: int, size: int) -> list[int]:
    """Little-endian bytes of ``value`` (two's complement for negative values)."""
    return list(int(value).to_bytes(size, "little", signed=value < 0))


class Transactions(Connection):
    """READ/WRITE of one servo and the error-status check every reply passes."""

    def _status(self, servo_id: int, what: str, result: int, error: int) -> bool:
        """Raise CommError for a failed transaction or an error status; True on Alert."""
        if result != COMM_SUCCESS:
            raise CommError(f"servo {servo_id}: {what}: {self._packet.getTxRxResult(result)}",
                            field=f"servo[{servo_id}]", value=result)
        if error & ~ALERT_BIT & 0xFF:
            raise CommError(f"servo {servo_id}: {what}: "
                            f"{self._packet.getRxPacketError(error & ~ALERT_BIT)} "
                            f"(status error 0x{error:02x})", field=f"servo[{servo_id}]",
                            value=error)
        return bool(error & ALERT_BIT)

    def _retry(self, what: str, servo_id: int | None, fn: Callable[[], T], *,
               silence_expected: bool = False) -> T:
        """``fn()`` through :func:`robodcn.bus.retry.retry` on this bus (open, not lost)."""
        self._port()
        return retry(self, what, servo_id, fn, silence_expected=silence_expected)

    def _read_txrx(self, port: PortHandler, servo_id: int, address: int,
                   length: int) -> tuple[list[int], int, int]:
        """readTxRx, or readTx + readRx with our own status timeout (``rx_timeout_ms``)."""
        if self.rx_timeout_ms is None:
            return self._packet.readTxRx(port, servo_id, address, length)
        result = self._packet.readTx(port, servo_id, address, length)
        if result != COMM_SUCCESS:
            return [], result, 0
        port.setPacketTimeoutMillis(self.rx_timeout_ms)
        return self._packet.readRx(port, servo_id, length)

    def _write_txrx(self, port: PortHandler, servo_id: int, address: int,
                    payload: list[int]) -> tuple[int, int]:
        """writeTxRx, or writeTxOnly + the status packet read with ``rx_timeout_ms``."""
        if self.rx_timeout_ms is None:
            return self._packet.writeTxRx(port, servo_id, address, len(payload), payload)
        result = self._packet.writeTxOnly(port, servo_id, address, len(payload), payload)
        if result != COMM_SUCCESS:
            return result, 0
        port.setPacketTimeoutMillis(self.rx_timeout_ms)
        _, result, error = self._packet.readRx(port, servo_id, 0)
        return result, error

    def read(self, servo_id: int, address: int, length: int) -> bytes:
        """READ ``length`` bytes at ``address`` from one servo, with bounded retries.

        Checks the SDK result, the status ERR byte and the data length before returning.
        """
        what = f"read {length} byte(s) at {address}"

        def once() -> bytes:
            data, result, error = self._read_txrx(self._port(), servo_id, address, length)
            self._status(servo_id, what, result, error)
            if len(data) != length:
                raise CommError(f"servo {servo_id}: read at {address} returned "
                                f"{len(data)} byte(s), expected {length}",
                                field=f"servo[{servo_id}]", value=len(data))
            return bytes(data)

        with self.claim():
            return self._retry(what, servo_id, once)

    def write(self, servo_id: int, address: int, data: Sequence[int] | bytes) -> None:
        """WRITE ``data`` at ``address`` to one servo and check its status (with retries)."""
        payload = list(data)
        what = f"write {len(payload)} byte(s) at {address}"

        def once() -> None:
            result, error = self._write_txrx(self._port(), servo_id, address, payload)
            self._status(servo_id, what, result, error)

        with self.claim():
            self._retry(what, servo_id, once)

    def _read_int(self, servo_id: int, address: int, length: int, *, signed: bool = False) -> int:
        return int.from_bytes(self.read(servo_id, address, length), "little", signed=signed)

    def _write_int(self, servo_id: int, address: int, value: int, length: int) -> None:
        self.write(servo_id, address, le_bytes(value, length))

    def _write_all(self, address: int, value: int, length: int) -> None:
        """Write to every servo; one that fails does not keep the others from the write
        (a disarm or a torque-off must reach every servo that still listens)."""
        failure: CommError | None = None
        for servo_id in self.ids:
            try:
                self._write_int(servo_id, address, value, length)
            except CommError as exc:
                failure = failure or exc
        if failure is not None:
            raise failure


__all__ = ["Transactions", "le_bytes"]
