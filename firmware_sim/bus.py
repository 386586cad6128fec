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

import dataclasses
import math
import threading
import time
import traceback
from collections.abc import Iterable, Mapping
from typing import Any

from firmware_sim.bus_config import SimBusConfig, layout
from firmware_sim.clock import VirtualClock
from firmware_sim.dispatch import Dispatcher
from firmware_sim.faults import FaultInjector
from firmware_sim.goals import GoalHistory
from firmware_sim.pacing import Pacer, SwitchInterval, sleep_until
from firmware_sim.packet_log import LogEntry, PacketLog
from firmware_sim.protocol import Packet, PacketParser
from firmware_sim.replies import ReplySender
from firmware_sim.servo import Servo, couple_arm
from firmware_sim.transport import PtyPort

__all__ = ["LogEntry", "SimBus", "SimBusConfig", "sleep_until"]

_SELECT_TIMEOUT_S = 0.005    # how soon the server thread notices close()
#: The server thread keeps every servo's physics at most this far behind the clock, s.
KEEP_UP_S = 0.005


class SimBus:
    """A bus of simulated servos behind a pseudo-terminal, built from a
    :class:`~firmware_sim.bus_config.SimBusConfig`.

    ``SimBus(config=SimBusConfig(ids=(1, 2), timing="realistic"))``; for brevity the
    config's fields may also be given directly, ``SimBus([1, 2], timing="realistic")``
    (``ids`` and ``model`` positionally), or on top of a config.

    Parameters
    ----------
    ids : iterable of int, optional
        :attr:`SimBusConfig.ids`.
    model : str or mapping id -> str, optional
        :attr:`SimBusConfig.model`.
    config : SimBusConfig, optional
        The settings (the defaults of :class:`SimBusConfig` without one).
    **options
        Other :class:`SimBusConfig` fields, overriding ``config``'s (TypeError for a
        name that is not a field; ValueError for a bad value).
    """

    def __init__(self, ids: Iterable[int] | None = None,
                 model: str | Mapping[int, str] | None = None, *,
                 config: SimBusConfig | None = None, **options: Any) -> None:
        if ids is not None:
            options["ids"] = ids
        if model is not None:
            options["model"] = model
        cfg = config if config is not None else SimBusConfig()
        if options:
            cfg = cfg.replace(**options)
        servos = layout(cfg)
        #: The settings this bus was built from.
        self.config = cfg
        self.baud = int(cfg.baud)
        self.link = cfg.link
        self.clock = cfg.clock
        self.dynamics = bool(cfg.dynamics)
        self.arm = servos.arm
        arm_lock = threading.RLock()
        self._servos = [Servo(sp.servo_id, sp.model, firmware=sp.firmware,
                              baud_index=cfg.baud_index, clock=cfg.clock,
                              position=sp.position, dynamics=self.dynamics,
                              supply_voltage=cfg.supply_voltage,
                              lock=arm_lock if sp.on_arm else None,
                              load_inertia=sp.load_inertia, indirect=sp.indirect)
                       for sp in servos.servos]
        #: The plant the arm's servos share (None without an arm).
        self._plant = None if servos.arm is None else \
            couple_arm(servos.arm, [self.servo(i) for i in servos.arm_ids])
        self.faults = FaultInjector(seed=cfg.fault_seed)
        self.faults._tripper = self._trip
        self._log = PacketLog(keep=cfg.log, limit=cfg.log_limit, path=cfg.log_file)
        self._goals = GoalHistory(self._servos, cfg.goal_limit)
        self._dispatcher = Dispatcher(self._servos, self._goals, self.faults,
                                      fast_chain_stops=bool(cfg.fast_chain_stops))
        self._port = PtyPort(cfg.link)
        self._pacer = Pacer(self._port.write)
        self._sender = ReplySender(self.faults, self._log, self._pacer,
                                   realistic=cfg.timing == "realistic",
                                   turnaround_s=float(cfg.turnaround_s))
        self._switch = (SwitchInterval(cfg.switch_interval)
                        if cfg.switch_interval is not None else None)
        #: Exceptions raised while serving (traceback text); tests assert it stays empty.
        self.errors: list[str] = []
        #: Held while a packet is dispatched; hold it to read servo state consistently.
        self.lock = threading.RLock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        #: Packets received and handled (also those with a bad CRC): counted once dispatched,
        #: so a test that waits for the count and then moves a virtual clock on moves it
        #: after the packet's effects (a watchdog fed), not between its receipt and them.
        self.rx_packets = 0
        self._keeps_up = not isinstance(self._servos[0].clock, VirtualClock)

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

    @property
    def payload_kg(self) -> float | None:
        """The point mass (kg) the simulated arm carries at its tool point; None without
        an arm (no ``arm=`` document, or the kinematic model)."""
        return None if self.arm is None else self.arm.payload

    def set_payload(self, kg: float) -> None:
        """Let the arm carry ``kg`` at its tool point from now on: a gripper closing on an
        object, or a dry run carrying the payload a move declares. The plant first advances
        to now on the old mass, then runs on the new one (its rest support recomputed).
        RuntimeError without an arm; ValueError for a mass that is not a finite number ≥ 0."""
        if self.arm is None or self._plant is None:
            raise RuntimeError("no arm on this bus (no arm file, or the kinematic model): "
                               "nothing carries a payload")
        if isinstance(kg, bool) or not isinstance(kg, int | float) or not math.isfinite(kg) \
                or kg < 0:
            raise ValueError(f"payload must be a finite number of kg >= 0, got {kg!r}")
        with self.lock:
            for s in self._plant.owners:
                s.update()
            arm = dataclasses.replace(self.arm, payload=float(kg))
            self._plant.set_arm(arm)
            self.arm = arm

    def goal_history(self, servo_id: int) -> list[int]:
        """Every accepted Goal Position of that servo, in order (WRITE, REG_WRITE+ACTION,
        SYNC_WRITE, BULK_WRITE, also through indirect addresses); the newest ``goal_limit``."""
        with self.lock:
            return self._goals.history(self.servo(servo_id))

    def timed_goal_history(self, servo_id: int) -> list[tuple[float, int]]:
        """:meth:`goal_history` with the time each goal was accepted: (seconds on the bus's
        clock — :func:`time.monotonic` in real time —, goal ticks), in order."""
        with self.lock:
            return self._goals.timed(self.servo(servo_id))

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
        kept = time.monotonic()
        while not self._stop.is_set():
            try:
                received = self._port.receive(_SELECT_TIMEOUT_S)
            except OSError:
                self.errors.append(traceback.format_exc())
                return
            if received is not None:
                data, now = received
                for pkt in parser.feed(data, now):
                    try:
                        self._handle(pkt)
                    except Exception:
                        self.errors.append(traceback.format_exc())
            if self._keeps_up and time.monotonic() - kept >= KEEP_UP_S:
                kept = time.monotonic()
                try:
                    self.keep_up()
                except Exception:
                    self.errors.append(traceback.format_exc())

    def keep_up(self) -> None:
        """Advance every servo's physics (the arm's plant, the watchdogs) to now.

        The model is lazy: a servo's plant steps only when it is read or written. An arm
        left moving (falling with torque off, say) while nobody talks to the bus would
        otherwise be integrated all at once by the first packet after the pause — seconds
        of 0.5 ms steps, far longer than the client's packet timeout, so that packet (the
        first ping of a client that took a second to start) went unanswered. The server
        thread calls this every :data:`KEEP_UP_S` between packets, so the catch-up before
        any reply stays a few steps. On a :class:`~firmware_sim.clock.VirtualClock` (a
        test that moves time itself) the server thread leaves the physics lazy. The live
        items are left to the next read (:meth:`Servo.advance`): refreshing every servo's
        Present items here cost more than the steps themselves."""
        with self.lock:
            for s in self._servos:
                s.advance()

    def _handle(self, pkt: Packet) -> None:
        self._log.add(LogEntry(pkt.time, "rx", pkt.id, pkt.name, pkt.params, None, pkt.raw,
                               "" if pkt.crc_ok else "crc error"))
        rate = self._port.rate()
        byte_s = 10.0 / rate if rate else 0.0
        with self.lock:
            try:
                replies = self._dispatcher.dispatch(pkt, rate)
            finally:
                self.rx_packets += 1
        if replies:
            end = pkt.time + len(pkt.raw) * byte_s if self._sender.realistic else pkt.time
            self._sender.send(replies, end, byte_s)

    def _trip(self, servo_id: int | None, bits: int) -> None:
        with self.lock:
            for s in self._servos if servo_id is None else [self.servo(servo_id)]:
                s.trip(bits)
