"""The servo bus: Dynamixel X-series servos over Protocol 2.0, through dynamixel-sdk only.

This package is the only part of robodcn that imports ``dynamixel_sdk``; every byte to and
from a servo goes through its ``PortHandler``, ``Protocol2PacketHandler``, ``GroupSyncWrite``
and ``GroupSyncRead`` (Fast Sync Read 0x8A when every servo's firmware has it, plain Sync
Read 0x82 otherwise).

Defensive decoding (dynamixel-notes §4, §1.7): the SDK hands back the CRC bytes as "data"
when a servo answers a READ with an error status and no parameters, and its fast-sync-read
parser ignores the per-servo ERR byte, hiding the Alert bit. Every read here therefore
checks the SDK result, the ERR byte (error number and Alert bit) and the data length
before decoding, and decodes fast-sync-read blocks itself.

Retries: every transaction that fails (timeout, corrupt packet, error status) is tried
again up to ``retries`` times by one helper (:meth:`ServoBus._retry`), which waits for a
straggling reply, flushes it and logs the failed try (logger ``robodcn.bus``) with the
servo and the instruction.

A lost device: any OS-level error of the serial port (SerialException, EIO, termios) is a
:class:`~robodcn.errors.CommError` naming the port; the bus then counts as ``lost``
(no retries are spent on it), :meth:`ServoBus.close` still succeeds, and
:meth:`ServoBus.reopen` (or ``open()``) opens it again once the device is back.

Threading: a :class:`ServoBus` is used from one thread at a time. Each public method takes
the bus's ownership lock without blocking and raises :class:`~robodcn.errors.BusyError` if
another thread holds it; :func:`robodcn.stream.execute` holds it (:meth:`ServoBus.claim`)
for the whole execution, so the streaming thread owns the port while an arm moves and
other threads (an HTTP status handler, say) get a clean ``BusyError`` instead of corrupting
a half-duplex transaction (the SDK's own ``is_using`` flag is not thread-safe).

Waiting for a status packet sleeps in ``select`` (a 1 ms pyserial read timeout) instead of
the SDK's busy poll, which burns a core and starves other Python threads of the GIL.

Bus Watchdog: :meth:`ServoBus.configure` clears it; :func:`robodcn.stream.execute` arms it
for the duration of a stream (:meth:`ServoBus.arm_watchdog`) and disarms it afterwards, so
servos stop by themselves if the host dies mid-stream but an idle, holding arm never trips it.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import TypeVar

import numpy as np
from dynamixel_sdk import (
    COMM_SUCCESS,
    GroupSyncRead,
    GroupSyncWrite,
    PacketHandler,
    PortHandler,
)
from numpy.typing import ArrayLike, NDArray

from robodcn.bus.control_table import (
    ADDR_BUS_WATCHDOG,
    ADDR_CURRENT_LIMIT,
    ADDR_FIRMWARE_VERSION,
    ADDR_GOAL_POSITION,
    ADDR_HARDWARE_ERROR,
    ADDR_MAX_POSITION_LIMIT,
    ADDR_MIN_POSITION_LIMIT,
    ADDR_OPERATING_MODE,
    ADDR_POSITION_D_GAIN,
    ADDR_POSITION_P_GAIN,
    ADDR_PRESENT_POSITION,
    ADDR_PROFILE_ACCELERATION,
    ADDR_PROFILE_VELOCITY,
    ADDR_RETURN_DELAY_TIME,
    ADDR_TORQUE_ENABLE,
    ALERT_BIT,
    BAUD_INDEX,
    FAST_SYNC_READ_MIN_FIRMWARE,
    MODEL_NAMES,
    MODEL_NUMBERS,
    OPERATING_MODE_POSITION,
    STALL_CURRENT_A,
    WATCHDOG_MAX,
    WATCHDOG_UNIT_MS,
)
from robodcn.bus.feedback import (
    ADDR_FEEDBACK,
    ADDR_INDIRECT_ADDRESS_29,
    CURRENT_UNIT_A,
    FEEDBACK_LENGTH,
    Feedback,
    current_units,
    decode_feedback,
    indirect_map,
)
from robodcn.bus.groups import check_ticks, encode_rows, fast_sync_read_blocks
from robodcn.bus.port import SERIAL_ERRORS, close_handler, open_handler
from robodcn.bus.records import ServoInfo, StreamProfile
from robodcn.config import ServoSpec
from robodcn.errors import (
    BusError,
    BusyError,
    CommError,
    InputError,
    ServoMismatchError,
)

log = logging.getLogger("robodcn.bus")
T = TypeVar("T")

#: Pause before a retry, for a late reply to the failed attempt to arrive and be flushed (s).
STRAGGLER_S = 0.002


def _le(value: int, size: int) -> list[int]:
    """Little-endian bytes of ``value`` (two's complement for negative values)."""
    return list(int(value).to_bytes(size, "little", signed=value < 0))


def _check_ids(servos: Sequence[ServoSpec]) -> tuple[int, ...]:
    ids = tuple(s.id for s in servos)
    if not ids:
        raise InputError("servos must name at least one servo, got none", field="servos",
                         value=servos)
    if len(set(ids)) != len(ids):
        raise InputError(f"servo ids must be unique, got {list(ids)}", field="servos",
                         value=ids)
    return ids


class ServoBus:
    """A Dynamixel Protocol 2.0 bus of X-series servos, opened at one baud rate.

    Parameters
    ----------
    port
        Serial device (``/dev/ttyUSB0``, or firmware_sim's pty path).
    baud
        Bits per second; the servos' Baud Rate item must match. The Python SDK cannot
        set 4.5 Mbps.
    servos
        The servos expected on the bus, in joint order: positions and goals are arrays in
        this order.
    retries
        Extra attempts for a read that fails (timeout, corrupt packet, error status).
    rx_timeout_ms
        Status-packet timeout of reads, writes and group reads (pings keep the SDK's).
        None keeps the SDK's own (wire time + 2·16 ms + 2 ms, i.e. ≥ 34 ms); a short value
        makes a lost reply cost little when the adapter's latency timer is 1 ms.
    fast_read
        Use Fast Sync Read for group reads: None decides from the firmware versions found by
        :meth:`verify` (≥ 45), True/False forces it.
    """

    def __init__(self, port: str, baud: int = 1_000_000, *, servos: Sequence[ServoSpec],
                 retries: int = 2, rx_timeout_ms: float | None = None,
                 fast_read: bool | None = None) -> None:
        if not isinstance(port, str) or not port:
            raise InputError(f"port must be a device path, got {port!r}", field="port",
                             value=port)
        if baud not in BAUD_INDEX.values():
            raise InputError(f"baud must be one of {sorted(BAUD_INDEX.values())}, got {baud!r}",
                             field="baud", value=baud)
        if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
            raise InputError(f"retries must be a non-negative integer, got {retries!r}",
                             field="retries", value=retries)
        if rx_timeout_ms is not None and not rx_timeout_ms > 0:
            raise InputError(f"rx_timeout_ms must be positive, got {rx_timeout_ms!r}",
                             field="rx_timeout_ms", value=rx_timeout_ms)
        self.port = port
        self.baud = baud
        self.servos: tuple[ServoSpec, ...] = tuple(servos)
        self.ids = _check_ids(self.servos)
        self.retries = retries
        self.rx_timeout_ms = rx_timeout_ms
        self.fast_read = fast_read
        #: Retries spent since the bus was created (the streamer reports the difference).
        self.retries_used = 0
        #: Ids whose last status packet carried the Alert bit (hardware error present).
        self.last_alert_ids: tuple[int, ...] = ()
        self.configured = False
        #: True once :meth:`configure` mapped the feedback items (:meth:`read_feedback`).
        self.feedback_mapped = False
        #: Per servo, read by :meth:`configure`: Position P and D Gains, Current Limit (A;
        #: the stall current where the model has no such item).
        self.position_p_gains: tuple[int, ...] | None = None
        self.position_d_gains: tuple[int, ...] | None = None
        self._current_units = current_units([s.model for s in self.servos])
        self.current_limits: tuple[float, ...] | None = None
        self.watchdog_ms = 0
        #: Position limits (ticks) read from each servo by :meth:`verify`, else the spec's.
        self.limits = np.array([[s.min_tick, s.max_tick] for s in self.servos], dtype=np.int64)
        #: True after an OS-level failure of the serial device (see :meth:`reopen`).
        self.lost = False
        self._lock = threading.RLock()
        self._handler: PortHandler | None = None
        self._packet = PacketHandler(2.0)
        self._write_group: GroupSyncWrite | None = None
        self._read_groups: dict[tuple[int, int], GroupSyncRead] = {}

    # -- lifecycle ---------------------------------------------------------------------------

    @property
    def is_open(self) -> bool:
        return self._handler is not None and bool(self._handler.is_open)

    def open(self) -> ServoBus:
        """Open the port at ``baud``; raises CommError when the device cannot be opened.

        A bus that lost its device is closed first, so ``open()`` after a loss reopens it.
        """
        with self.claim():
            if self.lost:
                self._drop_handler()
            if self.is_open:
                return self
            if self.baud == 4_500_000:
                raise InputError("baud 4500000 cannot be set through dynamixel-sdk's Python "
                                 "PortHandler; use 4000000 or lower", field="baud",
                                 value=self.baud)
            handler = open_handler(self.port, self.baud)
            self._handler = handler
            self.lost = False
            self._write_group = GroupSyncWrite(handler, self._packet, ADDR_GOAL_POSITION, 4)
            for servo_id in self.ids:
                self._write_group.addParam(servo_id, [0, 0, 0, 0])
            self._read_groups = {}
            log.debug("opened %s at %d baud", self.port, self.baud)
            return self

    def close(self) -> None:
        """Close the port (idempotent; never raises, also after the device was lost).

        Torque is left as it is: holding is the safe state.
        """
        with self.claim():
            self._drop_handler()

    def reopen(self, port: str | None = None) -> ServoBus:
        """Close and open again (optionally on another ``port`` path), e.g. after the device
        was lost and came back. The servos may have power-cycled: :attr:`configured` is
        cleared, so the next stream configures them again; call :meth:`verify` first."""
        with self.claim():
            self._drop_handler()
            if port is not None:
                if not isinstance(port, str) or not port:
                    raise InputError(f"port must be a device path, got {port!r}",
                                     field="port", value=port)
                self.port = port
            self.configured = False
            self.feedback_mapped = False
            self.watchdog_ms = 0
            return self.open()

    def _drop_handler(self) -> None:
        if self._handler is not None:
            close_handler(self._handler)
        self._handler = None
        self._write_group = None
        self._read_groups = {}

    def __enter__(self) -> ServoBus:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "open" if self.is_open else "closed"
        return f"ServoBus({self.port!r}, {self.baud}, ids={list(self.ids)}, {state})"

    @contextlib.contextmanager
    def claim(self) -> Iterator[ServoBus]:
        """Hold the bus for the calling thread; BusyError if another thread holds it."""
        if not self._lock.acquire(blocking=False):
            raise BusyError(f"the bus on {self.port} is in use by another thread "
                            "(a move is running)", field="bus", value=self.port)
        try:
            yield self
        except SERIAL_ERRORS as exc:
            # The device failed or is gone (unplugged adapter, closed pty): a bus fault.
            self.lost = True
            log.warning("serial device %s lost: %s", self.port, exc)
            raise CommError(f"serial device {self.port} lost: {exc}; the bus can be "
                            "reopened when the device is back", field="port",
                            value=self.port) from exc
        finally:
            self._lock.release()

    # -- low level: one servo ----------------------------------------------------------------

    def _port(self) -> PortHandler:
        if self.lost:
            # Talking to a device that failed would only time out: say so at once.
            raise CommError(f"serial device {self.port} was lost; reopen the bus "
                            "(reopen()) when it is back", field="port", value=self.port)
        if self._handler is None:
            raise BusError(f"the bus on {self.port} is not open; call open() first",
                           field="bus", value=self.port)
        return self._handler

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

    def _retry(self, what: str, servo_id: int | None, fn: Callable[[], T]) -> T:
        """``fn()``, tried up to 1 + ``retries`` times while it raises CommError.

        Before each retry: count it, wait ``STRAGGLER_S`` and flush the port. Status packets
        carry no sequence number, so a late reply to the failed try arriving after the
        retry's instruction went out would pass for its answer (same id; the length check
        catches only a different size); the wait and the flush keep most out. Each failed
        try is logged (``robodcn.bus``, DEBUG; the last one WARNING) with servo and
        instruction. A lost device is not retried: its error is raised at once.
        """
        port = self._port()
        tries = self.retries + 1
        for attempt in range(1, tries + 1):
            try:
                return fn()
            except CommError as exc:
                who = "bus" if servo_id is None else f"servo {servo_id}"
                level = logging.WARNING if attempt == tries else logging.DEBUG
                log.log(level, "%s: %s failed (try %d of %d): %s", who, what, attempt, tries,
                        exc.message)
                if attempt == tries or self.lost:
                    raise
            self.retries_used += 1
            time.sleep(STRAGGLER_S)
            port.clearPort()
        raise AssertionError("unreachable")  # the loop returns or raises

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
        self.write(servo_id, address, _le(value, length))

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

    # -- discovery ---------------------------------------------------------------------------

    def ping(self, servo_id: int) -> ServoInfo | None:
        """PING one id (with retries); its model, firmware and the bus baud, or None if silent."""
        def once() -> int:
            model_number, result, error = self._packet.ping(self._port(), servo_id)
            self._status(servo_id, "ping", result, error)
            return model_number

        with self.claim():
            try:
                model_number = self._retry("ping", servo_id, once)
            except CommError:
                if self.lost:
                    raise
                return None
            firmware = self._read_int(servo_id, ADDR_FIRMWARE_VERSION, 1)
            return ServoInfo(servo_id, model_number, MODEL_NAMES.get(model_number),
                             firmware, self.baud)

    def ping_all(self) -> dict[int, ServoInfo]:
        """Ping every configured id; the servos that answered, by id."""
        found = {}
        for servo_id in self.ids:
            info = self.ping(servo_id)
            if info is not None:
                found[servo_id] = info
        return found

    def verify(self, servos: Sequence[ServoSpec] | None = None) -> dict[int, ServoInfo]:
        """Check that every expected servo answers with the configured model.

        Also reads each servo's Min/Max Position Limit into :attr:`limits` (intersected
        with the spec's tick limits: the servo refuses goals outside its own limits) and,
        when ``fast_read`` is None, enables Fast Sync Read iff every firmware is ≥ 45.

        Raises
        ------
        ServoMismatchError naming the missing ids and the ids with the wrong model.
        """
        servos = self.servos if servos is None else tuple(servos)
        _check_ids(servos)
        found = self.ping_all()
        missing = [s.id for s in servos if s.id not in found]
        wrong = [(s.id, s.model, found[s.id]) for s in servos
                 if s.id in found and found[s.id].model_number != MODEL_NUMBERS.get(s.model)]
        if missing or wrong:
            parts = []
            if missing:
                parts.append(f"no reply from servo id(s) {missing} on {self.port} at "
                             f"{self.baud} baud (check power, wiring, id and baud rate; "
                             "`robodcn scan` lists what is there)")
            for servo_id, model, info in wrong:
                parts.append(f"servo {servo_id} is model {info.model or '?'} "
                             f"(number {info.model_number}), the config says {model} "
                             f"(number {MODEL_NUMBERS.get(model, '?')})")
            raise ServoMismatchError("; ".join(parts), field="servos",
                                     value={"missing": missing,
                                            "wrong_model": [w[0] for w in wrong]})
        with self.claim():
            for row, spec in enumerate(self.servos):
                high = self._read_int(spec.id, ADDR_MAX_POSITION_LIMIT, 4, signed=True)
                low = self._read_int(spec.id, ADDR_MIN_POSITION_LIMIT, 4, signed=True)
                self.limits[row] = (max(spec.min_tick, low), min(spec.max_tick, high))
            if self.fast_read is None:
                self.fast_read = all((found[i].firmware or 0) >= FAST_SYNC_READ_MIN_FIRMWARE
                                     for i in self.ids)
        return found

    # -- configuration -----------------------------------------------------------------------

    def configure(self, profile: StreamProfile | None = None) -> None:
        """Make the servos ready to stream, without moving them.

        Operating Mode 3 (position) and Return Delay Time live in EEPROM, which is locked
        while torque is on: only when one of them differs is torque switched off, and only
        the differing items are written (sparing the EEPROM and never letting a holding arm
        sag for nothing). Then: Bus Watchdog cleared; Profile Acceleration and Velocity
        (after the mode, whose change resets them); Goal Position := Present Position, so
        torque-on holds where the arm is; torque on.
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
            self._map_feedback()
            self._write_all(ADDR_TORQUE_ENABLE, 1, 1)
            self.configured = True

    def _map_feedback(self) -> None:
        """Indirect Address 29.. → the feedback items (:mod:`robodcn.bus.feedback`); read the
        P gains and current limits. A servo that refuses the map leaves the plain reads."""
        gains, d_gains, limits = [], [], []
        for spec in self.servos:
            gains.append(self._read_int(spec.id, ADDR_POSITION_P_GAIN, 2))
            d_gains.append(self._read_int(spec.id, ADDR_POSITION_D_GAIN, 2))
            if spec.model == "xm430-w350":
                limits.append(self._read_int(spec.id, ADDR_CURRENT_LIMIT, 2)
                              * CURRENT_UNIT_A[spec.model])
            else:
                limits.append(STALL_CURRENT_A.get(spec.model, 1.4))
        self.position_p_gains = tuple(gains)
        self.position_d_gains = tuple(d_gains)
        self.current_limits = tuple(limits)
        payload = indirect_map()
        try:
            for servo_id in self.ids:
                self.write(servo_id, ADDR_INDIRECT_ADDRESS_29, payload)
        except CommError as exc:
            log.warning("feedback map refused (%s); reading positions only", exc.message)
            self.feedback_mapped = False
            return
        self.feedback_mapped = True

    def read_feedback(self) -> Feedback:
        """Present Position, Velocity, Current and Hardware Error Status of every servo in
        one (Fast) Sync Read of the Indirect Data block (needs :meth:`configure`)."""
        if not self.feedback_mapped:
            raise BusError("read_feedback needs configure() first (the feedback map)",
                           field="bus", value=self.port)
        return decode_feedback(self.sync_read(ADDR_FEEDBACK, FEEDBACK_LENGTH),
                               self._current_units)

    def torque_enabled(self) -> dict[int, bool]:
        """Torque Enable (address 64) per servo id."""
        return {servo_id: bool(self._read_int(servo_id, ADDR_TORQUE_ENABLE, 1))
                for servo_id in self.ids}

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
        comes back with torque off and RAM at defaults, so :meth:`configure` is due again.
        """
        ids = self.ids if servo_ids is None else tuple(servo_ids)
        with self.claim():
            port = self._port()
            for servo_id in ids:
                result, error = self._packet.reboot(port, servo_id)
                self._status(servo_id, "reboot", result, error)
            self.configured = False
            self.feedback_mapped = False
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

    # -- group reads and writes (the streaming hot path) -------------------------------------

    def _group(self, address: int, length: int) -> GroupSyncRead:
        key = (address, length)
        group = self._read_groups.get(key)
        if group is None:
            group = GroupSyncRead(self._port(), self._packet, address, length)
            for servo_id in self.ids:
                group.addParam(servo_id)
            self._read_groups[key] = group
        return group

    def _sync_read_once(self, group: GroupSyncRead, length: int) -> list[bytes]:
        """One (Fast) Sync Read; raw data per servo in bus order, ERR/length checked."""
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
                                                         (length + 4) * len(self.ids))
            if result != COMM_SUCCESS:
                raise CommError(f"fast sync read: {self._packet.getTxRxResult(result)}",
                                field="bus", value=result)
            blocks = fast_sync_read_blocks(raw, self.ids, length)
            for servo_id, (error, data) in zip(self.ids, blocks, strict=True):
                if self._status(servo_id, "fast sync read", COMM_SUCCESS, error):
                    alerts.append(servo_id)
                out.append(data)
        else:
            for servo_id in self.ids:
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

    def sync_read(self, address: int, length: int) -> list[bytes]:
        """(Fast) Sync Read of one item from every servo, with bounded retries.

        Returns raw bytes per servo in bus order; :attr:`last_alert_ids` lists the servos
        whose status carried the Alert bit.
        """
        with self.claim():
            group = self._group(address, length)
            what = ("fast sync read" if self.fast_read else "sync read") + \
                f" {length} byte(s) at {address}"
            return self._retry(what, None, lambda: self._sync_read_once(group, length))

    def read_positions(self) -> NDArray[np.int64]:
        """Present Position of every servo (ticks, signed), shape (k,) in bus order."""
        raw = self.sync_read(ADDR_PRESENT_POSITION, 4)
        return np.frombuffer(b"".join(raw), dtype="<i4").astype(np.int64)

    def hardware_errors(self) -> dict[int, int]:
        """Hardware Error Status (address 70) per servo id; 0 means healthy."""
        raw = self.sync_read(ADDR_HARDWARE_ERROR, 1)
        return {servo_id: data[0] for servo_id, data in zip(self.ids, raw, strict=True)}

    def watchdog_status(self) -> dict[int, int]:
        """Bus Watchdog (address 98) per servo id, signed: -1 means it expired."""
        raw = self.sync_read(ADDR_BUS_WATCHDOG, 1)
        return {servo_id: int.from_bytes(data, "little", signed=True)
                for servo_id, data in zip(self.ids, raw, strict=True)}

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

    def write_encoded(self, row: Sequence[Sequence[int]]) -> None:
        """One Sync Write of Goal Position from :meth:`encode_goals` output (one sample)."""
        with self.claim():
            group = self._write_group
            if group is None or self.lost:
                self._port()
            assert group is not None
            for servo_id, data in zip(self.ids, row, strict=True):
                group.changeParam(servo_id, data)
            result = group.txPacket()
            if result != COMM_SUCCESS:
                raise CommError(f"sync write: {self._packet.getTxRxResult(result)}",
                                field="bus", value=result)

    def write_goals(self, ticks: ArrayLike) -> None:
        """Sync Write Goal Position (ticks, shape (k,), bus order) after a limit check."""
        self.write_encoded(self.encode_goals(np.asarray(ticks).reshape(1, -1))[0])


