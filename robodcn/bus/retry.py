"""The one retry pattern of the bus: try again, flush stragglers, log every failed try.

Every transaction that fails (timeout, corrupt packet, error status, i.e. a
:class:`~robodcn.errors.CommError`) is tried again up to ``retries`` times by
:func:`retry`, which waits for a straggling reply, flushes it and logs the failed try
(logger ``robodcn.bus``) with the servo and the instruction (style.md "One retry pattern",
after LeRobot's motors bus). Callers never write retry loops of their own.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Protocol, TypeVar

from robodcn.errors import CommError

log = logging.getLogger("robodcn.bus")
T = TypeVar("T")

#: Pause before a retry, for a late reply to the failed attempt to arrive and be flushed (s).
STRAGGLER_S = 0.002


class Retrying(Protocol):
    """What :func:`retry` needs of a bus: its retry budget and counter, whether its device
    is lost, and a way to flush the port."""

    retries: int
    retries_used: int
    lost: bool

    def flush(self) -> None: ...


def retry(bus: Retrying, what: str, servo_id: int | None, fn: Callable[[], T], *,
          silence_expected: bool = False) -> T:
    """``fn()``, tried up to 1 + ``bus.retries`` times while it raises CommError.

    After each failed try (the last one too): wait :data:`STRAGGLER_S` and flush the
    port; before each retry, count it (``bus.retries_used``). Status packets carry no
    sequence number, so a late reply to the failed try arriving after the retry's
    instruction went out would pass for its answer (same id; the length check catches
    only a different size), and a late reply to the last try would pass for the next
    transaction's; the wait and the flush keep most out. Each failed try is logged
    (``robodcn.bus``, DEBUG; the last one WARNING) with the servo (``servo_id``; None:
    the whole bus) and the instruction (``what``). A lost device is not retried: its
    error is raised at once. ``silence_expected``: no answer is an answer the caller asked
    about (a PING looking for a free id), so the last try is logged at DEBUG too.
    """
    tries = bus.retries + 1
    for attempt in range(1, tries + 1):
        try:
            return fn()
        except CommError as exc:
            who = "bus" if servo_id is None else f"servo {servo_id}"
            level = logging.WARNING if attempt == tries and not silence_expected \
                else logging.DEBUG
            log.log(level, "%s: %s failed (try %d of %d): %s", who, what, attempt, tries,
                    exc.message)
            if bus.lost:
                raise
            # wait for a straggler and flush it after the last try too: else a late reply
            # to it would pass for the next transaction's answer
            time.sleep(STRAGGLER_S)
            bus.flush()
            if attempt == tries:
                raise
        bus.retries_used += 1
    raise AssertionError("unreachable")  # the loop returns or raises


__all__ = ["STRAGGLER_S", "Retrying", "retry"]
