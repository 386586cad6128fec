"""SimBus: simulated Dynamixel X-series servos answering Protocol 2.0 on a pseudo-terminal.

The client (the unmodified dynamixel-sdk) opens :attr:`SimBus.port_path` like a USB
adapter. A server thread reads the pty (:mod:`firmware_sim.transport`), parses packets
(:mod:`firmware_sim.protocol`), executes them on :class:`firmware_sim.servo.Servo`
objects (:mod:`firmware_sim.dispatch`, :mod:`firmware_sim.group`) and writes their status
packets back (:mod:`firmware_sim.replies`), optionally paced like a real wire
(:mod:`firmware_sim.pacing`). Every packet goes to the log (:mod:`firmware_sim.packet_log`)
and every accepted goal to the history (:mod:`firmware_sim.goals`).

Timing (``timing="realistic"``): the instruction occupies the wire for 10 bits a byte at
the port's rate; the replies follow it as :mod:`firmware_sim.replies` describes.
"""

from __future__ import annotations

import os
import threading
import traceback
from collections.abc import Iterable, Mapping

from firmware_sim.arm_model import load_arm
from firmware_sim.clock import Clock
from firmware_sim.control_table import BAUD_RATES, MODELS
from firmware_sim.dispatch import Dispatcher
from firmware_sim.faults import FaultInjector
from firmware_sim.goals import GoalHistory
from firmware_sim.motor import DEFAULT_SUPPLY_V
from firmware_sim.pacing import Pacer, SwitchInterval, sleep_until
from firmware_sim.packet_log import LogEntry, PacketLog
from firmware_sim.protocol import MAX_ID, Packet, PacketParser
from firmware_sim.replies import ReplySender
from firmware_sim.servo import Servo, couple_arm
from firmware_sim.transport import PtyPort

__all__ = ["LogEntry", "SimBus", "sleep_until"]

_SELECT_TIMEOUT_S = 0.01     # how soon the server thread notices close()


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
        if switch_interval is not None and not switch_interval > 0:
            raise ValueError(f"switch_interval must be > 0 or None, got {switch_interval}")
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
            couple_arm(arm_model, [self.servo(i) for i in arm_ids])
        self.faults = FaultInjector(seed=fault_seed)
        self.faults._tripper = self._trip
        self._log = PacketLog(keep=log, limit=log_limit, path=log_file)
        self._goals = GoalHistory(self._servos, goal_limit)
        self._dispatcher = Dispatcher(self._servos, self._goals, self.faults,
                                      fast_chain_stops=bool(fast_chain_stops))
        self._port = PtyPort(link)
        self._pacer = Pacer(self._port.write)
        self._sender = ReplySender(self.faults, self._log, self._pacer,
                                   realistic=timing == "realistic",
                                   turnaround_s=float(turnaround_s))
        self._switch = SwitchInterval(switch_interval) if switch_interval is not None else None
        #: Exceptions raised while serving (traceback text); tests assert it stays empty.
        self.errors: list[str] = []
        #: Held while a packet is dispatched; hold it to read servo state consistently.
        self.lock = threading.RLock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        #: Packets received (also those with a bad CRC).
        self.rx_packets = 0

    # ---- settings -------------------------------------------------------------------
    @property
    def timing(self) -> str:
        """``"fast"`` or ``"realistic"``."""
        return "realistic" if self._sender.realistic else "fast"

    @property
    def turnaround_s(self) -> float:
        """Firmware turnaround before a reply in realistic timing, s."""
        return self._sender.turnaround_s

    @property
    def fast_chain_stops(self) -> bool:
        return self._dispatcher.fast_chain_stops

    # ---- lifecycle ------------------------------------------------------------------
    def start(self) -> SimBus:
        """Open the pty, make the link, start the server thread. Returns self."""
        if self._thread is not None:
            raise RuntimeError("SimBus already started")
        self._port.open()
        try:
            self._log.open()
        except BaseException:
            self._port.close()
            raise
        if self._switch is not None:
            self._switch.hold()
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
        self._port.close()
        self._log.close()
        if self._switch is not None:
            self._switch.release()

    def __enter__(self) -> SimBus:
        return self.start() if self._thread is None else self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---- inspection -----------------------------------------------------------------
    @property
    def port_path(self) -> str:
        """The pty slave the client opens ("" before :meth:`start`)."""
        return self._port.path

    @property
    def servos(self) -> list[Servo]:
        """All servos, in construction order."""
        return list(self._servos)

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
            return self._goals.history(self.servo(servo_id))

    @property
    def log(self) -> list[LogEntry]:
        """The packet log, oldest first (empty with ``log=False``)."""
        return self._log.entries

    def packets(self, direction: str | None = None, instruction: str | int | None = None,
                servo_id: int | None = None) -> list[LogEntry]:
        """Log entries filtered by direction ("rx"/"tx"), instruction (name or code), id."""
        return self._log.select(direction, instruction, servo_id)

    def clear_log(self) -> None:
        self._log.clear()

    def keep_log(self, keep: bool = True) -> None:
        """Start (or stop) keeping packets in :attr:`log`, e.g. for one stretch of a bus
        started with ``log=False``."""
        self._log.keep = keep

    def port_rate(self) -> int | None:
        """Bits/s the client set on the port (slave termios), None if not a known rate."""
        return self._port.rate()

    # ---- server thread --------------------------------------------------------------
    def _serve(self) -> None:
        self._pacer.adopt_thread()
        parser = PacketParser()
        while not self._stop.is_set():
            try:
                received = self._port.receive(_SELECT_TIMEOUT_S)
            except OSError:
                self.errors.append(traceback.format_exc())
                return
            if received is None:
                continue
            data, now = received
            for pkt in parser.feed(data, now):
                try:
                    self._handle(pkt)
                except Exception:
                    self.errors.append(traceback.format_exc())

    def _handle(self, pkt: Packet) -> None:
        self.rx_packets += 1
        self._log.add(LogEntry(pkt.time, "rx", pkt.id, pkt.name, pkt.params, None, pkt.raw,
                               "" if pkt.crc_ok else "crc error"))
        rate = self._port.rate()
        byte_s = 10.0 / rate if rate else 0.0
        with self.lock:
            replies = self._dispatcher.dispatch(pkt, rate)
        if replies:
            end = pkt.time + len(pkt.raw) * byte_s if self._sender.realistic else pkt.time
            self._sender.send(replies, end, byte_s)

    def _trip(self, servo_id: int | None, bits: int) -> None:
        with self.lock:
            for s in self._servos if servo_id is None else [self.servo(servo_id)]:
                s.trip(bits)
