"""Clocks for firmware_sim: the servo model reads time from one of these.

Motion and the bus watchdog are evaluated lazily from ``Clock.now()``, so a
:class:`VirtualClock` lets a test jump time instead of sleeping.
"""

from __future__ import annotations

import threading
import time
from abc import ABC, abstractmethod


class Clock(ABC):
    """A monotonic time source in seconds (the origin is arbitrary)."""

    @abstractmethod
    def now(self) -> float:
        """Current time in seconds; never decreases."""


class RealClock(Clock):
    """Wall-independent time: :func:`time.monotonic`."""

    def now(self) -> float:
        return time.monotonic()


class VirtualClock(Clock):
    """A clock that moves only when told to (thread-safe).

    Parameters
    ----------
    start : float
        Initial time in seconds.
    """

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)
        self._lock = threading.Lock()

    def now(self) -> float:
        with self._lock:
            return self._t

    def advance(self, dt: float) -> None:
        """Move time forward by ``dt`` seconds (``dt >= 0``)."""
        if not dt >= 0:
            raise ValueError(f"VirtualClock.advance: dt must be >= 0 s, got {dt!r}")
        with self._lock:
            self._t += float(dt)

    def set(self, t: float) -> None:
        """Jump to absolute time ``t`` (not earlier than now: the clock is monotonic)."""
        with self._lock:
            if not t >= self._t:
                raise ValueError(f"VirtualClock.set: t={t!r} s is before now ({self._t} s); "
                                 "the clock is monotonic")
            self._t = float(t)
