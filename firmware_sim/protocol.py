"""Dynamixel Protocol 2.0 framing: CRC-16, byte stuffing, packet build/parse, stream parser.

Packet layout (dynamixel-notes.md §1.1, ROBOTIS e-manual "Protocol 2.0")::

    instruction  FF FF FD 00 | ID | LEN_L LEN_H | INST | P1..Pn       | CRC_L CRC_H
    status       FF FF FD 00 | ID | LEN_L LEN_H | 0x55 | ERR | P1..Pn | CRC_L CRC_H

LEN counts the bytes after the LEN field (INST, params, CRC), after stuffing. The CRC runs
over every byte from the first FF through the last (stuffed) parameter.
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import IntEnum

HEADER = b"\xff\xff\xfd\x00"
BROADCAST_ID = 0xFE
MAX_ID = 0xFC
STATUS = 0x55
#: Largest packet (header to CRC) either side accepts; the SDK's TXPACKET_MAX_LEN.
MAX_PACKET = 1024
#: Inter-byte gap after which a servo drops a partial packet (e-manual "Byte to Byte Time").
BYTE_GAP_S = 0.0015

_STUFF_FROM = b"\xff\xff\xfd"
_STUFF_TO = b"\xff\xff\xfd\xfd"


class Instruction(IntEnum):
    """Protocol 2.0 instruction codes (dynamixel-notes.md §1.4)."""

    PING = 0x01
    READ = 0x02
    WRITE = 0x03
    REG_WRITE = 0x04
    ACTION = 0x05
    FACTORY_RESET = 0x06
    REBOOT = 0x08
    CLEAR = 0x10
    CONTROL_TABLE_BACKUP = 0x20
    STATUS = 0x55
    SYNC_READ = 0x82
    SYNC_WRITE = 0x83
    FAST_SYNC_READ = 0x8A
    BULK_READ = 0x92
    BULK_WRITE = 0x93
    FAST_BULK_READ = 0x9A


def instruction_name(code: int) -> str:
    """Name of an instruction code, or ``0xNN`` for an undefined one."""
    try:
        return Instruction(code).name
    except ValueError:
        return f"0x{code:02X}"


class ProtocolError(ValueError):
    """A byte string that is not a well-formed Protocol 2.0 packet."""


def _crc_table() -> tuple[int, ...]:
    # MSB-first table for poly 0x8005 (CRC-16/BUYPASS): entry i is the CRC of byte i.
    table = []
    for i in range(256):
        c = i << 8
        for _ in range(8):
            c = ((c << 1) ^ 0x8005) if c & 0x8000 else (c << 1)
        table.append(c & 0xFFFF)
    return tuple(table)


_CRC_TABLE = _crc_table()


def crc16(data: bytes | bytearray | memoryview, crc: int = 0) -> int:
    """CRC-16 of Protocol 2.0: poly 0x8005, init 0, no reflection, no final XOR.

    Parameters
    ----------
    data : bytes-like
        Bytes to fold in.
    crc : int
        Running value to continue from (0 starts a packet); lets the fast-read chain
        continue one CRC over the whole packet (dynamixel-notes.md §1.7).
    """
    table = _CRC_TABLE
    for b in data:
        crc = ((crc << 8) & 0xFFFF) ^ table[((crc >> 8) ^ b) & 0xFF]
    return crc


def stuff(body: bytes) -> bytes:
    """Byte stuffing of INST..last parameter: every ``FF FF FD`` gains an extra ``FD``.

    ``FF FF FD`` cannot overlap itself, so one non-overlapping replace is exact.
    """
    return bytes(body).replace(_STUFF_FROM, _STUFF_TO)


def unstuff(body: bytes) -> bytes:
    """Inverse of :func:`stuff`: ``FF FF FD FD`` becomes ``FF FF FD``."""
    return bytes(body).replace(_STUFF_TO, _STUFF_FROM)


def build_packet(packet_id: int, instruction: int, params: bytes = b"", *,
                 stuffing: bool = True) -> bytes:
    """Wire bytes of one packet: header, ID, LEN, stuffed INST+params, CRC (low byte first)."""
    if not 0 <= packet_id <= 0xFF:
        raise ValueError(f"packet id must be 0..255, got {packet_id}")
    body = bytes([instruction]) + bytes(params)
    if stuffing:
        body = stuff(body)
    length = len(body) + 2
    head = HEADER + bytes((packet_id, length & 0xFF, length >> 8))
    packet = head + body
    return packet + crc16(packet).to_bytes(2, "little")


def build_status(packet_id: int, error: int, params: bytes = b"", *,
                 stuffing: bool = True) -> bytes:
    """Status packet: INST 0x55, the ERR byte, then the parameters."""
    return build_packet(packet_id, STATUS, bytes([error]) + bytes(params), stuffing=stuffing)


@dataclass(frozen=True)
class Packet:
    """One decoded packet (params are unstuffed; for a status packet params[0] is ERR).

    ``crc_ok`` is False for a packet whose framing was sound but whose CRC did not match;
    its fields are then as received (still stuffed).
    """

    id: int
    instruction: int
    params: bytes
    raw: bytes = field(repr=False, default=b"")
    crc_ok: bool = True
    time: float = 0.0

    @property
    def name(self) -> str:
        return instruction_name(self.instruction)

    @property
    def error(self) -> int | None:
        """ERR byte of a status packet, None for an instruction packet."""
        if self.instruction == STATUS and self.params:
            return self.params[0]
        return None


def parse_packet(raw: bytes) -> Packet:
    """Decode one complete packet (header first, CRC last), checking LEN and CRC.

    Raises
    ------
    ProtocolError
        Header, LEN or CRC wrong.
    """
    raw = bytes(raw)
    if len(raw) < 10 or raw[:4] != HEADER:
        raise ProtocolError(f"not a Protocol 2.0 packet: {raw[:8].hex(' ')}")
    length = raw[5] | raw[6] << 8
    if length + 7 != len(raw) or length < 3:
        raise ProtocolError(f"LEN {length} does not match {len(raw)} bytes on the wire")
    crc = raw[-2] | raw[-1] << 8
    if crc16(raw[:-2]) != crc:
        raise ProtocolError(f"CRC mismatch: wire {crc:#06x}, computed {crc16(raw[:-2]):#06x}")
    body = unstuff(raw[7:-2])
    return Packet(raw[4], body[0], body[1:], raw)


class FastStatusWriter:
    """Builds a Fast Sync/Bulk Read reply block by block (dynamixel-notes.md §1.7).

    One 0xFE status packet; each servo appends ``ERR ID DATA C_k`` where C_k is the CRC
    of every byte of the packet so far (header, earlier blocks with their CRCs, its own
    ERR ID DATA). No stuffing. ``length`` is the header LEN the first servo announces,
    ``1 + Σ(L_k + 4)`` over the requested servos.
    """

    def __init__(self, length: int) -> None:
        self.header = HEADER + bytes((BROADCAST_ID, length & 0xFF, length >> 8, STATUS))
        self._crc = crc16(self.header)

    def block(self, error: int, servo_id: int, data: bytes) -> bytes:
        """Bytes one servo sends; the running CRC continues into the next block."""
        piece = bytes((error, servo_id)) + bytes(data)
        c = crc16(piece, self._crc)
        tail = c.to_bytes(2, "little")
        self._crc = crc16(tail, c)
        return piece + tail


def fast_status_length(data_lengths: Sequence[int]) -> int:
    """Header LEN of a fast reply: 1 (INST) + Σ(ERR + ID + L_k + 2 CRC)."""
    return 1 + sum(n + 4 for n in data_lengths)


def build_fast_status(blocks: Sequence[tuple[int, int, bytes]]) -> bytes:
    """Complete fast reply from ``(error, id, data)`` blocks in request order."""
    writer = FastStatusWriter(fast_status_length([len(d) for _, _, d in blocks]))
    return writer.header + b"".join(writer.block(e, i, d) for e, i, d in blocks)


def parse_fast_status(raw: bytes, data_lengths: Sequence[int]
                      ) -> list[tuple[int, int, bytes, bool]]:
    """Split a fast reply into ``(error, id, data, crc_ok)`` per block.

    ``crc_ok`` checks that block's running CRC C_k over the packet up to its data.
    """
    raw = bytes(raw)
    if raw[:4] != HEADER or raw[4] != BROADCAST_ID or raw[7] != STATUS:
        raise ProtocolError(f"not a fast status packet: {raw[:8].hex(' ')}")
    out = []
    pos = 8
    for n in data_lengths:
        end = pos + 2 + n
        if end + 2 > len(raw):
            raise ProtocolError(f"fast status packet ends after {len(out)} blocks")
        crc = raw[end] | raw[end + 1] << 8
        out.append((raw[pos], raw[pos + 1], raw[pos + 2:end], crc16(raw[:end]) == crc))
        pos = end + 2
    return out


class PacketParser:
    """Incremental receive side: header hunt, LEN, CRC, unstuffing, inter-byte gap reset.

    Feed it each chunk read from the wire with the time it arrived; it returns the
    packets completed by that chunk (``crc_ok=False`` for a CRC failure, so the bus can
    answer with CRC Error 0x03). The hunt skips ``FF FF FD FD`` (a stuffed FD, not a
    header) and any reserved byte other than 00; a partial packet is dropped when the
    next byte comes more than ``gap`` seconds after the previous one.
    Each packet's ``time`` is the arrival time of the chunk holding its first byte.
    """

    def __init__(self, gap: float = BYTE_GAP_S, max_packet: int = MAX_PACKET) -> None:
        self.gap = gap
        self.max_packet = max_packet
        self._buf = bytearray()
        self._base = 0                      # absolute stream offset of _buf[0]
        self._chunk_ends: list[int] = []    # absolute end offset of each buffered chunk
        self._chunk_times: list[float] = []
        self._last: float | None = None
        self.dropped_partial = 0            # partial packets discarded by the gap rule
        self.discarded_bytes = 0            # bytes skipped while hunting for a header

    def reset(self) -> None:
        """Forget any buffered bytes."""
        self._base += len(self._buf)
        self._buf.clear()
        self._chunk_ends.clear()
        self._chunk_times.clear()

    def _discard(self, n: int) -> None:
        del self._buf[:n]
        self._base += n
        k = bisect.bisect_right(self._chunk_ends, self._base)
        del self._chunk_ends[:k]
        del self._chunk_times[:k]

    def _time_at(self, offset: int) -> float:
        k = bisect.bisect_right(self._chunk_ends, self._base + offset)
        return self._chunk_times[min(k, len(self._chunk_times) - 1)]

    def feed(self, data: bytes, now: float) -> list[Packet]:
        """Add received bytes; return the packets they complete, in order."""
        if not data:
            return []
        if self._buf and self._last is not None and now - self._last > self.gap:
            self.dropped_partial += 1
            self.reset()
        self._last = now
        self._buf += data
        self._chunk_ends.append(self._base + len(self._buf))
        self._chunk_times.append(now)
        out: list[Packet] = []
        buf = self._buf
        while True:
            i = buf.find(_STUFF_FROM)
            if i < 0:
                # keep a tail that may be the start of a header split across chunks
                keep = 2 if buf.endswith(b"\xff\xff") else 1 if buf.endswith(b"\xff") else 0
                self.discarded_bytes += len(buf) - keep
                self._discard(len(buf) - keep)
                break
            if i:
                self.discarded_bytes += i
                self._discard(i)
            if len(buf) < 7:
                break
            length = buf[5] | buf[6] << 8
            if buf[3] != 0x00 or length < 3 or length + 7 > self.max_packet:
                # FF FF FD FD (stuffing), a bad reserved byte or a silly LEN: not a header
                self.discarded_bytes += 1
                self._discard(1)
                continue
            total = length + 7
            if len(buf) < total:
                break
            raw = bytes(buf[:total])
            t0 = self._time_at(0)
            self._discard(total)
            crc_ok = crc16(raw[:-2]) == (raw[-2] | raw[-1] << 8)
            if crc_ok:
                body = unstuff(raw[7:-2])
                out.append(Packet(raw[4], body[0], body[1:], raw, True, t0))
            else:
                out.append(Packet(raw[4], raw[7], raw[8:-2], raw, False, t0))
        return out
