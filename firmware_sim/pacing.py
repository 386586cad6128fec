"""Meeting wire-time deadlines from a Python thread.

The server thread of a :class:`~firmware_sim.bus.SimBus` sleeps to the instant each
reply byte would leave a real servo (:class:`Pacer`). Three things make a Python thread
late and are countered here: the OS timer slack (a sleeper wakes up to 50 µs late, so
the last stretch is spun, and the slack is cut to 1 µs where Linux allows), other
processes on the CPU (the thread's priority is raised where allowed) and the GIL switch
interval (the client's SDK spins holding the GIL for up to 5 ms by default:
:class:`SwitchInterval`).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
import threading
import time
from collections.abc import Callable
from typing import ClassVar

#: Spin window before a deadline with the default timer slack (50 µs) plus margin.
SPIN_S = 200e-6
#: Spin window once the thread's timer slack is 1 µs.
SPIN_TIGHT_S = 40e-6
#: Paced writes go out in chunks of about this long on the wire (one syscall each).
PACE_CHUNK_S = 100e-6
_PR_SET_TIMERSLACK = 29
_SERVER_NICE = -5


def sleep_until(deadline: float, spin_s: float = SPIN_S) -> None:
    """Sleep to a ``time.perf_counter()`` deadline: OS sleep for most, spin the last
    ``spin_s`` (the OS wakes a sleeper late by its timer slack, 50 µs by default)."""
    while True:
        remaining = deadline - time.perf_counter()
        if remaining <= 0:
            return
        if remaining > spin_s:
            time.sleep(remaining - spin_s)
        else:
            while time.perf_counter() < deadline:
                pass
            return


def tighten_timer_slack() -> bool:
    """Ask Linux for 1 µs timer slack on this thread (prctl PR_SET_TIMERSLACK).

    Sleeps then overshoot by ~10-20 µs instead of ~60 µs, so the pacing can sleep
    instead of spinning; spinning threads lose out to other processes under CPU load.
    """
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_TIMERSLACK, 1000, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


class Pacer:
    """Writes bytes no earlier than a real wire would carry them.

    Parameters
    ----------
    write : callable
        Puts bytes on the port at once.
    """

    def __init__(self, write: Callable[[bytes], None]) -> None:
        self._write = write
        self.spin_s = SPIN_S

    def adopt_thread(self) -> None:
        """Tune the calling thread (the one that will pace) for punctual wake-ups."""
        self.spin_s = SPIN_TIGHT_S if tighten_timer_slack() else SPIN_S
        # Real servos do not share the host's CPU; where allowed (root, CAP_SYS_NICE),
        # favour this mostly sleeping thread so host load disturbs its timing less.
        with contextlib.suppress(OSError):
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), _SERVER_NICE)

    def write(self, data: bytes, start: float, byte_s: float) -> float:
        """Write ``data`` so its last byte lands ``len * byte_s`` after ``start`` (a
        ``perf_counter`` time); return that end. ``byte_s = 0``: all at ``start``, and
        return when written."""
        if byte_s <= 0:
            sleep_until(start, self.spin_s)
            self._write(data)
            return time.perf_counter()
        per = max(1, int(PACE_CHUNK_S / byte_s))
        for k in range(0, len(data), per):
            piece = data[k:k + per]
            sleep_until(start + (k + len(piece)) * byte_s, self.spin_s)
            self._write(piece)
        return start + len(data) * byte_s


class SwitchInterval:
    """Holds the interpreter's GIL switch interval at most ``seconds`` while held.

    Shared by every holder in the process: the first hold saves the interval, the last
    release restores it. The SDK client spins on the port holding the GIL; with the
    default 5 ms interval the server thread can wait that long for it, and under CPU
    load long enough to miss the SDK's 34 ms timeout.
    """

    _users: ClassVar[int] = 0
    _saved: ClassVar[float] = 0.0
    _lock: ClassVar[threading.Lock] = threading.Lock()

    def __init__(self, seconds: float) -> None:
        if not seconds > 0:
            raise ValueError(f"switch interval must be > 0 s, got {seconds}")
        self.seconds = float(seconds)
        self._held = False

    def hold(self) -> None:
        if self._held:
            return
        cls = SwitchInterval
        with cls._lock:
            if cls._users == 0:
                cls._saved = sys.getswitchinterval()
            cls._users += 1
            sys.setswitchinterval(min(self.seconds, sys.getswitchinterval()))
        self._held = True

    def release(self) -> None:
        if not self._held:
            return
        cls = SwitchInterval
        with cls._lock:
            cls._users -= 1
            if cls._users == 0:
                sys.setswitchinterval(cls._saved)
        self._held = False
