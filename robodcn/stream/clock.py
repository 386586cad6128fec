"""The streamer's time source: the present time and waiting until a due time.

The loop asks its :class:`Clock` for ``now()`` and waits with ``wait_until(due, stop,
spin)``; nothing else in the stream reads a clock or sleeps (the stop latency excepted:
:attr:`StopSignal.requested_at` is ``time.perf_counter()`` of the requesting thread).

* :class:`RealClock` (the default, :data:`REAL_CLOCK`) — ``time.perf_counter``; a wait
  sleeps on the stop signal until ``spin`` seconds before the due time (so a stop request
  wakes it at once) and spins the rest (sleeps overshoot by 50–100 µs on Linux).
* :class:`VirtualClock` — time that moves only when the streamer waits: a wait sets the
  time to its due time at once, so a schedule runs as fast as the bus answers and every
  sample is exactly on time unless a test makes it late (:meth:`VirtualClock.advance`). A
  test may hold the clock at a time (:meth:`VirtualClock.hold`): the loop then parks in
  its wait until the test releases it, which places an online operation at a known sample.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Protocol, runtime_checkable

from robodcn.stream.signal import Waitable


@runtime_checkable
class Clock(Protocol):
    """What the streamer needs of a time source (seconds on a monotonic scale)."""

    def now(self) -> float: ...

    def wait_until(self, due: float, stop: Waitable | None = None,
                   spin: float = 0.0) -> bool:
        """Return at ``due`` (or later); True if ``stop`` was set meanwhile."""
        ...

    def sleep(self, seconds: float) -> None: ...


class RealClock:
    """Real time: ``now`` is ``time.perf_counter`` (or the callable given)."""

    def __init__(self, now: Callable[[], float] = time.perf_counter) -> None:
        self._now = now

    def now(self) -> float:
        return self._now()

    def wait_until(self, due: float, stop: Waitable | None = None,
                   spin: float = 0.0) -> bool:
        """Sleep (on ``stop``, which wakes it) until ``spin`` before ``due``, spin the rest."""
        remaining = due - self._now() - spin
        if remaining > 0:
            if stop is not None:
                if stop.wait(remaining):
                    return True
            else:
                time.sleep(remaining)
        while self._now() < due:
            pass
        return stop is not None and stop.is_set()

    def sleep(self, seconds: float) -> None:
        time.sleep(seconds)


#: The default clock of an execution.
REAL_CLOCK = RealClock()


class VirtualClock:
    """Virtual time for tests: it moves only when waited on (or advanced).

    ``wait_until(due)`` sets the time to ``due`` at once, unless the clock is held at an
    earlier time (:meth:`hold`): then the wait parks until the hold moves past ``due`` or a
    stop is requested. Thread-safe: the streaming thread waits, a test thread holds,
    releases and advances.
    """

    #: how often a parked wait looks at its stop signal (real seconds)
    POLL_S = 0.002

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)
        self._limit = math.inf
        self._parked = False
        self._cond = threading.Condition()

    def now(self) -> float:
        with self._cond:
            return self._t

    def advance(self, seconds: float) -> None:
        """Time passes (a stalled host): the loop finds itself ``seconds`` later."""
        with self._cond:
            self._t += float(seconds)

    def sleep(self, seconds: float) -> None:
        self.advance(max(0.0, seconds))

    def wait_until(self, due: float, stop: Waitable | None = None,
                   spin: float = 0.0) -> bool:
        with self._cond:
            while due > self._limit:
                if stop is not None and stop.is_set():
                    self._parked = False
                    return True
                self._parked = True
                self._cond.notify_all()
                self._cond.wait(self.POLL_S)
            self._parked = False
            self._t = max(self._t, due)
        return stop is not None and stop.is_set()

    def hold(self, at: float) -> None:
        """Let the time run up to ``at`` and no further until :meth:`release` (or another
        hold)."""
        with self._cond:
            self._limit = float(at)
            self._parked = False
            self._cond.notify_all()

    def release(self) -> None:
        self.hold(math.inf)

    def wait_parked(self, timeout: float = 10.0) -> bool:
        """Block until a wait is parked at the hold (True), or ``timeout`` real seconds."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while not self._parked:
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._cond.wait(left)
            return True


def as_clock(clock: Clock | Callable[[], float]) -> Clock:
    """``clock`` as a :class:`Clock`: a bare callable is read as a real clock's ``now``."""
    if isinstance(clock, Clock):
        return clock
    return RealClock(clock)


__all__ = ["REAL_CLOCK", "Clock", "RealClock", "VirtualClock", "as_clock"]
