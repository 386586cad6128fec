"""Verification: are the expected servos on the bus, of the configured model?

:meth:`Verification.verify` pings every expected id, compares the model numbers with the
config's, reads each servo's own position limits and decides whether group reads may use
Fast Sync Read (firmware ≥ 45, dynamixel-notes §1.4).

A PING waits for its status packet as long as the bus's reads do: with ``rx_timeout_ms``
given, the SDK's ``txPacket`` sends the instruction and its ``readRx`` takes the status
with our deadline (``ping`` itself always waits the SDK's own 34 ms, dynamixel-notes §4:
a servo answering later, as a simulator sharing a loaded host's CPU does, would count as
missing). With ``rx_timeout_ms`` None the SDK's ``ping`` is used unchanged, as
:func:`robodcn.bus.scan` does to keep probing silent ids fast.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from dynamixel_sdk import (
    BROADCAST_ID,
    COMM_SUCCESS,
    INST_PING,
    PKT_ID,
    PKT_INSTRUCTION,
    PKT_LENGTH_H,
    PKT_LENGTH_L,
    PortHandler,
)

from robodcn.bus.connection import check_ids
from robodcn.bus.control_table import (
    ADDR_FIRMWARE_VERSION,
    ADDR_MAX_POSITION_LIMIT,
    ADDR_MIN_POSITION_LIMIT,
    FAST_SYNC_READ_MIN_FIRMWARE,
)
from robodcn.bus.records import ServoInfo
from robodcn.bus.transactions import Transactions
from robodcn.config import ServoSpec
from robodcn.errors import CommError, ServoMismatchError
from robodcn.servo_models import MODEL_NAMES, MODEL_NUMBERS

#: Parameters of a PING's status packet: Model Number (2 bytes), Firmware Version.
PING_STATUS_PARAMS = 3


def ping_packet(servo_id: int) -> list[int]:
    """A PING instruction for ``servo_id`` as the SDK's ``ping`` builds it (10 bytes; the
    SDK's ``txPacket`` adds header and CRC)."""
    packet = [0] * 10
    packet[PKT_ID] = servo_id
    packet[PKT_LENGTH_L] = 3
    packet[PKT_LENGTH_H] = 0
    packet[PKT_INSTRUCTION] = INST_PING
    return packet


class Verification(Transactions):
    """PING and the check of the expected servos (ids, models, limits, firmware)."""

    #: Position limits (ticks) per servo, bus order (set by ServoBus, narrowed by verify).
    limits: np.ndarray
    #: Fast Sync Read for group reads; None: decided by :meth:`verify`.
    fast_read: bool | None

    def _ping_txrx(self, port: PortHandler, servo_id: int) -> tuple[int, int, int]:
        """(model number, result, error) of one PING: the SDK's ``ping``, or with
        ``rx_timeout_ms`` its ``txPacket`` + ``readRx`` with our status timeout."""
        if self.rx_timeout_ms is None or servo_id >= BROADCAST_ID:
            return self._packet.ping(port, servo_id)
        result = self._packet.txPacket(port, ping_packet(servo_id))
        if result != COMM_SUCCESS:
            return 0, result, 0
        port.setPacketTimeoutMillis(self.rx_timeout_ms)
        data, result, error = self._packet.readRx(port, servo_id, PING_STATUS_PARAMS)
        # as the SDK's ping: the model is read whatever the error byte says (an alert bit
        # is the servo's state, reported by _status, not a failed ping)
        if result != COMM_SUCCESS:
            return 0, result, error
        if len(data) < 2:
            raise CommError(f"servo {servo_id}: ping returned {len(data)} parameter "
                            f"byte(s), expected {PING_STATUS_PARAMS}",
                            field=f"servo[{servo_id}]", value=len(data))
        return data[0] | data[1] << 8, result, error

    def ping(self, servo_id: int) -> ServoInfo | None:
        """PING one id (with retries); its model, firmware and the bus baud, or None if silent.

        Each try waits ``rx_timeout_ms`` for the status (the SDK's 34 ms when None; module
        docstring)."""
        def once() -> int:
            model_number, result, error = self._ping_txrx(self._port(), servo_id)
            self._status(servo_id, "ping", result, error)
            return model_number

        with self.claim():
            try:
                # a silent id is this call's answer (None): the caller says what it means
                model_number = self._retry("ping", servo_id, once, silence_expected=True)
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
        check_ids(servos)
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


__all__ = ["PING_STATUS_PARAMS", "Verification", "ping_packet"]
