"""A thread-safe stop request for a running stream."""

from __future__ import annotations

import threading
import time
from typing import Protocol


class Waitable(Protocol):
    """What the streamer needs of a stop signal (StopSignal, ``threading.Event``)."""

    def is_set(self) -> bool: ...
    def wait(self, timeout: float | None = None) -> bool: ...


class StopSignal:
    """A thread-safe stop request (CLI Ctrl-C handler, HTTP stop endpoint, tests).

    ``request(reason)`` from any thread; the streamer wakes from its sleep at once and stops
    before the next write. Behaves like ``threading.Event`` (``is_set``, ``wait``, ``clear``).
    ``requested_at`` (``time.perf_counter()``) lets the report give the stop latency.
    """

    def __init__(self) -> None:
        self._event = threading.Event()
        self.reason: str | None = None
        self.requested_at: float | None = None

    def request(self, reason: str = "stop requested") -> None:
        if not self._event.is_set():
            self.reason = reason
            self.requested_at = time.perf_counter()
        self._event.set()

    set = request

    def is_set(self) -> bool:
        return self._event.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        return self._event.wait(timeout)

    def clear(self) -> None:
        self.reason = None
        self.requested_at = None
        self._event.clear()
