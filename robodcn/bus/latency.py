"""The FTDI latency timer of USB serial adapters (Linux sysfs).

Each status packet waits up to one timer period in the adapter, so the Linux default of
16 ms caps a read-back loop near 30–60 Hz (dynamixel-notes §5); opening a ``/dev/ttyUSB*``
whose timer is above 1 ms warns with the one-line fix, and the commands that stream or scan
(``move``, ``scan``, ``run``, ...) lower it with :func:`lower_latency_timer` when the sysfs
file is writable.
"""

from __future__ import annotations

import logging
import os
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

SYSFS_USB_SERIAL = "/sys/bus/usb-serial/devices"

log = logging.getLogger(__name__)


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


@dataclass(frozen=True)
class LatencyResult:
    """What :func:`lower_latency_timer` found and did: ``before`` / ``after`` in ms (None
    when the port has no FTDI timer), ``changed`` and ``path`` of the sysfs file."""

    before: int | None
    after: int | None
    changed: bool
    path: str | None

    def message(self, port: str) -> str | None:
        """One line for the user, or None when there is nothing to say."""
        if self.changed:
            return f"{port}: set the USB latency timer to {self.after} ms (was {self.before} ms)"
        if self.before is not None and self.before > 1:
            return (f"{port}: USB latency_timer is {self.before} ms and {self.path} is not "
                    f"writable; fix: echo 1 | sudo tee {self.path}")
        return None


def lower_latency_timer(port: str, *, sysfs: str | os.PathLike[str] = SYSFS_USB_SERIAL,
                        target_ms: int = 1) -> LatencyResult:
    """Set a ``/dev/ttyUSB*`` adapter's FTDI latency timer to ``target_ms`` when its sysfs
    file is writable (:func:`check_latency_timer` only warns). Other ports: nothing to do."""
    before = latency_timer_ms(port, sysfs=sysfs)
    if before is None:
        return LatencyResult(None, None, False, None)
    path = Path(sysfs, os.path.basename(os.path.realpath(port)), "latency_timer")
    if before <= target_ms or not sys.platform.startswith("linux"):
        return LatencyResult(before, before, False, str(path))
    try:
        path.write_text(f"{target_ms}\n")
    except OSError as exc:
        log.info("cannot write %s: %s", path, exc)
        return LatencyResult(before, before, False, str(path))
    after = latency_timer_ms(port, sysfs=sysfs)
    return LatencyResult(before, after, after == target_ms, str(path))
