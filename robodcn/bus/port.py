"""Opening a serial port through dynamixel-sdk's PortHandler, and what its failures mean.

Every OS-level failure of the device (pyserial's SerialException, an OSError such as EIO
after a USB adapter is unplugged or firmware_sim's pty is closed, ``termios.error`` from a
flush) is a :class:`~robodcn.errors.CommError`: the caller sees a bus fault, never a
traceback from below the SDK.
"""

from __future__ import annotations

import contextlib
import termios
from collections.abc import Iterator
from typing import Any

import serial
from dynamixel_sdk import PacketHandler, PortHandler

from robodcn.bus.latency import check_latency_timer
from robodcn.errors import CommError

#: pyserial read timeout while a status packet is awaited (s); see sleep_while_waiting.
READ_POLL_S = 0.001
#: What a serial device raises when it fails or disappears (SerialException is an OSError).
SERIAL_ERRORS: tuple[type[BaseException], ...] = (OSError, serial.SerialException,
                                                  termios.error)


def sleep_while_waiting(handler: PortHandler) -> None:
    """Let the SDK's receive loop sleep in ``select`` instead of spinning.

    PortHandler opens pyserial with ``timeout=0`` and the SDK polls ``readPort`` in a tight
    loop until its packet deadline (dynamixel-notes §4): 100 % CPU, and between polls the
    thread re-takes the GIL at once, so a simulator or any other Python thread in the same
    process may wait a whole switch interval (5 ms) per system call, long enough to miss
    reply deadlines. With a short read timeout, pyserial blocks in ``select`` and returns
    as soon as the requested bytes are there (no added latency); the SDK's deadline checks
    stay the same, at most ``READ_POLL_S`` coarser.
    """
    if handler.ser is not None:
        handler.ser.timeout = READ_POLL_S


def open_handler(port: str, baud: int) -> PortHandler:
    """A PortHandler open on ``port`` at ``baud``; CommError (field "port") if it cannot be."""
    check_latency_timer(port)
    handler = PortHandler(port)
    try:
        # setBaudRate opens the port (openPort would first open it at 1 Mbps).
        opened = handler.setBaudRate(baud)
    except Exception as exc:  # pyserial raises SerialException / OSError / ValueError
        raise CommError(f"cannot open {port}: {exc}", field="port", value=port) from exc
    if not opened:
        close_handler(handler)
        raise CommError(f"cannot open {port} at {baud} baud", field="port", value=port)
    sleep_while_waiting(handler)
    return handler


def close_handler(handler: PortHandler) -> None:
    """Close ``handler`` without raising: a device that is gone cannot refuse its close."""
    with contextlib.suppress(Exception):
        handler.closePort()
    if handler.ser is not None:
        # pyserial keeps the fd in ``ser``; make sure nothing leaks if closePort raised.
        with contextlib.suppress(Exception):
            handler.ser.close()


@contextlib.contextmanager
def raw_port(port: str, baud: int) -> Iterator[tuple[PortHandler, Any]]:
    """A PortHandler and a Protocol 2.0 PacketHandler for one-off use (broadcast ping)."""
    handler = open_handler(port, baud)
    try:
        yield handler, PacketHandler(2.0)
    except SERIAL_ERRORS as exc:
        raise CommError(f"serial device {port} failed: {exc}", field="port",
                        value=port) from exc
    finally:
        close_handler(handler)
