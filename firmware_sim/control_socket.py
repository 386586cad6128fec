"""``--control PATH``: move the simulated arm "by hand" over a UNIX stream socket.

One command a line, one answer a line (``ok`` or ``error <reason>``)::

    move ID TICKS      backdrive servo ID so Present Position reads TICKS (torque off)
    push ID NM         external torque on servo ID's output shaft, N·m (0 releases)
    obstacle ID DEG    block servo ID's joint beyond DEG degrees (``obstacle ID off`` clears;
                       a servo that is no joint of the arm, e.g. a gripper: its own angle,
                       tick 2048 = 0°)
    voltage ID V       supply voltage of servo ID
    indirect ID MODE   how servo ID's firmware treats the Indirect Address map: on, off
                       (a WRITE to an Indirect Address answers OK and stores nothing: an
                       older firmware, a clone) or unresolved (stored, not followed)
    get ID             answers ``ok POSITION VELOCITY CURRENT TEMPERATURE`` (table units)
    payload KG         the arm carries KG at its tool point from now on (``payload`` alone
                       answers ``ok KG``): an object picked up, or a dry run's declared load

A client may keep the connection open and send many lines; several clients may connect.
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import stat
import threading
from collections.abc import Callable

from firmware_sim import control_table as ct
from firmware_sim.bus import SimBus

log = logging.getLogger(__name__)


def execute(bus: SimBus, line: str) -> str:
    """Run one command line against ``bus``; the answer line (without newline)."""
    words = line.split()
    if not words:
        return "error empty command"
    verb, args = words[0].lower(), words[1:]
    if verb == "payload":
        return _payload(bus, args)
    commands: dict[str, tuple[int, Callable[..., str]]] = {
        "move": (2, lambda s, a: _do(lambda: s.backdrive(int(a)))),
        "push": (2, lambda s, a: _do(lambda: s.push(float(a)))),
        "obstacle": (2, lambda s, a: _do(lambda: s.set_obstacle(
            None if a.lower() == "off" else float(a)))),
        "voltage": (2, lambda s, a: _do(lambda: setattr(s, "supply_voltage", float(a)))),
        "indirect": (2, lambda s, a: _do(lambda: setattr(s, "indirect", a))),
        "get": (1, lambda s: "ok " + " ".join(str(s.get(a)) for a in (
            ct.PRESENT_POSITION, ct.PRESENT_VELOCITY, ct.PRESENT_CURRENT,
            ct.PRESENT_TEMPERATURE))),
    }
    if verb not in commands:
        known = ", ".join(sorted([*commands, "payload"]))
        return f"error unknown command {verb!r}; known: {known}"
    arity, run = commands[verb]
    if len(args) != arity:
        return f"error {verb} takes {arity} argument(s), got {len(args)}"
    try:
        servo_id = int(args[0])
    except ValueError:
        return f"error servo id {args[0]!r} is not an integer"
    try:
        servo = bus.servo(servo_id)
    except KeyError:
        return f"error no servo {servo_id} on the bus"
    try:
        return run(servo, *args[1:])
    except ValueError as exc:
        return f"error {exc}"


def _payload(bus: SimBus, args: list[str]) -> str:
    """``payload [KG]``: the arm's payload, read or set (:meth:`SimBus.set_payload`)."""
    if len(args) > 1:
        return f"error payload takes 0 or 1 argument(s), got {len(args)}"
    if not args:
        kg = bus.payload_kg
        return "error no arm on this bus" if kg is None else f"ok {kg!r}"
    try:
        bus.set_payload(float(args[0]))
    except ValueError as exc:
        return f"error {exc}"
    except RuntimeError as exc:
        return f"error {exc}"
    return "ok"


def _do(action: Callable[[], object]) -> str:
    try:
        action()
    except RuntimeError as exc:
        return f"error {exc}"
    return "ok"



def take_over_stale_socket(path: str) -> None:
    """Remove the UNIX socket at ``path`` if nothing listens on it any more.

    A simulator killed with ``kill -9`` leaves its control socket behind; ``bind`` would then
    fail with EADDRINUSE. A socket that still answers belongs to a running simulator and a
    path that is not a socket is somebody's file: both are left alone (``bind`` refuses).
    """
    try:
        if not stat.S_ISSOCK(os.stat(path).st_mode):
            return
    except FileNotFoundError:
        return
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        probe.connect(path)
    except ConnectionRefusedError:
        log.info("removing the stale control socket %s (nothing listens on it)", path)
        with contextlib.suppress(FileNotFoundError):
            os.unlink(path)
    except OSError:
        pass
    finally:
        probe.close()

class ControlServer:
    """Serve :func:`execute` on a UNIX socket at ``path`` in a daemon thread."""

    def __init__(self, bus: SimBus, path: str) -> None:
        self.bus = bus
        self.path = path
        take_over_stale_socket(path)
        self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self._sock.bind(path)
        self._sock.listen(4)
        self._sock.settimeout(0.2)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="firmware_sim control",
                                        daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        while not self._stop.is_set():
            try:
                conn, _ = self._sock.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            threading.Thread(target=self._client, args=(conn,), daemon=True).start()

    def _client(self, conn: socket.socket) -> None:
        with conn, conn.makefile("rw", encoding="utf-8", newline="\n") as f:
            for line in f:
                answer = execute(self.bus, line)
                log.info("control %r -> %s", line.strip(), answer)
                try:
                    f.write(answer + "\n")
                    f.flush()
                except OSError:
                    return

    def close(self) -> None:
        self._stop.set()
        self._sock.close()
        self._thread.join(timeout=2)
        with contextlib.suppress(FileNotFoundError):
            os.unlink(self.path)
