"""SimBus: simulated Dynamixel X-series servos answering Protocol 2.0 on a pseudo-terminal.

The client (the unmodified dynamixel-sdk) opens :attr:`SimBus.port_path` like a USB
adapter. A server thread reads the pty master with ``select``, parses packets
(:mod:`firmware_sim.protocol`), dispatches them to :class:`firmware_sim.servo.Servo`
objects and writes their status packets back, optionally paced like a real wire.

Rules followed (dynamixel-notes.md §1): broadcast ID 0xFE gets replies only for PING and
the (fast) sync/bulk reads; READ to 0xFE is not executed; Status Return Level 0 answers
PING only, 1 PING and reads, 2 everything; sync/bulk replies come in request order; a
fast read is one 0xFE packet with running CRCs; servos with firmware < 45 ignore the fast
instructions; a unicast packet with a bad CRC gets CRC Error 0x03; an undefined
instruction gets Instruction Error 0x02. A servo hears nothing while its Baud Rate item
differs from the rate the client set on the port (read from the slave's termios).

Timing (``timing="realistic"``): the instruction occupies the wire for 10 bits a byte at
the port's rate; each reply starts after a turnaround plus the servo's Return Delay Time
(2 µs a unit) counted from the end of the previous packet on the wire, and its bytes are
paced at the byte time. Broadcast PING replies start in slots proportional to the ID. In
a fast read the first responder's Return Delay Time applies once and the later blocks
follow back to back (how RDT applies inside the chain is undocumented; inference).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import select
import sys
import termios
import threading
import time
import traceback
import tty
from collections import deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import IO, ClassVar

from firmware_sim.arm_model import load_arm
from firmware_sim.clock import Clock
from firmware_sim.control_table import (
    BAUD_RATES,
    ERR_CRC,
    ERR_DATA_LENGTH,
    ERR_INSTRUCTION,
    MODELS,
)
from firmware_sim.faults import FaultInjector, FaultKind
from firmware_sim.motor import DEFAULT_SUPPLY_V
from firmware_sim.protocol import (
    BROADCAST_ID,
    MAX_ID,
    FastStatusWriter,
    Instruction,
    Packet,
    PacketParser,
    build_status,
    fast_status_length,
    instruction_name,
)
from firmware_sim.servo import Servo, couple_arm

#: Firmware version from which X430 servos answer Fast Sync/Bulk Read (e-manual).
FAST_READ_MIN_FIRMWARE = 45
GOAL_POSITION = 116
_GOAL = range(GOAL_POSITION, GOAL_POSITION + 4)
# Indirect Data k mirrors the byte whose address is stored in Indirect Address k.
_INDIRECT = ((224, 252, 168), (634, 662, 578))   # (data start, data end, address start)
_READ_CLASS = frozenset({Instruction.READ, Instruction.SYNC_READ, Instruction.FAST_SYNC_READ,
                         Instruction.BULK_READ, Instruction.FAST_BULK_READ})
_SELECT_TIMEOUT_S = 0.01
_ALREADY_WAITING_S = 50e-6
_SPIN_S = 200e-6
_SPIN_TIGHT_S = 40e-6        # spin window once the thread's timer slack is 1 µs
_PR_SET_TIMERSLACK = 29
_SERVER_NICE = -5
_PACE_CHUNK_S = 100e-6


def _termios_rates() -> dict[int, int]:
    rates = {}
    for name in dir(termios):
        if name.startswith("B") and name[1:].isdigit():
            rates[getattr(termios, name)] = int(name[1:])
    return rates


_TERMIOS_RATES = _termios_rates()


def sleep_until(deadline: float, spin_s: float = _SPIN_S) -> None:
    """Sleep to a ``time.perf_counter()`` deadline: OS sleep for most, spin the last
    ``spin_s`` (the OS wakes a sleeper late by its timer slack, 50 µs by default)."""
    while True:
        remaining = deadline - time.perf_counter()
        if remaining <= 0:
            return
        if remaining > spin_s:
            time.sleep(remaining - spin_s)
        else:
            while time.perf_counter() < deadline:
                pass
            return


def _tighten_timer_slack() -> bool:
    """Ask Linux for 1 µs timer slack on this thread (prctl PR_SET_TIMERSLACK).

    Sleeps then overshoot by ~10-20 µs instead of ~60 µs, so the pacing can sleep
    instead of spinning; spinning threads lose out to other processes under CPU load.
    """
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_TIMERSLACK, 1000, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


@dataclass(frozen=True)
class LogEntry:
    """One packet seen on the wire.

    ``time`` is ``time.perf_counter()`` seconds when the packet was read (rx) or written
    (tx). ``params`` are the unstuffed parameters (status: after the ERR byte); ``error``
    is the ERR byte of a status packet. ``note`` says what the sim did to it
    (``"crc error"``, ``"dropped"``, ``"delayed 40.0 ms"``, ``"fast: 1,2,3"`` ...).
    """

    time: float
    direction: str
    id: int
    instruction: str
    params: bytes
    error: int | None = None
    raw: bytes = field(default=b"", repr=False)
    note: str = ""

    def __str__(self) -> str:
        err = "" if self.error is None else f" err=0x{self.error:02X}"
        note = f" [{self.note}]" if self.note else ""
        return (f"{self.time:.6f} {self.direction} id={self.id} {self.instruction}{err} "
                f"params={self.params.hex(' ')}{note}")


@dataclass
class _Reply:
    """A status packet (or a fast chain) waiting to go out."""

    servo_id: int | None          # None: a fast chain (bus-wide faults only)
    instruction: int
    data: bytes
    rdt_s: float
    slot_s: float = 0.0           # earliest start after the instruction's end
    status: tuple[int, int, bytes] | None = None   # (id, error, params) to rebuild on wrong_id
    note: str = ""
    block_ends: list[int] = field(default_factory=list)   # fast chain: end offset per block


class SimBus:
    """A bus of simulated servos behind a pseudo-terminal.

    Parameters
    ----------
    ids : iterable of int
        Servo IDs (0..252, unique).
    model : str or mapping id -> str
        ``"xm430-w350"`` or ``"xl430-w250"``, for all servos or per ID.
    baud : int
        Bits/s; the servos' Baud Rate item is set to match (a key of BAUD_RATES).
    timing : {"fast", "realistic"}
        ``fast``: reply as soon as possible (unit tests); ``realistic``: wire timing.
    firmware : int or mapping id -> int
        Firmware version per servo (< 45: no Fast Sync/Bulk Read).
    clock : Clock, optional
        Time base of the servos' motion (a VirtualClock lets tests jump time).
    link : str, optional
        Path of a symlink to the pty slave, created on start and removed on close.
    log : bool
        Keep a packet log in :attr:`log`.
    log_file : str, optional
        Also append every log entry to this text file.
    turnaround_s : float
        Firmware turnaround before a reply in realistic timing.
    fault_seed : int, optional
        Seed for probabilistic faults.
    log_limit : int
        Oldest entries are discarded beyond this many.
    goal_limit : int
        Goal history kept per servo (:meth:`goal_history`); older goals are dropped, so a
        long-running ``serve --sim`` does not grow without bound.
    dynamics : bool
        False (default): the kinematic model, Present Position = the profile. True: the
        physics model (:mod:`firmware_sim.drive`, :mod:`firmware_sim.dynamics`).
    arm : path or mapping, optional
        An arm TOML file (or its parsed dict): its servos drive the arm's rigid-body
        dynamics (:mod:`firmware_sim.arm_model`); needs ``dynamics=True``. ``ids`` defaults
        to the arm's servo ids and each arm servo starts at its zero_offset.
    positions : mapping id -> int, optional
        Initial Present Position per servo (default 2048).
    supply_voltage : float
        Supply of every servo, V (physics model).
    fast_chain_stops : bool
        What later servos of a Fast Sync/Bulk Read do when an earlier one stays silent
        (undocumented): False, they append their blocks anyway; True, the chain ends.
        Either way the packet is shorter than its LEN and the SDK reports RX_CORRUPT.
    switch_interval : float or None
        While any bus runs, the interpreter's GIL switch interval is lowered to this
        (restored when the last bus closes). The SDK client spins on the port holding
        the GIL; with the default 5 ms interval the server thread can wait that long
        for it, and under CPU load long enough to miss the SDK's 34 ms timeout.
        None leaves the interpreter alone.
    """

    _switch_users = 0
    _switch_saved = 0.0
    _switch_lock = threading.Lock()

    def __init__(self, ids: Iterable[int] | None = None,
                 model: str | Mapping[int, str] = "xm430-w350", *, baud: int = 1_000_000,
                 timing: str = "fast",
                 firmware: int | Mapping[int, int] = 46, clock: Clock | None = None,
                 link: str | None = None, log: bool = True, log_file: str | None = None,
                 turnaround_s: float = 30e-6, fault_seed: int | None = None,
                 log_limit: int = 100_000, goal_limit: int = 1_000_000,
                 fast_chain_stops: bool = False,
                 switch_interval: float | None = 1e-4, dynamics: bool = False,
                 arm: str | os.PathLike[str] | Mapping[str, object] | None = None,
                 positions: Mapping[int, int] | None = None,
                 supply_voltage: float = DEFAULT_SUPPLY_V) -> None:
        arm_model = load_arm(arm) if arm is not None else None     # ArmConfigError: ValueError
        if arm_model is not None and not dynamics:
            raise ValueError("an arm load needs the physics model: pass dynamics=True")
        arm_ids = [jm.servo_id for jm in arm_model.joints] if arm_model is not None else []
        if ids is None:
            ids = arm_ids or (1,)
        id_list = [int(i) for i in ids]
        if not id_list:
            raise ValueError("SimBus needs at least one servo id")
        for i in id_list:
            if not 0 <= i <= MAX_ID:
                raise ValueError(f"servo id must be 0..{MAX_ID}, got {i}")
        if len(set(id_list)) != len(id_list):
            raise ValueError(f"servo ids must be unique, got {id_list}")
        if timing not in ("fast", "realistic"):
            raise ValueError(f"timing must be 'fast' or 'realistic', got {timing!r}")
        baud_index = {bps: k for k, bps in BAUD_RATES.items()}.get(int(baud))
        if baud_index is None:
            raise ValueError(f"baud {baud} is not an X-series rate; choose from "
                             f"{sorted(BAUD_RATES.values())}")
        if turnaround_s < 0:
            raise ValueError(f"turnaround_s must be >= 0, got {turnaround_s}")
        models = model if isinstance(model, Mapping) else dict.fromkeys(id_list, model)
        if arm_model is not None:
            missing = [i for i in arm_ids if i not in id_list]
            if missing:
                raise ValueError(f"arm servo ids {missing} are not among the bus ids {id_list}")
            if not isinstance(model, Mapping):      # the arm file names its servos' models
                models = {**models, **{jm.servo_id: jm.model for jm in arm_model.joints}}
        start = dict(positions or {})
        for i in start:
            if i not in id_list:
                raise ValueError(f"positions: no servo {i} on the bus (ids {id_list})")
        if arm_model is not None:
            for jm in arm_model.joints:
                start.setdefault(jm.servo_id, jm.zero_offset)
        firmwares = firmware if isinstance(firmware, Mapping) else dict.fromkeys(id_list, firmware)
        for i in id_list:
            if i not in models:
                raise ValueError(f"no model given for servo id {i}")
            if models[i] not in MODELS:
                raise ValueError(f"model {models[i]!r} for servo {i} unknown; known: "
                                 f"{sorted(MODELS)}")
        self.baud = int(baud)
        self.timing = timing
        self.turnaround_s = float(turnaround_s)
        self.fast_chain_stops = bool(fast_chain_stops)
        self.link = link
        self.clock = clock
        self.dynamics = bool(dynamics)
        self.arm = arm_model
        arm_lock = threading.RLock()
        self._servos = [Servo(i, models[i], firmware=int(firmwares.get(i, 46)),
                              baud_index=baud_index, clock=clock,
                              position=int(start.get(i, 2048)), dynamics=self.dynamics,
                              supply_voltage=supply_voltage,
                              lock=arm_lock if i in arm_ids else None) for i in id_list]
        if arm_model is not None:
            couple_arm(arm_model, [self._servo_by_id(i) for i in arm_ids])
        self._goals: dict[int, deque[int]] = {id(s): deque(maxlen=int(goal_limit))
                                              for s in self._servos}
        self._registered: dict[int, tuple[int, int]] = {}
        self.faults = FaultInjector(seed=fault_seed)
        self.faults._tripper = self._trip
        self._log_on = bool(log)
        self.log: list[LogEntry] = []
        self._log_limit = int(log_limit)
        self._log_path = log_file
        self._log_fh: IO[str] | None = None
        #: Exceptions raised while serving (traceback text); tests assert it stays empty.
        self.errors: list[str] = []
        #: Held while a packet is dispatched; hold it to read servo state consistently.
        self.lock = threading.RLock()
        self.port_path = ""
        self._master: int | None = None
        self._slave: int | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._link_made = False
        self.rx_packets = 0
        self._before: dict[int, tuple[int, int]] = {}
        if switch_interval is not None and not switch_interval > 0:
            raise ValueError(f"switch_interval must be > 0 or None, got {switch_interval}")
        self._switch_interval = switch_interval
        self._spin_s = _SPIN_S
        self._switch_held = False

    # ---- lifecycle ------------------------------------------------------------------
    def start(self) -> SimBus:
        """Open the pty, make the link, start the server thread. Returns self."""
        if self._thread is not None:
            raise RuntimeError("SimBus already started")
        master, slave = os.openpty()
        try:
            tty.setraw(slave)       # nothing echoed or line-buffered before the client opens it
            os.set_blocking(master, False)
            self.port_path = os.ttyname(slave)
            if self.link:
                os.symlink(self.port_path, self.link)
                self._link_made = True
            if self._log_path:
                self._log_fh = open(self._log_path, "a", encoding="utf-8")
        except BaseException:
            os.close(master)
            os.close(slave)
            raise
        self._master, self._slave = master, slave
        self._hold_switch_interval()
        self._stop.clear()
        self._thread = threading.Thread(target=self._serve, name=f"SimBus {self.port_path}",
                                        daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop the server thread and release the pty, link and log file (idempotent)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        for fd in (self._master, self._slave):
            if fd is not None:
                os.close(fd)
        self._master = self._slave = None
        if self._link_made and self.link:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.link)
            self._link_made = False
        if self._log_fh is not None:
            self._log_fh.close()
            self._log_fh = None
        self._release_switch_interval()

    def _hold_switch_interval(self) -> None:
        if self._switch_interval is None or self._switch_held:
            return
        cls = SimBus
        with cls._switch_lock:
            if cls._switch_users == 0:
                cls._switch_saved = sys.getswitchinterval()
            cls._switch_users += 1
            sys.setswitchinterval(min(self._switch_interval, sys.getswitchinterval()))
        self._switch_held = True

    def _release_switch_interval(self) -> None:
        if not self._switch_held:
            return
        cls = SimBus
        with cls._switch_lock:
            cls._switch_users -= 1
            if cls._switch_users == 0:
                sys.setswitchinterval(cls._switch_saved)
        self._switch_held = False

    def __enter__(self) -> SimBus:
        return self.start() if self._thread is None else self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---- inspection -----------------------------------------------------------------
    @property
    def servos(self) -> list[Servo]:
        """All servos, in construction order."""
        return list(self._servos)

    def _servo_by_id(self, servo_id: int) -> Servo:
        return next(s for s in self._servos if s.id == servo_id)

    def servo(self, servo_id: int) -> Servo:
        """The servo whose ID item is currently ``servo_id``."""
        for s in self._servos:
            if s.id == servo_id:
                return s
        raise KeyError(f"no servo with id {servo_id} on the bus (ids: "
                       f"{[s.id for s in self._servos]})")

    def goal_history(self, servo_id: int) -> list[int]:
        """Every accepted Goal Position of that servo, in order (WRITE, REG_WRITE+ACTION,
        SYNC_WRITE, BULK_WRITE, also through indirect addresses); the newest ``goal_limit``."""
        with self.lock:
            return list(self._goals[id(self.servo(servo_id))])

    def packets(self, direction: str | None = None, instruction: str | int | None = None,
                servo_id: int | None = None) -> list[LogEntry]:
        """Log entries filtered by direction ("rx"/"tx"), instruction (name or code), id."""
        if isinstance(instruction, int):
            instruction = instruction_name(instruction)
        return [e for e in list(self.log)
                if (direction is None or e.direction == direction)
                and (instruction is None or e.instruction == instruction)
                and (servo_id is None or e.id == servo_id)]

    def clear_log(self) -> None:
        self.log.clear()

    def port_rate(self) -> int | None:
        """Bits/s the client set on the port (slave termios), None if not a known rate."""
        if self._slave is None:
            return None
        try:
            speed = termios.tcgetattr(self._slave)[5]
        except termios.error:
            return None
        return _TERMIOS_RATES.get(speed)

    # ---- server thread --------------------------------------------------------------
    def _serve(self) -> None:
        self._spin_s = _SPIN_TIGHT_S if _tighten_timer_slack() else _SPIN_S
        # Real servos do not share the host's CPU; where allowed (root, CAP_SYS_NICE),
        # favour this mostly sleeping thread so host load disturbs its timing less.
        with contextlib.suppress(OSError):
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), _SERVER_NICE)
        parser = PacketParser()
        master = self._master
        assert master is not None
        while not self._stop.is_set():
            try:
                t_wait = time.perf_counter()
                ready, _, _ = select.select([master], [], [], _SELECT_TIMEOUT_S)
                if not ready:
                    continue
                data = os.read(master, 4096)
            except BlockingIOError:
                continue
            except OSError as exc:
                if exc.errno == errno.EIO:     # no slave open; we keep one, but be safe
                    self._stop.wait(_SELECT_TIMEOUT_S)
                    continue
                self.errors.append(traceback.format_exc())
                return
            now = time.perf_counter()
            if now - t_wait < _ALREADY_WAITING_S:
                # the bytes were there before we looked (the thread was busy): they arrived
                # no later than t_wait. Using it keeps a busy thread from seeing a false
                # 1.5 ms inter-byte gap, and dates the instruction closer to its arrival.
                now = t_wait
            for pkt in parser.feed(data, now):
                try:
                    self._handle(pkt)
                except Exception:
                    self.errors.append(traceback.format_exc())

    def _write(self, data: bytes) -> None:
        master = self._master
        if master is None:
            return
        view = memoryview(data)
        flushed = False
        while view:
            try:
                n = os.write(master, view)
                view = view[n:]
            except BlockingIOError:
                if flushed or self._slave is None:
                    return            # nobody reads the port: the bytes are lost, as on a wire
                # the client is not reading: drop what it never collected, as a wire would
                termios.tcflush(self._slave, termios.TCIFLUSH)
                flushed = True

    def _add_log(self, entry: LogEntry) -> None:
        if self._log_on:
            self.log.append(entry)
            if len(self.log) > self._log_limit:
                del self.log[: len(self.log) - self._log_limit]
        if self._log_fh is not None:
            self._log_fh.write(f"{entry}\n")
            self._log_fh.flush()

    # ---- dispatch ---------------------------------------------------------------------
    def _handle(self, pkt: Packet) -> None:
        self.rx_packets += 1
        self._add_log(LogEntry(pkt.time, "rx", pkt.id, pkt.name, pkt.params, None, pkt.raw,
                               "" if pkt.crc_ok else "crc error"))
        rate = self.port_rate()
        byte_s = 10.0 / rate if rate else 0.0
        with self.lock:
            listening = [s for s in self._servos
                         if rate is not None and BAUD_RATES.get(s.baud_index) == rate
                         and not s.booting()]
            self._before = {id(s): (s.id, s.status_return_level) for s in listening}
            if pkt.id == BROADCAST_ID:
                targets = listening
            else:
                targets = [s for s in listening if s.id == pkt.id]
            if not pkt.crc_ok:
                replies = [] if pkt.id == BROADCAST_ID else [
                    self._status(s, pkt.instruction, ERR_CRC) for s in targets
                    if self._answers(s, pkt.instruction)]
            else:
                handler = self._HANDLERS.get(pkt.instruction)
                if handler is None:
                    replies = self._undefined(pkt, targets)
                else:
                    replies = handler(self, pkt, targets)
        if replies:
            end = pkt.time + len(pkt.raw) * byte_s if self.timing == "realistic" else pkt.time
            self._send(replies, end, byte_s)

    def _answers(self, servo: Servo, instruction: int) -> bool:
        # the level in force when the instruction arrived (a WRITE of SRL itself is
        # answered, or not, under the old level)
        level = self._before.get(id(servo), (servo.id, servo.status_return_level))[1]
        if instruction == Instruction.PING:
            return True
        if instruction in _READ_CLASS:
            return level >= 1
        return level >= 2

    def _status(self, servo: Servo, instruction: int, code: int, params: bytes = b"",
                *, error: int | None = None, reply_id: int | None = None) -> _Reply:
        err = servo.status_error(code) if error is None else error
        # a reply carries the ID the servo had when the instruction arrived (a WRITE of
        # the ID item is answered under the old ID, so the host sees it)
        rid = self._before.get(id(servo), (servo.id, 0))[0] if reply_id is None else reply_id
        return _Reply(rid, instruction, build_status(rid, err, params),
                      servo.return_delay_us * 1e-6, status=(rid, err, bytes(params)))

    def _undefined(self, pkt: Packet, targets: list[Servo]) -> list[_Reply]:
        if pkt.instruction == Instruction.STATUS:
            return []      # another device's status packet: not for the servos
        for s in targets:
            s.note_instruction()
        if pkt.id == BROADCAST_ID:
            return []
        return [self._status(s, pkt.instruction, ERR_INSTRUCTION) for s in targets
                if self._answers(s, pkt.instruction)]

    def _unicast_reply(self, pkt: Packet, servo: Servo, code: int) -> list[_Reply]:
        if pkt.id == BROADCAST_ID or not self._answers(servo, pkt.instruction):
            return []
        return [self._status(servo, pkt.instruction, code)]

    # ---- goal bookkeeping -----------------------------------------------------------
    def _touches_goal(self, servo: Servo, address: int, length: int) -> bool:
        span = range(address, address + length)
        if span.start < _GOAL.stop and _GOAL.start < span.stop:
            return True
        for start, stop, addr_item in _INDIRECT:
            lo, hi = max(start, span.start), min(stop, span.stop)
            for a in range(lo, hi):
                err, raw = servo.read(addr_item + 2 * (a - start), 2)
                if not err and len(raw) == 2 and int.from_bytes(raw, "little") in _GOAL:
                    return True
        return False

    def _write_servo(self, servo: Servo, address: int, data: bytes) -> int:
        code = servo.write(address, data)
        if code == 0 and self._touches_goal(servo, address, len(data)):
            self._goals[id(servo)].append(servo.goal_position)
        return code

    # ---- instructions ---------------------------------------------------------------
    def _ping(self, pkt: Packet, targets: list[Servo]) -> list[_Reply]:
        replies = []
        for s in sorted(targets, key=lambda s: s.id):
            s.note_instruction()
            params = s.model_number.to_bytes(2, "little") + bytes([s.firmware_version & 0xFF])
            r = self._status(s, pkt.instruction, 0, params)
            if pkt.id == BROADCAST_ID:
                r.slot_s = s.id      # scaled to a slot length in _send
            replies.append(r)
        return replies

    def _read(self, pkt: Packet, targets: list[Servo]) -> list[_Reply]:
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
            if self._answers(s, pkt.instruction):
                replies.append(self._status(s, pkt.instruction, code, data if not code else b""))
        return replies

    def _write_like(self, pkt: Packet, targets: list[Servo]) -> list[_Reply]:
        replies = []
        for s in targets:
            s.note_instruction()
            if len(pkt.params) < 3:
                replies += self._unicast_reply(pkt, s, ERR_DATA_LENGTH)
                continue
            address = int.from_bytes(pkt.params[:2], "little")
            data = pkt.params[2:]
            if pkt.instruction == Instruction.WRITE:
                code = self._write_servo(s, address, data)
            else:
                code = s.reg_write(address, data)
                if code == 0:
                    self._registered[id(s)] = (address, len(data))
            replies += self._unicast_reply(pkt, s, code)
        return replies

    def _action(self, pkt: Packet, targets: list[Servo]) -> list[_Reply]:
        replies = []
        for s in targets:
            s.note_instruction()
            code = s.action()
            reg = self._registered.pop(id(s), None)
            if code == 0 and reg is not None and self._touches_goal(s, *reg):
                self._goals[id(s)].append(s.goal_position)
            replies += self._unicast_reply(pkt, s, code)
        return replies

    def _factory_reset(self, pkt: Packet, targets: list[Servo]) -> list[_Reply]:
        option = pkt.params[0] if len(pkt.params) == 1 else None
        if pkt.id == BROADCAST_ID and option == 0xFF:
            return []        # X-series fw >= 42 refuses a broadcast reset-all
        replies = []
        for s in targets:
            s.note_instruction()
            if option is None:
                replies += self._unicast_reply(pkt, s, ERR_DATA_LENGTH)
                continue
            answer = self._answers(s, pkt.instruction)
            old_id, alert = s.id, s.status_error(0)
            code = s.factory_reset(option)
            self._registered.pop(id(s), None)
            if answer and pkt.id != BROADCAST_ID:
                replies.append(self._status(s, pkt.instruction, code, error=code | alert,
                                            reply_id=old_id))
        return replies

    def _reboot(self, pkt: Packet, targets: list[Servo]) -> list[_Reply]:
        replies = []
        for s in targets:
            s.note_instruction()
            answer = self._answers(s, pkt.instruction) and pkt.id != BROADCAST_ID
            r = self._status(s, pkt.instruction, 0) if answer else None
            s.reboot()           # the status (with any alert bit) was formed before the reboot
            self._registered.pop(id(s), None)
            if r is not None:
                replies.append(r)
        return replies

    def _clear_or_backup(self, pkt: Packet, targets: list[Servo]) -> list[_Reply]:
        replies = []
        for s in targets:
            s.note_instruction()
            if pkt.instruction == Instruction.CLEAR:
                code = s.clear(pkt.params)
            else:
                code = s.backup(pkt.params)
            replies += self._unicast_reply(pkt, s, code)
        return replies

    def _find(self, servos: list[Servo], servo_id: int) -> Servo | None:
        for s in servos:
            if s.id == servo_id:
                return s
        return None

    def _read_requests(self, pkt: Packet) -> list[tuple[int, int, int]] | None:
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

    def _group_read(self, pkt: Packet, targets: list[Servo]) -> list[_Reply]:
        if pkt.id != BROADCAST_ID:
            return []
        requests = self._read_requests(pkt)
        if requests is None:
            return []
        fast = pkt.instruction in (Instruction.FAST_SYNC_READ, Instruction.FAST_BULK_READ)
        for servo_id in {r[0] for r in requests}:
            s = self._find(targets, servo_id)
            if s is not None:
                s.note_instruction()
        if not fast:
            replies = []
            for servo_id, address, length in requests:
                s = self._find(targets, servo_id)
                if s is None or not self._answers(s, pkt.instruction):
                    continue
                code, data = s.read(address, length)
                replies.append(self._status(s, pkt.instruction, code, data if not code else b""))
            return replies
        writer = FastStatusWriter(fast_status_length([n for _, _, n in requests]))
        chunks: list[bytes] = []
        ids: list[str] = []
        ends: list[int] = []
        rdt: float | None = None
        for servo_id, address, length in requests:
            s = self._find(targets, servo_id)
            if (s is None or s.firmware_version < FAST_READ_MIN_FIRMWARE
                    or not self._answers(s, pkt.instruction)):
                ids.append(f"{servo_id} silent")
                if self.fast_chain_stops:
                    break
                continue
            if self.faults.take(FaultKind.DROP, s.id, pkt.instruction, bus_wide=False):
                ids.append(f"{s.id} dropped")
                if self.fast_chain_stops:
                    break
                continue
            code, data = s.read(address, length)
            data = data if not code else b""
            # fixed stride: a failed read still fills its slot so the chain stays parsable
            data = (data + bytes(length))[:length]
            block_id = s.id
            wrong = self.faults.take(FaultKind.WRONG_ID, s.id, pkt.instruction, bus_wide=False)
            if wrong:
                block_id = wrong.to_id
            block = bytearray(writer.block(s.status_error(code), block_id, data))
            if self.faults.take(FaultKind.CORRUPT_CRC, s.id, pkt.instruction, bus_wide=False):
                block[-1] ^= 0xFF
            if rdt is None:
                rdt = s.return_delay_us * 1e-6
                chunks.append(writer.header)
            chunks.append(bytes(block))
            ends.append(sum(map(len, chunks)))
            ids.append(str(s.id))
        if rdt is None:
            return []
        return [_Reply(None, pkt.instruction, b"".join(chunks), rdt,
                       note="fast: " + ",".join(ids), block_ends=ends)]

    def _group_write(self, pkt: Packet, targets: list[Servo]) -> list[_Reply]:
        if pkt.id != BROADCAST_ID:
            return []
        p = pkt.params
        writes: list[tuple[int, int, bytes]] = []
        if pkt.instruction == Instruction.SYNC_WRITE:
            if len(p) < 4:
                return []
            address = int.from_bytes(p[:2], "little")
            length = int.from_bytes(p[2:4], "little")
            stride = 1 + length
            if length == 0 or (len(p) - 4) % stride:
                return []
            writes = [(p[k], address, p[k + 1:k + stride]) for k in range(4, len(p), stride)]
        else:
            k = 0
            while k + 5 <= len(p):
                length = int.from_bytes(p[k + 3:k + 5], "little")
                if k + 5 + length > len(p):
                    return []
                writes.append((p[k], int.from_bytes(p[k + 1:k + 3], "little"),
                               p[k + 5:k + 5 + length]))
                k += 5 + length
            if k != len(p):
                return []
        for servo_id, address, data in writes:
            s = self._find(targets, servo_id)
            if s is not None:
                s.note_instruction()
                self._write_servo(s, address, data)
        return []

    _HANDLERS: ClassVar[dict[int, Callable[[SimBus, Packet, list[Servo]], list[_Reply]]]] = {
        Instruction.PING: _ping,
        Instruction.READ: _read,
        Instruction.WRITE: _write_like,
        Instruction.REG_WRITE: _write_like,
        Instruction.ACTION: _action,
        Instruction.FACTORY_RESET: _factory_reset,
        Instruction.REBOOT: _reboot,
        Instruction.CLEAR: _clear_or_backup,
        Instruction.CONTROL_TABLE_BACKUP: _clear_or_backup,
        Instruction.SYNC_READ: _group_read,
        Instruction.FAST_SYNC_READ: _group_read,
        Instruction.BULK_READ: _group_read,
        Instruction.FAST_BULK_READ: _group_read,
        Instruction.SYNC_WRITE: _group_write,
        Instruction.BULK_WRITE: _group_write,
    }

    def _trip(self, servo_id: int | None, bits: int) -> None:
        with self.lock:
            for s in self._servos if servo_id is None else [self.servo(servo_id)]:
                s.trip(bits)

    # ---- transmit -------------------------------------------------------------------
    def _send(self, replies: list[_Reply], wire_end: float, byte_s: float) -> None:
        realistic = self.timing == "realistic"
        # a broadcast-ping slot: one 14-byte reply plus turnaround per ID value
        slot = 14 * byte_s + self.turnaround_s
        cursor = wire_end
        for r in replies:
            data = r.data
            note = r.note
            sid = r.servo_id
            if self.faults.take(FaultKind.DROP, sid, r.instruction):
                self._log_tx(time.perf_counter(), r, data, _join(note, "dropped"))
                continue
            wrong = None if sid is None else self.faults.take(FaultKind.WRONG_ID, sid,
                                                               r.instruction)
            if wrong and r.status is not None:
                _, err, params = r.status
                data = build_status(wrong.to_id, err, params)
                note = _join(note, f"wrong id {wrong.to_id}")
            if self.faults.take(FaultKind.CORRUPT_CRC, sid, r.instruction):
                data = data[:-1] + bytes([data[-1] ^ 0xFF])
                note = _join(note, "crc corrupted")
            delay = self.faults.take(FaultKind.DELAY, sid, r.instruction)
            truncate = (self.faults.take(FaultKind.TRUNCATE_FAST, None, r.instruction)
                        if sid is None else None)
            if truncate:
                ends = [0, *r.block_ends]
                data = data[:ends[min(truncate.keep, len(ends) - 1)]]
                note = _join(note, f"truncated to {truncate.keep} blocks")
            split = self.faults.take(FaultKind.SPLIT, sid, r.instruction)
            start = time.perf_counter()
            if realistic:
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
                t = self._write_paced(piece, t, byte_s if realistic else 0.0)
            cursor = t

    def _write_paced(self, data: bytes, start: float, byte_s: float) -> float:
        """Write ``data`` so its last byte lands ``len * byte_s`` after ``start``; return then."""
        if byte_s <= 0:
            sleep_until(start, self._spin_s)
            self._write(data)
            return time.perf_counter()
        per = max(1, int(_PACE_CHUNK_S / byte_s))
        for k in range(0, len(data), per):
            piece = data[k:k + per]
            sleep_until(start + (k + len(piece)) * byte_s, self._spin_s)
            self._write(piece)
        return start + len(data) * byte_s

    def _log_tx(self, t: float, r: _Reply, data: bytes, note: str) -> None:
        if r.status is not None:
            rid, err, params = r.status
            if note and "wrong id" in note:
                rid = data[4]
            self._add_log(LogEntry(t, "tx", rid, "STATUS", params, err, data, note))
        else:
            self._add_log(LogEntry(t, "tx", BROADCAST_ID, "STATUS", data[8:-2] if data else b"",
                                   None, data, note))


def _join(a: str, b: str) -> str:
    return f"{a}; {b}" if a else b
