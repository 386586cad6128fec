"""Fault injection for the simulated bus: what can go wrong between a servo and the host.

A :class:`Fault` matches replies by servo (or the whole bus) and optionally by
instruction, fires a bounded number of times or with a probability, and is consulted by
:class:`firmware_sim.bus.SimBus` each time a reply is about to go out. What each fault
looks like to the ROBOTIS SDK (dynamixel-sdk 4.1.0):

=================  =======================================================
drop               no status packet: ``COMM_RX_TIMEOUT`` after ≥ 34 ms
delay              late status packet: accepted if it beats the SDK timeout
corrupt_crc        last CRC byte flipped: ``COMM_RX_CORRUPT``
wrong_id           reply carries another ID: ``COMM_RX_TIMEOUT`` (SDK waits for its ID)
truncate_fast      fast-read chain cut after ``keep`` blocks: ``COMM_RX_CORRUPT``
split              reply written in pieces with gaps: tolerated while gaps < timeout
stale              a late reply to an earlier read (of ``of_address``) goes out just
                   before this one's: the SDK takes it for this read's answer (status
                   packets carry no sequence number; a same-size straggler passes)
trip               :meth:`Servo.trip`: hardware error bits, alert bit 0x80 in replies
=================  =======================================================
"""

from __future__ import annotations

import random
import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from enum import StrEnum


class FaultKind(StrEnum):
    DROP = "drop"
    DELAY = "delay"
    CORRUPT_CRC = "corrupt_crc"
    WRONG_ID = "wrong_id"
    TRUNCATE_FAST = "truncate_fast"
    SPLIT = "split"
    STALE = "stale"


@dataclass
class Fault:
    """One armed fault.

    Attributes
    ----------
    kind : FaultKind
    servo_id : int or None
        Servo whose replies are hit; None = the whole bus (for a fast read: the
        combined packet).
    times : int or None
        Firings left; None = unlimited.
    probability : float
        Chance that a matching reply is hit (0..1).
    instructions : frozenset of int or None
        Only replies to these instruction codes; None = any.
    delay_s : float
        DELAY: extra time before the reply.
    to_id : int
        WRONG_ID: the ID the reply carries.
    keep : int
        TRUNCATE_FAST: blocks of the fast chain sent before it is cut.
    pieces, gap_s : int, float
        SPLIT: number of write() calls and the pause between them.
    address : int or None
        Only replies to reads that include this control-table address; None = any reply.
    of_address : int
        STALE: the address of the earlier read whose reply (the last one sent for it, by
        the same servo or fast chain) is replayed as the straggler.
    fired : int
        How often it has fired so far.
    """

    kind: FaultKind
    servo_id: int | None = None
    times: int | None = 1
    probability: float = 1.0
    instructions: frozenset[int] | None = None
    delay_s: float = 0.0
    to_id: int = 0
    keep: int = 0
    pieces: int = 2
    gap_s: float = 0.0
    address: int | None = None
    of_address: int = 0
    fired: int = 0

    def __post_init__(self) -> None:
        if self.times is not None and self.times < 1:
            raise ValueError(f"fault times must be >= 1 or None, got {self.times}")
        if not 0.0 <= self.probability <= 1.0:
            raise ValueError(f"fault probability must be in [0, 1], got {self.probability}")
        if self.delay_s < 0 or self.gap_s < 0:
            raise ValueError(f"fault delay/gap must be >= 0, got {self.delay_s}/{self.gap_s}")
        if self.pieces < 1:
            raise ValueError(f"split pieces must be >= 1, got {self.pieces}")
        if self.keep < 0:
            raise ValueError(f"truncate keep must be >= 0, got {self.keep}")
        if not 0 <= self.to_id <= 0xFF:
            raise ValueError(f"wrong_id to_id must be 0..255, got {self.to_id}")

    @property
    def spent(self) -> bool:
        return self.times is not None and self.fired >= self.times


