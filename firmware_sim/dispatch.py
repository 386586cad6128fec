"""Instruction packets executed on the servos that hear them; their status replies formed.

Rules followed (dynamixel-notes.md §1): a servo hears nothing while its Baud Rate item
differs from the rate the client set on the port, nor while it boots. Broadcast ID 0xFE
gets replies only for PING and the (fast) sync/bulk reads (:mod:`firmware_sim.group`);
READ to 0xFE is not executed. Status Return Level 0 answers PING only, 1 PING and reads,
2 everything, judged by the level (and ID) in force when the instruction arrived. A
unicast packet with a bad CRC gets CRC Error 0x03; an undefined instruction gets
Instruction Error 0x02.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from firmware_sim.control_table import BAUD_RATES, ERR_CRC, ERR_DATA_LENGTH, ERR_INSTRUCTION
from firmware_sim.faults import FaultInjector
from firmware_sim.goals import GoalHistory
from firmware_sim.group import group_read, group_write
from firmware_sim.protocol import BROADCAST_ID, Instruction, Packet, build_status
from firmware_sim.replies import Reply
from firmware_sim.servo import Servo

_READ_CLASS = frozenset({Instruction.READ, Instruction.SYNC_READ, Instruction.FAST_SYNC_READ,
                         Instruction.BULK_READ, Instruction.FAST_BULK_READ})


class Dispatcher:
    """Runs instructions on a set of servos.

    Parameters
    ----------
    servos : sequence of Servo
        Every servo on the bus.
    goals : GoalHistory
        Told about every accepted write (goal bookkeeping).
    faults : FaultInjector
        Per-block faults inside a fast chain are applied while it is formed.
    fast_chain_stops : bool
        A fast chain ends at the first silent servo (True) or skips it (False).
    """

    def __init__(self, servos: Sequence[Servo], goals: GoalHistory, faults: FaultInjector, *,
                 fast_chain_stops: bool = False) -> None:
        self.servos = servos
        self.goals = goals
        self.faults = faults
        self.fast_chain_stops = fast_chain_stops
        self._before: dict[int, tuple[int, int]] = {}

    def dispatch(self, pkt: Packet, rate: int | None) -> list[Reply]:
        """Execute ``pkt`` as received at ``rate`` bits/s; the replies to send, in order."""
        listening = [s for s in self.servos
                     if rate is not None and BAUD_RATES.get(s.baud_index) == rate
                     and not s.booting()]
        self._before = {id(s): (s.id, s.status_return_level) for s in listening}
        if pkt.id == BROADCAST_ID:
            targets = listening
        else:
            targets = [s for s in listening if s.id == pkt.id]
        if not pkt.crc_ok:
            if pkt.id == BROADCAST_ID:
                return []
            return [self.status(s, pkt.instruction, ERR_CRC) for s in targets
                    if self.answers(s, pkt.instruction)]
        handler = _HANDLERS.get(pkt.instruction)
        if handler is None:
            return self._undefined(pkt, targets)
        return handler(self, pkt, targets)

    # ---- replies ----------------------------------------------------------------------
    def answers(self, servo: Servo, instruction: int) -> bool:
        """Whether ``servo`` replies to ``instruction`` at its Status Return Level."""
        # the level in force when the instruction arrived (a WRITE of SRL itself is
        # answered, or not, under the old level)
        level = self._before.get(id(servo), (servo.id, servo.status_return_level))[1]
        if instruction == Instruction.PING:
            return True
        if instruction in _READ_CLASS:
            return level >= 1
        return level >= 2

    def status(self, servo: Servo, instruction: int, code: int, params: bytes = b"",
               *, error: int | None = None, reply_id: int | None = None) -> Reply:
        """The status packet of ``servo`` with result ``code`` (alert bit added)."""
        err = servo.status_error(code) if error is None else error
        # a reply carries the ID the servo had when the instruction arrived (a WRITE of
        # the ID item is answered under the old ID, so the host sees it)
        rid = self._before.get(id(servo), (servo.id, 0))[0] if reply_id is None else reply_id
        return Reply(rid, instruction, build_status(rid, err, params),
                     servo.return_delay_us * 1e-6, status=(rid, err, bytes(params)))

    def _unicast_reply(self, pkt: Packet, servo: Servo, code: int) -> list[Reply]:
        if pkt.id == BROADCAST_ID or not self.answers(servo, pkt.instruction):
            return []
        return [self.status(servo, pkt.instruction, code)]

    def write(self, servo: Servo, address: int, data: bytes) -> int:
        """WRITE ``data`` at ``address`` of ``servo``, noting an accepted goal."""
        code = servo.write(address, data)
        if code == 0:
            self.goals.wrote(servo, address, len(data))
        return code

    # ---- instructions -----------------------------------------------------------------
    def _ping(self, pkt: Packet, targets: list[Servo]) -> list[Reply]:
        replies = []
        for s in sorted(targets, key=lambda s: s.id):
            s.note_instruction()
            params = s.model_number.to_bytes(2, "little") + bytes([s.firmware_version & 0xFF])
            r = self.status(s, pkt.instruction, 0, params)
            if pkt.id == BROADCAST_ID:
                r.slot_s = s.id
            replies.append(r)
        return replies

    def _read(self, pkt: Packet, targets: list[Servo]) -> list[Reply]:
        if pkt.id == BROADCAST_ID:
            return []
        replies = []
        for s in targets:
            s.note_instruction()
            if len(pkt.params) != 4:
                replies += self._unicast_reply(pkt, s, ERR_DATA_LENGTH)
                continue
            address = int.from_bytes(pkt.params[:2], "little")
            length = int.from_bytes(pkt.params[2:], "little")
            code, data = s.read(address, length)
            if self.answers(s, pkt.instruction):
                reply = self.status(s, pkt.instruction, code, data if not code else b"")
                reply.span = (address, length)
                replies.append(reply)
        return replies

    def _write_like(self, pkt: Packet, targets: list[Servo]) -> list[Reply]:
        replies = []
        for s in targets:
            s.note_instruction()
            if len(pkt.params) < 3:
                replies += self._unicast_reply(pkt, s, ERR_DATA_LENGTH)
                continue
            address = int.from_bytes(pkt.params[:2], "little")
            data = pkt.params[2:]
            if pkt.instruction == Instruction.WRITE:
                code = self.write(s, address, data)
            else:
                code = s.reg_write(address, data)
                if code == 0:
                    self.goals.registered(s, address, len(data))
            replies += self._unicast_reply(pkt, s, code)
        return replies

    def _action(self, pkt: Packet, targets: list[Servo]) -> list[Reply]:
        replies = []
        for s in targets:
            s.note_instruction()
            code = s.action()
            self.goals.acted(s, accepted=code == 0)
            replies += self._unicast_reply(pkt, s, code)
        return replies

    def _factory_reset(self, pkt: Packet, targets: list[Servo]) -> list[Reply]:
        option = pkt.params[0] if len(pkt.params) == 1 else None
        if pkt.id == BROADCAST_ID and option == 0xFF:
            return []        # X-series fw >= 42 refuses a broadcast reset-all
        replies = []
        for s in targets:
            s.note_instruction()
            if option is None:
                replies += self._unicast_reply(pkt, s, ERR_DATA_LENGTH)
                continue
            answer = self.answers(s, pkt.instruction)
            old_id, alert = s.id, s.status_error(0)
            code = s.factory_reset(option)
            self.goals.forget_registered(s)
            if answer and pkt.id != BROADCAST_ID:
                replies.append(self.status(s, pkt.instruction, code, error=code | alert,
                                           reply_id=old_id))
        return replies

    def _reboot(self, pkt: Packet, targets: list[Servo]) -> list[Reply]:
        replies = []
        for s in targets:
            s.note_instruction()
            answer = self.answers(s, pkt.instruction) and pkt.id != BROADCAST_ID
            r = self.status(s, pkt.instruction, 0) if answer else None
            s.reboot()           # the status (with any alert bit) was formed before the reboot
            self.goals.forget_registered(s)
            if r is not None:
                replies.append(r)
        return replies

    def _clear_or_backup(self, pkt: Packet, targets: list[Servo]) -> list[Reply]:
        replies = []
        for s in targets:
            s.note_instruction()
            if pkt.instruction == Instruction.CLEAR:
                code = s.clear(pkt.params)
            else:
                code = s.backup(pkt.params)
            replies += self._unicast_reply(pkt, s, code)
        return replies

    def _undefined(self, pkt: Packet, targets: list[Servo]) -> list[Reply]:
        if pkt.instruction == Instruction.STATUS:
            return []      # another device's status packet: not for the servos
        for s in targets:
            s.note_instruction()
        if pkt.id == BROADCAST_ID:
            return []
        return [self.status(s, pkt.instruction, ERR_INSTRUCTION) for s in targets
                if self.answers(s, pkt.instruction)]


_HANDLERS: dict[int, Callable[[Dispatcher, Packet, list[Servo]], list[Reply]]] = {
    Instruction.PING: Dispatcher._ping,
    Instruction.READ: Dispatcher._read,
    Instruction.WRITE: Dispatcher._write_like,
    Instruction.REG_WRITE: Dispatcher._write_like,
    Instruction.ACTION: Dispatcher._action,
    Instruction.FACTORY_RESET: Dispatcher._factory_reset,
    Instruction.REBOOT: Dispatcher._reboot,
    Instruction.CLEAR: Dispatcher._clear_or_backup,
    Instruction.CONTROL_TABLE_BACKUP: Dispatcher._clear_or_backup,
    Instruction.SYNC_READ: group_read,
    Instruction.FAST_SYNC_READ: group_read,
    Instruction.BULK_READ: group_read,
    Instruction.FAST_BULK_READ: group_read,
    Instruction.SYNC_WRITE: group_write,
    Instruction.BULK_WRITE: group_write,
}
