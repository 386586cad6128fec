"""Waiting precisely: timer slack and SCHED_FIFO for the streaming thread (Linux).

The last part of every wait is spun on the clock (sleeps overshoot by 50–100 µs on Linux);
the thread's timer slack is set to 1 µs while streaming (``PR_SET_TIMERSLACK``) so the
sleep itself ends close to its deadline. Under SCHED_FIFO a normal thread cannot lose the
CPU for a whole scheduler slice, which is what keeps a 1 kHz schedule on a loaded machine.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
import warnings
from collections.abc import Iterator

#: The last part of every wait is spun on the clock: sleeps overshoot by 50–100 µs on Linux.
SPIN_S = 0.0004
#: Spin window under SCHED_FIFO, where a 1 µs-slack sleep overshoots by < 50 µs; kept short
#: so a real-time spinner leaves the CPU to the kernel threads that move the serial bytes.
SPIN_REALTIME_S = 0.0001
#: SCHED_FIFO priority of the streaming thread with ``realtime=True`` (1..99; 50 leaves room
#: above for kernel threads such as USB interrupt handlers).
REALTIME_PRIORITY = 50
_PR_SET_TIMERSLACK, _PR_GET_TIMERSLACK = 29, 30


@contextlib.contextmanager
def timer_slack(ns: int = 1000) -> Iterator[None]:
    """The calling thread's timer slack set to ``ns`` inside the block (Linux; else no-op)."""
    prctl = None
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            prctl = ctypes.CDLL(None, use_errno=True).prctl
    old = prctl(_PR_GET_TIMERSLACK, 0, 0, 0, 0) if prctl is not None else -1
    if old > 0:
        prctl(_PR_SET_TIMERSLACK, ns, 0, 0, 0)
    try:
        yield
    finally:
        if old > 0:
            prctl(_PR_SET_TIMERSLACK, old, 0, 0, 0)


@contextlib.contextmanager
def realtime_priority(enabled: bool) -> Iterator[bool]:
    """SCHED_FIFO for the calling thread inside the block (Linux); yields whether it is on.

    Where that is not permitted (no CAP_SYS_NICE / rtprio limit, not Linux) a RuntimeWarning
    says so and the block runs at normal priority.
    """
    if not enabled:
        yield False
        return
    try:
        # pid 0 is the calling thread on Linux: only the streaming thread changes policy.
        old_policy = os.sched_getscheduler(0)
        old_param = os.sched_getparam(0)
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(REALTIME_PRIORITY))
    except (AttributeError, OSError) as exc:
        warnings.warn(f"realtime=True: cannot switch to SCHED_FIFO ({exc}); streaming at "
                      "normal priority (grant CAP_SYS_NICE or an rtprio limit in "
                      "/etc/security/limits.conf)", RuntimeWarning, stacklevel=4)
        yield False
        return
    try:
        yield True
    finally:
        os.sched_setscheduler(0, old_policy, old_param)
