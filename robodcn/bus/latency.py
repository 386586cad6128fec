"""The FTDI latency timer of USB serial adapters (Linux sysfs).

Each status packet waits up to one timer period in the adapter, so the Linux default of
16 ms caps a read-back loop near 30–60 Hz (dynamixel-notes §5); opening a ``/dev/ttyUSB*``
whose timer is above 1 ms warns with the one-line fix.
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

SYSFS_USB_SERIAL = "/sys/bus/usb-serial/devices"


class LatencyTimerWarning(UserWarning):
    """A USB serial adapter's latency timer is above 1 ms."""


def latency_timer_ms(port: str, *, sysfs: str | os.PathLike[str] = SYSFS_USB_SERIAL) -> int | None:
    """The FTDI latency timer (ms) of a ``/dev/ttyUSB*`` port, or None when not applicable.

    Follows symlinks (``/dev/serial/by-id/...``) to the tty name and reads
    ``<sysfs>/<ttyUSBn>/latency_timer``; None off Linux, for other devices or when unreadable.
    """
    if not sys.platform.startswith("linux"):
        return None
    name = os.path.basename(os.path.realpath(port))
    if not name.startswith("ttyUSB"):
        return None
    try:
        return int(Path(sysfs, name, "latency_timer").read_text().strip())
    except (OSError, ValueError):
        return None


def check_latency_timer(port: str, *,
                        sysfs: str | os.PathLike[str] = SYSFS_USB_SERIAL) -> int | None:
    """Warn (:class:`LatencyTimerWarning`) when ``port``'s latency timer is above 1 ms.

    Returns the timer value (None when unknown).
    """
    value = latency_timer_ms(port, sysfs=sysfs)
    if value is not None and value > 1:
        name = os.path.basename(os.path.realpath(port))
        path = Path(sysfs, name, "latency_timer")
        warnings.warn(
            f"{port}: USB latency_timer is {value} ms, which caps read-back loops near "
            f"{1000 // (2 * value)} Hz; fix: echo 1 | sudo tee {path}",
            LatencyTimerWarning, stacklevel=3)
    return value
