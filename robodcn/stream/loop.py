"""The schedule: one Sync Write of goal ticks per sample on an absolute clock.

Sample i is due at t0 + i/rate on the execution's clock (:mod:`robodcn.stream.clock`; real
time by default); the wait sleeps until ``SPIN_S`` (``SPIN_REALTIME_S`` under SCHED_FIFO)
before the due time (on the stop signal, so a stop request wakes it at once) and spins the
rest. Time is never accumulated: a late cycle makes only its own write late. Rules:

* **overrun** — the loop reached sample i after its due time (the previous cycle's work
  spilled into this slot); the sample is sent at once and counted.
* **skip ahead** — if it is a whole period or more late, the samples whose slots have fully
  passed are not sent: it jumps to the latest due sample (never past the last) and counts
  the skipped ones; motion stays on the planned clock. With ``skip_late=False`` every
  sample is sent instead, the late ones back to back until the loop has caught up.

Every goal written keeps the joints' velocity limits (:mod:`robodcn.stream.step_guard`: a
source's goal beyond v_max·T of the one written before is slewed toward, and after the last
sample the loop writes on until the servos' goal is the source's last one).

A cycle reads at most once: a health poll takes the place of that cycle's position read
(the last sample always reads positions), so no cycle carries two round trips. The source
is read afresh at every sample: :meth:`Stream.swap` replaces it between two (online
operations, :mod:`robodcn.stream.online`).
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn.bus import ServoBus
from robodcn.errors import CommError
from robodcn.stream.compensation import max_steps
from robodcn.stream.feedback import CommFailures, Feedback
from robodcn.stream.options import ExecutionOptions
from robodcn.stream.realtime import SPIN_S
from robodcn.stream.report import Ending, Progress, StreamStop
from robodcn.stream.step_guard import StepGuard

log = logging.getLogger("robodcn.stream")

#: Minimum time between progress callbacks (s).
PROGRESS_INTERVAL_S = 0.05


class SentRecords:
    """Per sent sample, preallocated (no appends in the loop): its index, write start, due
    time and the cycle's work (write start to the end of its reads), on the loop's clock."""

    def __init__(self, n: int) -> None:
        self.index = [0] * n
        self.at = [0.0] * n
        self.due = [0.0] * n
        self.work = [0.0] * n
        self.count = 0

    def grow(self, n: int) -> None:
        """Room for ``n`` samples (a longer source swapped in)."""
        more = n - len(self.index)
        if more > 0:
            self.index.extend([0] * more)
            self.at.extend([0.0] * more)
            self.due.extend([0.0] * more)
            self.work.extend([0.0] * more)

    def last_index(self) -> int:
        """Index of the last sample sent (−1 before the first)."""
        return int(self.index[self.count - 1]) if self.count else -1


def wall_to_clock(clock: Any, t_wall: float, tries: int = 3) -> float:
    """UNIX time ``t_wall`` on ``clock``'s scale: the clock read on both sides of a
    ``time.time()`` read, the tightest of ``tries`` pairs (a thread switch between two
    reads would put the whole switch into the offset)."""
    best = (math.inf, 0.0, 0.0)
    for _ in range(tries):
        before = clock.now()
        wall = time.time()
        after = clock.now()
        if after - before < best[0]:
            best = (after - before, (before + after) / 2, wall)
    _, mid, wall = best
    return mid + (t_wall - wall)


class Stream:
    """The streaming loop of one execution (its schedule and bookkeeping)."""

    def __init__(self, source: Any, bus: ServoBus, opts: ExecutionOptions,
                 feedback: Feedback, failures: CommFailures) -> None:
        #: the sample source; re-read at every sample, so it may be replaced between two
        self.source = source
        self.bus = bus
        self.n = len(source)
        self.period = source.period
        self.rate_hz = source.rate_hz
        self.clock = opts.clock
        self.start_at = opts.start_at
        self.stop = opts.stop
        self.progress = opts.progress
        self.skip_late = opts.skip_late
        self.feedback_every = opts.feedback_every
        self.health_every = max(1, round(opts.health_interval / self.period))
        self.spin = SPIN_S
        self.realtime = False
        self.feedback = feedback
        self.failures = failures
        self.records = SentRecords(self.n)
        self.skipped_late = 0
        #: the source ended with its last goal not yet written (slewed writes followed it)
        self.caught_up = False
        self.failed_writes = 0
        self.overruns = 0
        self.retries_start = bus.retries_used
        #: the bound on every goal written (module notes); the first from the goal the
        #: servos held, where the source read it
        self.guard = StepGuard(max_steps(getattr(source, "arm", None), bus.servos,
                                         self.period, len(bus.ids)),
                               getattr(source, "start_goal", None))
        self.last_goal: NDArray[np.int64] | None = None
        self.previous_goal: NDArray[np.int64] | None = None
        self.ending = Ending()
        self.stop_latency: float | None = None
        self.t_start = 0.0
        self.t_end = 0.0
        self._last_progress = -math.inf

    # -- what online operations use ---------------------------------------------------------

    def swap(self, source: Any) -> None:
        """Replace the sample source between two samples (any thread; online operations).

        The per-sample records grow first, then the source, then the loop's bound: a loop
        that still runs to the old bound reads the new source, which answers every index."""
        self.records.grow(len(source))
        self.source = source
        self.n = len(source)

    @property
    def sent(self) -> int:
        """Samples sent so far."""
        return self.records.count

    @property
    def running(self) -> bool:
        """True until the loop has ended."""
        return self.t_end == 0.0

    def due_now(self) -> int:
        """Index of the sample due now on the loop's clock (−1 before the loop started)."""
        if not self.t_start:
            return -1
        return int((self.clock.now() - self.t_start) / self.period)

    # -- the loop ---------------------------------------------------------------------------

    def run(self) -> None:
        """Stream every sample (or until a stop); the outcome is in :attr:`ending`."""
        bus, period, clock, records = self.bus, self.period, self.clock, self.records
        guard = self.guard
        feedback_every = self.feedback_every
        watchdog_s = bus.watchdog_ms / 1000.0
        t0 = clock.now() + min(period, 0.002)
        if self.start_at is not None:  # a UNIX time on this loop's clock
            t0 = max(t0, wall_to_clock(clock, self.start_at))
        self.t_start = t0
        i = 0
        last_write = t0
        try:
            while i < self.n:
                n = self.n  # a swapped source may change the bound (swap)
                due = t0 + i * period
                if self.stop is not None and self.stop.is_set():
                    raise StreamStop("stopped", self._stop_message())
                now = clock.now()
                if now < due:
                    if clock.wait_until(due, self.stop, self.spin):
                        raise StreamStop("stopped", self._stop_message())
                    now = clock.now()
                elif now > due:
                    self.overruns += 1
                    if self.skip_late and now - due >= period and i < n - 1:
                        j = min(n - 1, int((now - t0) / period))
                        self.skipped_late += j - i
                        i = j
                        due = t0 + i * period
                if watchdog_s and now - last_write > watchdog_s:
                    # The host stalled past the watchdog: the servos may have stopped.
                    try:
                        self.feedback.check_watchdog()
                    except CommError as exc:
                        self.failures.failed(exc)
                source = self.source
                start = clock.now()
                try:
                    bus.write_encoded(guard.row(i, source.encoded(i)))
                except CommError as exc:
                    self.failed_writes += 1
                    self.failures.failed(exc)
                    i += 1
                    continue
                last_write = start
                if guard.behind():
                    self.feedback.slewed(i)
                slot = records.count
                records.index[slot] = i
                records.at[slot] = start
                records.due[slot] = due
                records.count += 1
                goal = source.goal(i)
                if (i + 1) % self.health_every == 0 and i != n - 1:
                    self.feedback.health()
                elif (feedback_every and i % feedback_every == 0) or i == n - 1:
                    previous = self.previous_goal
                    lag = guard.lag()
                    if lag is not None:     # the loop's own lag: not the servos' error
                        previous = goal - np.asarray(lag, dtype=np.int64)
                    self.feedback.read(self, i, goal, previous)
                self.previous_goal = goal
                self.last_goal = goal
                records.work[slot] = clock.now() - start
                if self.progress is not None and start - self._last_progress >= \
                        PROGRESS_INTERVAL_S:
                    self._last_progress = start
                    self._report_progress(i, start)
                i += 1
            if guard.behind():
                self.caught_up = True
                self._catch_up(t0, i)
        except StreamStop as stop:
            self.ending = stop.ending
            requested = getattr(self.stop, "requested_at", None)
            if stop.ending.reason == "stopped" and requested is not None:
                self.stop_latency = time.perf_counter() - requested
            log.info("stream stopped (%s): %s", stop.ending.reason, stop.ending.message)
        self.t_end = clock.now()
        if self.progress is not None and records.count:
            self._report_progress(records.last_index(), self.t_end)

    def _catch_up(self, t0: float, i: int) -> None:
        """After the last sample: write slewed goals on the schedule until the servos' goal
        is the source's last (a few periods at most; a stop request ends it, the hold keeps
        the goal written)."""
        guard, period = self.guard, self.period
        while guard.behind():
            if self.clock.wait_until(t0 + i * period, self.stop, self.spin):
                raise StreamStop("stopped", self._stop_message())
            try:
                self.bus.write_encoded(guard.catch_up(i))
            except CommError as exc:
                self.failed_writes += 1
                self.failures.failed(exc)
            i += 1
        log.debug("goal steps slewed to the velocity limit: %d", guard.slewed)

    def _stop_message(self) -> str:
        reason = getattr(self.stop, "reason", None)
        return reason or "stop requested"

    def _report_progress(self, i: int, now: float) -> None:
        assert self.progress is not None
        fb = self.feedback
        present = error = None
        if fb.last_present is not None:
            present = tuple(int(v) for v in fb.last_present)
        if fb.last_error is not None:
            error = tuple(float(v) for v in np.abs(fb.last_error) * fb.rad_per_tick)
        last = fb.last_feedback
        self.progress(Progress(
            i, self.n, now - self.t_start, tuple(int(v) for v in self.source.goal(i)), present,
            error, None if last is None else tuple(last.velocities.tolist()),
            None if last is None else tuple(last.currents.tolist())))


__all__ = ["PROGRESS_INTERVAL_S", "SentRecords", "Stream"]