@dataclass
class FaultInjector:
    """The armed faults of one bus; thread-safe (tests arm faults while the bus serves).

    Every ``arm`` method returns the :class:`Fault` so a test can read ``fault.fired``.
    ``servo_id=None`` means the whole bus. ``times=None`` means "until cleared".
    """

    seed: int | None = None
    _faults: list[Fault] = field(default_factory=list)
    _lock: threading.Lock = field(default_factory=threading.Lock)
    _rng: random.Random = field(init=False)
    _tripper: Callable[[int | None, int], None] | None = None

    def __post_init__(self) -> None:
        self._rng = random.Random(self.seed)

    # ---- arming -------------------------------------------------------------------
    def add(self, fault: Fault) -> Fault:
        with self._lock:
            self._faults.append(fault)
        return fault

    def _make(self, kind: FaultKind, servo_id: int | None, times: int | None, probability: float,
              instructions: Iterable[int] | None, **kw: object) -> Fault:
        inst = frozenset(int(i) for i in instructions) if instructions is not None else None
        return self.add(Fault(kind, servo_id, times, probability, inst, **kw))  # type: ignore[arg-type]

    def drop(self, servo_id: int | None = None, *, times: int | None = 1,
             probability: float = 1.0, instructions: Iterable[int] | None = None) -> Fault:
        """Swallow replies (the servo stays silent)."""
        return self._make(FaultKind.DROP, servo_id, times, probability, instructions)

    def delay(self, seconds: float, servo_id: int | None = None, *, times: int | None = 1,
              probability: float = 1.0, instructions: Iterable[int] | None = None) -> Fault:
        """Hold replies back by ``seconds`` before they start."""
        return self._make(FaultKind.DELAY, servo_id, times, probability, instructions,
                          delay_s=float(seconds))

    def corrupt_crc(self, servo_id: int | None = None, *, times: int | None = 1,
                    probability: float = 1.0,
                    instructions: Iterable[int] | None = None) -> Fault:
        """Flip bits of the reply's (or fast block's) CRC."""
        return self._make(FaultKind.CORRUPT_CRC, servo_id, times, probability, instructions)

    def wrong_id(self, to_id: int, servo_id: int | None = None, *, times: int | None = 1,
                 probability: float = 1.0,
                 instructions: Iterable[int] | None = None) -> Fault:
        """Send replies carrying ``to_id`` instead of the servo's ID."""
        return self._make(FaultKind.WRONG_ID, servo_id, times, probability, instructions,
                          to_id=int(to_id))

    def truncate_fast(self, keep: int, *, times: int | None = 1,
                      probability: float = 1.0) -> Fault:
        """Cut Fast Sync/Bulk Read chains after ``keep`` blocks (header counts with block 1)."""
        return self._make(FaultKind.TRUNCATE_FAST, None, times, probability, None, keep=int(keep))

    def split(self, pieces: int = 2, gap_s: float = 0.0005, servo_id: int | None = None, *,
              times: int | None = 1, probability: float = 1.0,
              instructions: Iterable[int] | None = None) -> Fault:
        """Write replies in ``pieces`` chunks with ``gap_s`` pauses between them."""
        return self._make(FaultKind.SPLIT, servo_id, times, probability, instructions,
                          pieces=int(pieces), gap_s=float(gap_s))

    def stale(self, of_address: int, servo_id: int | None = None, *, address: int | None = None,
              times: int | None = 1, probability: float = 1.0,
              instructions: Iterable[int] | None = None) -> Fault:
        """Before the reply to a read (that includes ``address``; None: any), send again
        the last reply to a read at ``of_address`` — a straggler answering in its place."""
        return self._make(FaultKind.STALE, servo_id, times, probability, instructions,
                          address=address, of_address=int(of_address))

    def trip(self, servo_id: int | None = None, bits: int = 0x20) -> None:
        """Inject hardware error ``bits`` now (Servo.trip; default 0x20 overload).

        ``servo_id=None`` trips every servo on the bus.
        """
        if self._tripper is None:
            raise RuntimeError("fault injector is not attached to a bus")
        self._tripper(servo_id, bits)

    def clear(self) -> None:
        """Disarm every fault."""
        with self._lock:
            self._faults.clear()

    @property
    def active(self) -> list[Fault]:
        with self._lock:
            return [f for f in self._faults if not f.spent]

    # ---- consulted by the bus -----------------------------------------------------
    def take(self, kind: FaultKind, servo_id: int | None, instruction: int, *,
             bus_wide: bool = True, span: tuple[int, int] | None = None,
             accept: Callable[[Fault], bool] | None = None) -> Fault | None:
        """The first armed fault of ``kind`` hitting this reply, counting the firing.

        ``servo_id=None`` asks for bus-wide faults only (e.g. a whole fast reply); a
        servo's reply is hit by its own faults and, if ``bus_wide``, by bus-wide ones.
        ``span``: the (address, length) the reply answers a read of (None: not a read); a
        fault with an ``address`` hits only reads that include it. ``accept``: a further condition
        a fault must meet to fire (a STALE fault: an earlier reply to replay is known).
        """
        with self._lock:
            for f in self._faults:
                if f.kind is not kind or f.spent:
                    continue
                if f.servo_id is None and not bus_wide:
                    continue
                if f.servo_id is not None and f.servo_id != servo_id:
                    continue
                if f.instructions is not None and instruction not in f.instructions:
                    continue
                if f.address is not None and (
                        span is None or not span[0] <= f.address < span[0] + span[1]):
                    continue
                if accept is not None and not accept(f):
                    continue
                if f.probability < 1.0 and self._rng.random() >= f.probability:
                    continue
                f.fired += 1
                return f
        return None
