"""Goal Position history per servo: what a test or ``serve --sim`` checks a client sent.

A goal counts when a WRITE, SYNC_WRITE or BULK_WRITE (or the ACTION of a REG_WRITE) the
servo accepted covered Goal Position (116..119) directly or through an Indirect Data byte
whose Indirect Address points into it.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable

from firmware_sim import control_table as ct
from firmware_sim.servo import Servo

_GOAL = range(ct.GOAL_POSITION, ct.GOAL_POSITION + 4)


def touches_goal(servo: Servo, address: int, length: int) -> bool:
    """Whether bytes ``address .. address+length-1`` of ``servo`` reach Goal Position."""
    span = range(address, address + length)
    if span.start < _GOAL.stop and _GOAL.start < span.stop:
        return True
    for addr_base, data_base, count in ct.INDIRECT_BANKS:
        for a in range(max(data_base, span.start), min(data_base + count, span.stop)):
            err, raw = servo.read(addr_base + 2 * (a - data_base), 2)
            if not err and len(raw) == 2 and int.from_bytes(raw, "little") in _GOAL:
                return True
    return False


class GoalHistory:
    """The newest ``limit`` accepted goals of each servo with the time each was accepted
    (the servo's clock), and its pending REG_WRITE."""

    def __init__(self, servos: Iterable[Servo], limit: int) -> None:
        servos = list(servos)
        self._goals: dict[int, deque[int]] = {id(s): deque(maxlen=int(limit)) for s in servos}
        self._times: dict[int, deque[float]] = {id(s): deque(maxlen=int(limit))
                                                for s in servos}
        self._registered: dict[int, tuple[int, int]] = {}

    def _accepted(self, servo: Servo) -> None:
        self._goals[id(servo)].append(servo.goal_position)
        self._times[id(servo)].append(servo.clock.now())

    def wrote(self, servo: Servo, address: int, length: int) -> None:
        """After an accepted WRITE (or group write) of ``length`` bytes at ``address``."""
        if touches_goal(servo, address, length):
            self._accepted(servo)

    def registered(self, servo: Servo, address: int, length: int) -> None:
        """After an accepted REG_WRITE: its span is checked when ACTION runs it."""
        self._registered[id(servo)] = (address, length)

    def acted(self, servo: Servo, accepted: bool) -> None:
        """After an ACTION; the registered write counts if the servo ``accepted`` it."""
        span = self._registered.pop(id(servo), None)
        if accepted and span is not None and touches_goal(servo, *span):
            self._accepted(servo)

    def forget_registered(self, servo: Servo) -> None:
        """A reboot or factory reset discards the pending REG_WRITE."""
        self._registered.pop(id(servo), None)

    def history(self, servo: Servo) -> list[int]:
        return list(self._goals[id(servo)])

    def timed(self, servo: Servo) -> list[tuple[float, int]]:
        """(time accepted on the servo's clock, goal) of :meth:`history`'s goals."""
        return list(zip(self._times[id(servo)], self._goals[id(servo)], strict=True))
