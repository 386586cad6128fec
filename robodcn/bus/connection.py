"""The bus's connection: its port, its servo ids, the ownership lock and a lost device.

:class:`Connection` is the base of :class:`~robodcn.bus.ServoBus`: it opens and closes the
``PortHandler`` (:mod:`robodcn.bus.port`), hands it to transactions (:meth:`_port`), keeps
the SDK group objects bound to the open handler (:meth:`_bound`), and serialises threads
(:meth:`claim`).

A lost device: any OS-level error of the serial port (SerialException, EIO, termios) is a
:class:`~robodcn.errors.CommError` naming the port; the bus then counts as ``lost``
(no retries are spent on it), :meth:`close` still succeeds, and :meth:`reopen` (or
``open()``) opens it again once the device is back.

Threading: a bus is used from one thread at a time. Each public method takes the bus's
ownership lock without blocking and raises :class:`~robodcn.errors.BusyError` if another
thread holds it; :func:`robodcn.stream.execute` holds it (:meth:`claim`) for the whole
execution, so the streaming thread owns the port while an arm moves and other threads (an
HTTP status handler, say) get a clean ``BusyError`` instead of corrupting a half-duplex
transaction (the SDK's own ``is_using`` flag is not thread-safe).
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable, Hashable, Iterator, Sequence
from typing import Any, Self, TypeVar

from dynamixel_sdk import PacketHandler, PortHandler

from robodcn import _checks
from robodcn.bus.control_table import BAUD_INDEX
from robodcn.bus.port import SERIAL_ERRORS, close_handler, open_handler
from robodcn.config import ServoSpec
from robodcn.errors import BusError, BusyError, CommError, InputError

log = logging.getLogger("robodcn.bus")
G = TypeVar("G")


def check_port(port: object) -> str:
    """``port`` when it is a non-empty device path; InputError (field "port") otherwise."""
    if not isinstance(port, str) or not port:
        raise InputError(f"port must be a device path, got {port!r}", field="port", value=port)
    return port


def check_ids(servos: Sequence[ServoSpec]) -> tuple[int, ...]:
    """The servos' ids, at least one and all different; InputError (field "servos") else."""
    ids = tuple(s.id for s in servos)
    if not ids:
        raise InputError("servos must name at least one servo, got none", field="servos",
                         value=servos)
    if len(set(ids)) != len(ids):
        raise InputError(f"servo ids must be unique, got {list(ids)}", field="servos",
                         value=ids)
    return ids


