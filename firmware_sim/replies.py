"""Status packets onto the wire: the armed reply faults, then wire timing.

Timing (``realistic``): each reply starts after a turnaround plus the servo's Return
Delay Time (2 µs a unit) counted from the end of the previous packet on the wire, and
its bytes are paced at the byte time (10 bits a byte at the port's rate). Broadcast
PING replies start in slots proportional to the ID. A fast chain carries its first
responder's Return Delay Time once (inference: the e-manual does not say).
``fast`` timing sends every reply as soon as it is formed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from firmware_sim.faults import FaultInjector, FaultKind
from firmware_sim.pacing import Pacer
from firmware_sim.packet_log import LogEntry, PacketLog
from firmware_sim.protocol import BROADCAST_ID, build_status


@dataclass
class Reply:
    """A status packet (or a fast chain) waiting to go out."""

    servo_id: int | None          # None: a fast chain (bus-wide faults only)
    instruction: int
    data: bytes
    rdt_s: float
    slot_s: float = 0.0           # broadcast PING: the ID, scaled to a reply slot when sent
    status: tuple[int, int, bytes] | None = None   # (id, error, params) to rebuild on wrong_id
    note: str = ""
    block_ends: list[int] = field(default_factory=list)   # fast chain: end offset per block
    span: tuple[int, int] | None = None   # a read's (address, length) (None: not a read)


class ReplySender:
    """Sends the replies to one instruction.

    Parameters
    ----------
    faults : FaultInjector
        Consulted per reply: drop, wrong id, corrupt CRC, delay, truncate fast, split.
    log : PacketLog
        Gets a ``tx`` entry per reply (also dropped ones, noted so).
    pacer : Pacer
        Writes the bytes on time.
    realistic : bool
        Wire timing; False: as soon as possible.
    turnaround_s : float
        Firmware turnaround before each reply (realistic timing).
    """

    def __init__(self, faults: FaultInjector, log: PacketLog, pacer: Pacer, *,
                 realistic: bool, turnaround_s: float) -> None:
        self.faults = faults
        self.log = log
        self.pacer = pacer
        self.realistic = realistic
        self.turnaround_s = turnaround_s
        #: The last reply sent to a read, by (servo id or None for a fast chain, address):
        #: what a STALE fault replays.
        self._last_read: dict[tuple[int | None, int], bytes] = {}

    def send(self, replies: list[Reply], wire_end: float, byte_s: float) -> None:
        """Send ``replies`` in order after an instruction whose last byte was on the wire at
        ``wire_end`` (``perf_counter`` s); ``byte_s`` is the port's time per byte."""
        # a broadcast-ping slot: one 14-byte reply plus turnaround per ID value
        slot = 14 * byte_s + self.turnaround_s
        cursor = wire_end
        faults = self.faults
        for r in replies:
            data = r.data
            note = r.note
            sid = r.servo_id
            known = {a for s, a in self._last_read if s == sid}
            stale = faults.take(FaultKind.STALE, sid, r.instruction, span=r.span,
                                accept=lambda f, known=known: f.of_address in known)
            if stale:
                straggler = self._last_read[(sid, stale.of_address)]
                self.log.add(LogEntry(time.perf_counter(), "tx", sid if sid is not None
                                      else BROADCAST_ID, "STATUS", b"", None, straggler,
                                      f"stale: the last reply to a read at {stale.of_address}"))
                cursor = self.pacer.write(straggler, max(cursor, time.perf_counter()),
                                          byte_s if self.realistic else 0.0)
            if r.span is not None:
                self._last_read[(sid, r.span[0])] = data
            if faults.take(FaultKind.DROP, sid, r.instruction):
                self._log_tx(time.perf_counter(), r, data, _join(note, "dropped"))
                continue
            wrong = None if sid is None else faults.take(FaultKind.WRONG_ID, sid, r.instruction)
            if wrong and r.status is not None:
                _, err, params = r.status
                data = build_status(wrong.to_id, err, params)
                note = _join(note, f"wrong id {wrong.to_id}")
            if faults.take(FaultKind.CORRUPT_CRC, sid, r.instruction):
                data = data[:-1] + bytes([data[-1] ^ 0xFF])
                note = _join(note, "crc corrupted")
            delay = faults.take(FaultKind.DELAY, sid, r.instruction)
            truncate = (faults.take(FaultKind.TRUNCATE_FAST, None, r.instruction)
                        if sid is None else None)
            if truncate:
                ends = [0, *r.block_ends]
                data = data[:ends[min(truncate.keep, len(ends) - 1)]]
                note = _join(note, f"truncated to {truncate.keep} blocks")
            split = faults.take(FaultKind.SPLIT, sid, r.instruction)
            start = time.perf_counter()
            if self.realistic:
                start = max(cursor + self.turnaround_s + r.rdt_s, wire_end + r.slot_s * slot)
            if delay:
                start = max(start, time.perf_counter()) + delay.delay_s
                note = _join(note, f"delayed {delay.delay_s * 1e3:.1f} ms")
            pieces = [data]
            if split and split.pieces > 1:
                step = -(-len(data) // split.pieces)
                pieces = [data[k:k + step] for k in range(0, len(data), step)]
                note = _join(note, f"split in {len(pieces)}")
            self._log_tx(start, r, data, note)
            if not data:
                continue
            t = start
            for k, piece in enumerate(pieces):
                if k and split:
                    t = max(t, time.perf_counter()) + split.gap_s
                t = self.pacer.write(piece, t, byte_s if self.realistic else 0.0)
            cursor = t

    def _log_tx(self, t: float, r: Reply, data: bytes, note: str) -> None:
        if r.status is not None:
            rid, err, params = r.status
            if note and "wrong id" in note:
                rid = data[4]
            self.log.add(LogEntry(t, "tx", rid, "STATUS", params, err, data, note))
        else:
            self.log.add(LogEntry(t, "tx", BROADCAST_ID, "STATUS", data[8:-2] if data else b"",
                                  None, data, note))


def _join(a: str, b: str) -> str:
    return f"{a}; {b}" if a else b
