"""Sync/Bulk Read and Write, and the Fast Sync/Bulk Read chain (dynamixel-notes.md §1).

Group instructions are broadcast only. Plain reads get one status packet per servo in
request order. A fast read gets one 0xFE packet whose blocks carry running CRCs
(:class:`firmware_sim.protocol.FastStatusWriter`); servos with firmware < 45 ignore the
fast instructions. A silent servo leaves the chain shorter than its LEN; whether the
later servos still append their blocks is undocumented (``fast_chain_stops``).
"""

from __future__ import annotations

from typing import Protocol

from firmware_sim.faults import FaultInjector, FaultKind
from firmware_sim.protocol import (
    BROADCAST_ID,
    FastStatusWriter,
    Instruction,
    Packet,
    fast_status_length,
)
from firmware_sim.replies import Reply
from firmware_sim.servo import Servo

#: Firmware version from which X430 servos answer Fast Sync/Bulk Read (e-manual).
FAST_READ_MIN_FIRMWARE = 45
_FAST_READS = (Instruction.FAST_SYNC_READ, Instruction.FAST_BULK_READ)


class Dispatcher(Protocol):
    """What the group instructions need of the dispatcher that runs them
    (:class:`firmware_sim.dispatch.Dispatcher`; a protocol, so this module does not
    import it back)."""

    faults: FaultInjector
    fast_chain_stops: bool

    def answers(self, servo: Servo, instruction: int) -> bool:
        """Whether ``servo`` replies to ``instruction`` at its Status Return Level."""
        ...

    def status(self, servo: Servo, instruction: int, code: int, params: bytes = b"") -> Reply:
        """The status packet of ``servo`` with result ``code``."""
        ...

    def write(self, servo: Servo, address: int, data: bytes) -> int:
        """WRITE ``data`` at ``address`` of ``servo``, noting an accepted goal."""
        ...


def _by_id(servos: list[Servo]) -> dict[int, Servo]:
    found: dict[int, Servo] = {}
    for s in servos:
        found.setdefault(s.id, s)     # two servos set to one ID: the first answers
    return found


def read_requests(pkt: Packet) -> list[tuple[int, int, int]] | None:
    """(id, address, length) per requested servo, in request order; None if malformed."""
    p = pkt.params
    if pkt.instruction in (Instruction.SYNC_READ, Instruction.FAST_SYNC_READ):
        if len(p) < 5:
            return None
        address = int.from_bytes(p[:2], "little")
        length = int.from_bytes(p[2:4], "little")
        return [(i, address, length) for i in p[4:]]
    if len(p) == 0 or len(p) % 5:
        return None
    return [(p[k], int.from_bytes(p[k + 1:k + 3], "little"),
             int.from_bytes(p[k + 3:k + 5], "little")) for k in range(0, len(p), 5)]


def write_requests(pkt: Packet) -> list[tuple[int, int, bytes]] | None:
    """(id, address, data) per addressed servo of a Sync/Bulk Write; None if malformed."""
    p = pkt.params
    if pkt.instruction == Instruction.SYNC_WRITE:
        if len(p) < 4:
            return None
        address = int.from_bytes(p[:2], "little")
        length = int.from_bytes(p[2:4], "little")
        stride = 1 + length
        if length == 0 or (len(p) - 4) % stride:
            return None
        return [(p[k], address, p[k + 1:k + stride]) for k in range(4, len(p), stride)]
    writes = []
    k = 0
    while k + 5 <= len(p):
        length = int.from_bytes(p[k + 3:k + 5], "little")
        if k + 5 + length > len(p):
            return None
        writes.append((p[k], int.from_bytes(p[k + 1:k + 3], "little"), p[k + 5:k + 5 + length]))
        k += 5 + length
    return writes if k == len(p) else None


def group_read(d: Dispatcher, pkt: Packet, targets: list[Servo]) -> list[Reply]:
    """(Fast) Sync/Bulk Read: the status packets, or the one fast chain."""
    if pkt.id != BROADCAST_ID:
        return []
    requests = read_requests(pkt)
    if requests is None:
        return []
    servos = _by_id(targets)
    for servo_id in {r[0] for r in requests}:
        if servo_id in servos:
            servos[servo_id].note_instruction()
    if pkt.instruction in _FAST_READS:
        return _fast_chain(d, pkt, requests, servos)
    replies = []
    for servo_id, address, length in requests:
        s = servos.get(servo_id)
        if s is None or not d.answers(s, pkt.instruction):
            continue
        code, data = s.read(address, length)
        reply = d.status(s, pkt.instruction, code, data if not code else b"")
        reply.span = (address, length)
        replies.append(reply)
    return replies


def _fast_chain(d: Dispatcher, pkt: Packet, requests: list[tuple[int, int, int]],
                servos: dict[int, Servo]) -> list[Reply]:
    writer = FastStatusWriter(fast_status_length([n for _, _, n in requests]))
    chunks: list[bytes] = []
    ids: list[str] = []
    ends: list[int] = []
    rdt: float | None = None
    for servo_id, address, length in requests:
        s = servos.get(servo_id)
        if (s is None or s.firmware_version < FAST_READ_MIN_FIRMWARE
                or not d.answers(s, pkt.instruction)):
            ids.append(f"{servo_id} silent")
            if d.fast_chain_stops:
                break
            continue
        if d.faults.take(FaultKind.DROP, s.id, pkt.instruction, bus_wide=False):
            ids.append(f"{s.id} dropped")
            if d.fast_chain_stops:
                break
            continue
        code, data = s.read(address, length)
        data = data if not code else b""
        # fixed stride: a failed read still fills its slot so the chain stays parsable
        data = (data + bytes(length))[:length]
        block_id = s.id
        wrong = d.faults.take(FaultKind.WRONG_ID, s.id, pkt.instruction, bus_wide=False)
        if wrong:
            block_id = wrong.to_id
        block = bytearray(writer.block(s.status_error(code), block_id, data))
        if d.faults.take(FaultKind.CORRUPT_CRC, s.id, pkt.instruction, bus_wide=False):
            block[-1] ^= 0xFF
        if rdt is None:
            # the first responder's Return Delay Time applies once; the later blocks
            # follow back to back (how RDT applies inside the chain is undocumented)
            rdt = s.return_delay_us * 1e-6
            chunks.append(writer.header)
        chunks.append(bytes(block))
        ends.append(sum(map(len, chunks)))
        ids.append(str(s.id))
    if rdt is None:
        return []
    return [Reply(None, pkt.instruction, b"".join(chunks), rdt,
                  note="fast: " + ",".join(ids), block_ends=ends,
                  span=(requests[0][1], requests[0][2]))]


def group_write(d: Dispatcher, pkt: Packet, targets: list[Servo]) -> list[Reply]:
    """Sync/Bulk Write: each addressed servo writes its part; nobody replies."""
    if pkt.id != BROADCAST_ID:
        return []
    writes = write_requests(pkt)
    if writes is None:
        return []
    for servo_id, address, data in writes:
        # looked up per part: an earlier part may have written a servo's ID item
        s = next((s for s in targets if s.id == servo_id), None)
        if s is not None:
            s.note_instruction()
            d.write(s, address, data)
    return []