class Connection:
    """A Protocol 2.0 port at one baud rate, and the servos expected on it.

    Parameters are :class:`~robodcn.bus.ServoBus`'s (``port``, ``baud``, ``servos``,
    ``retries``, ``rx_timeout_ms``), validated here.
    """

    def __init__(self, port: str, baud: int, *, servos: Sequence[ServoSpec], retries: int,
                 rx_timeout_ms: float | None) -> None:
        check_port(port)
        if baud not in BAUD_INDEX.values():
            raise InputError(f"baud must be one of {sorted(BAUD_INDEX.values())}, got {baud!r}",
                             field="baud", value=baud)
        if not _checks.is_int(retries) or retries < 0:
            raise InputError(f"retries must be a non-negative integer, got {retries!r}",
                             field="retries", value=retries)
        if rx_timeout_ms is not None and not rx_timeout_ms > 0:
            raise InputError(f"rx_timeout_ms must be positive, got {rx_timeout_ms!r}",
                             field="rx_timeout_ms", value=rx_timeout_ms)
        self.port = port
        self.baud = baud
        self.servos: tuple[ServoSpec, ...] = tuple(servos)
        self.ids = check_ids(self.servos)
        self.retries = int(retries)
        self.rx_timeout_ms = rx_timeout_ms
        #: Retries spent since the bus was created (the streamer reports the difference).
        self.retries_used = 0
        #: True after an OS-level failure of the serial device (see :meth:`reopen`).
        self.lost = False
        #: What the servos hold since :meth:`ServoBus.configure`: forgotten when they may
        #: have power-cycled or rebooted (:meth:`reopen`, :meth:`ServoBus.reboot`).
        self.configured = False
        #: True once :meth:`ServoBus.configure` mapped the feedback items.
        self.feedback_mapped = False
        self.watchdog_ms = 0
        #: Current Limit (A) per servo id once read (EEPROM; forgotten by :meth:`reopen`).
        self._current_limit_a: dict[int, float] = {}
        self._lock = threading.RLock()
        self._handler: PortHandler | None = None
        self._packet = PacketHandler(2.0)
        #: SDK group objects built on the open handler (dropped with it).
        self._groups: dict[Hashable, Any] = {}

    # -- lifecycle ---------------------------------------------------------------------------

    @property
    def is_open(self) -> bool:
        return self._handler is not None and bool(self._handler.is_open)

    def open(self) -> Self:
        """Open the port at ``baud``; raises CommError when the device cannot be opened.

        A bus that lost its device is closed first, so ``open()`` after a loss reopens it.
        """
        with self.claim():
            if self.lost:
                self._drop_handler()
            if self.is_open:
                return self
            if self.baud == 4_500_000:
                raise InputError("baud 4500000 cannot be set through dynamixel-sdk's Python "
                                 "PortHandler; use 4000000 or lower", field="baud",
                                 value=self.baud)
            self._handler = open_handler(self.port, self.baud)
            self.lost = False
            self._groups = {}
            log.debug("opened %s at %d baud", self.port, self.baud)
            return self

    def close(self) -> None:
        """Close the port (idempotent; never raises, also after the device was lost).

        Torque is left as it is: holding is the safe state.
        """
        with self.claim():
            self._drop_handler()

    def reopen(self, port: str | None = None) -> Self:
        """Close and open again (optionally on another ``port`` path), e.g. after the device
        was lost and came back. The servos may have power-cycled: :attr:`configured` is
        cleared, so the next stream configures them again; call ``verify()`` first."""
        with self.claim():
            self._drop_handler()
            if port is not None:
                self.port = check_port(port)
            self._forget_configuration()
            self.watchdog_ms = 0
            self._current_limit_a = {}
            return self.open()

    def _forget_configuration(self) -> None:
        """The servos may have lost their RAM (power cycle, reboot): configure again."""
        self.configured = False
        self.feedback_mapped = False

    def _drop_handler(self) -> None:
        if self._handler is not None:
            close_handler(self._handler)
        self._handler = None
        self._groups = {}

    def __enter__(self) -> Self:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "open" if self.is_open else "closed"
        return f"{type(self).__name__}({self.port!r}, {self.baud}, ids={list(self.ids)}, {state})"

    @contextlib.contextmanager
    def claim(self) -> Iterator[Self]:
        """Hold the bus for the calling thread; BusyError if another thread holds it."""
        if not self._lock.acquire(blocking=False):
            raise BusyError(f"the bus on {self.port} is in use by another thread "
                            "(a move is running)", field="bus", value=self.port)
        try:
            yield self
        except SERIAL_ERRORS as exc:
            # The device failed or is gone (unplugged adapter, closed pty): a bus fault.
            self.lost = True
            log.warning("serial device %s lost: %s", self.port, exc)
            raise CommError(f"serial device {self.port} lost: {exc}; the bus can be "
                            "reopened when the device is back", field="port",
                            value=self.port) from exc
        finally:
            self._lock.release()

    # -- what transactions use ---------------------------------------------------------------

    def _port(self) -> PortHandler:
        """The open handler; CommError at once for a lost device, BusError when closed."""
        if self.lost:
            # Talking to a device that failed would only time out: say so at once.
            raise CommError(f"serial device {self.port} was lost; reopen the bus "
                            "(reopen()) when it is back", field="port", value=self.port)
        if self._handler is None:
            raise BusError(f"the bus on {self.port} is not open; call open() first",
                           field="bus", value=self.port)
        return self._handler

    def _bound(self, key: Hashable, make: Callable[[PortHandler], G]) -> G:
        """The SDK object ``make(handler)`` for ``key``, built once per open handler."""
        group = self._groups.get(key)
        if group is None:
            group = make(self._port())
            self._groups[key] = group
        return group

    def flush(self) -> None:
        """Drop whatever the port has received (a straggling reply) before a retry."""
        self._port().clearPort()


__all__ = ["Connection", "check_ids", "check_port"]
