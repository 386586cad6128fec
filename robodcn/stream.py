"""Execute a :class:`~robodcn.planner.Trajectory` on a :class:`~robodcn.bus.ServoBus` in real time.

``execute(trajectory, bus, ...)`` checks before the first write, streams one Sync Write of
goal ticks per sample on an absolute schedule, reads back present positions every k samples,
polls servo health, stops and holds on the first fault, and returns an
:class:`ExecutionReport`.

Before any write
    the servos that answer are the trajectory's (ids, models: :meth:`ServoBus.verify`); every
    tick is inside the servo limits; no servo reports a hardware error; the present
    positions are within ``start_tolerance`` of the first sample. Otherwise the call raises
    (ServoMismatchError, TickLimitError, HardwareAlertError, StartMismatchError), or, with
    ``approach=True``, re-plans the request from the present joints
    (``plan_request(replace(request, start_joints=present))``: the planner prepends a
    joint-space approach).

Schedule
    sample i is due at t0 + i/rate on a monotonic clock (``time.perf_counter``); the wait
    sleeps until ``SPIN_S`` (``SPIN_REALTIME_S`` under SCHED_FIFO) before the due time (on
    the stop signal, so a stop request wakes it at once) and spins the rest; the thread's
    timer slack is set to 1 µs while streaming (Linux ``PR_SET_TIMERSLACK``) so the sleep
    itself ends close to its deadline. Time is never accumulated: a late cycle makes only its
    own write late. Rules:

    * **overrun** — the loop reached sample i after its due time (the previous cycle's
      work spilled into this slot); the sample is sent at once and counted.
    * **skip ahead** — if it is a whole period or more late, the samples whose slots have
      fully passed are not sent: it jumps to the latest due sample (never past the last)
      and counts the skipped ones; motion stays on the planned clock. With
      ``skip_late=False`` every sample is sent instead, the late ones back to back until
      the loop has caught up with the clock (the servos then receive every planned goal).

Feedback and health
    present positions are read after the write on every ``feedback_every``-th sample and on
    the last one (0: only at the end). Tracking error of joint j is how far the present
    position lies outside the last commanded step, [previous goal, goal just sent]: a
    servo that follows within one sample (instantly, or a period behind) has error 0, one
    that lags or overshoots by more has the excess, in ticks and radians. Fast Sync Read
    hides a servo's Alert bit in the SDK, so the bus decodes the per-servo ERR bytes
    itself, and every ``health_interval`` seconds the streamer polls Hardware Error Status
    (70) and Bus Watchdog (98) in turn. A cycle reads at most once: a health poll takes the
    place of that cycle's position read (the last sample always reads positions), so no
    cycle carries two round trips.

Stops (``stop_reason``)
    "stopped" (a :class:`StopSignal`/``threading.Event`` set from any thread; acted on within
    one period), "comm_failure" (``max_comm_failures`` consecutive failed transactions, each
    after the bus's own retries), "hardware_alert" (Alert bit, non-zero Hardware Error
    Status or an expired Bus Watchdog), "tracking_error" (|error| above ``tracking_limit``
    rad on any joint), else "completed". On every stop the arm holds: the Bus Watchdog is
    disarmed (which also makes goals writable after a trip) and the freshly read present
    positions become the goals (if they cannot be read, the last goals sent: the arm is
    already within a sample of them, so it does not reverse). Torque goes off only with
    ``release=True`` (also after a completed move).

Bus Watchdog
    armed for the execution (``watchdog_ms``; default max(250 ms, 10 periods), at most
    2.54 s) so servos stop by themselves if this process dies or stalls; disarmed at the end.
    In position mode a servo already holds its last goal when the stream stops; the
    watchdog additionally freezes any profile in progress, so a generous timeout costs
    little and does not trip on a host that is merely slow for a moment.

Real-time priority
    with ``realtime=True`` the calling thread runs under SCHED_FIFO (priority
    ``REALTIME_PRIORITY``) for the execution and gets its old policy back afterwards; where
    that is not permitted (no CAP_SYS_NICE / rtprio limit, not Linux) a RuntimeWarning says
    so and the stream runs at normal priority. On a loaded machine this is what keeps a
    1 kHz schedule: a normal thread can lose the CPU for a whole scheduler slice.

Threading
    ``execute`` holds the bus (:meth:`ServoBus.claim`) for its whole duration: the calling
    thread owns the port; other threads get BusyError from the bus and stop through the
    stop signal.
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import math
import os
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from robodcn import servo_units
from robodcn.bus import ServoBus, StreamProfile, describe_hardware_error
from robodcn.errors import (
    BusError,
    CommError,
    HardwareAlertError,
    InputError,
    ServoMismatchError,
    StartMismatchError,
)
from robodcn.planner import Trajectory, plan_request

STOP_REASONS = ("completed", "stopped", "comm_failure", "hardware_alert", "tracking_error")
#: The last part of every wait is spun on the clock: sleeps overshoot by 50–100 µs on Linux.
SPIN_S = 0.0004
#: Spin window under SCHED_FIFO, where a 1 µs-slack sleep overshoots by < 50 µs; kept short
#: so a real-time spinner leaves the CPU to the kernel threads that move the serial bytes.
SPIN_REALTIME_S = 0.0001
_PR_SET_TIMERSLACK, _PR_GET_TIMERSLACK = 29, 30
#: SCHED_FIFO priority of the streaming thread with ``realtime=True`` (1..99; 50 leaves room
#: above for kernel threads such as USB interrupt handlers).
REALTIME_PRIORITY = 50
#: Minimum time between progress callbacks (s).
PROGRESS_INTERVAL_S = 0.05


class _Waitable(Protocol):
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


@dataclass(frozen=True)
class Progress:
    """What a progress callback receives: sample index (of n), seconds since the first write,
    last goals sent and last present positions read (ticks, bus order; None before any)."""

    sample: int
    samples_total: int
    elapsed_s: float
    goals: tuple[int, ...]
    present: tuple[int, ...] | None


@dataclass
class ExecutionReport:
    """The outcome of :func:`execute`; ``to_dict()`` is JSON-ready.

    Times are seconds. Jitter is the period jitter |(w_i − w_{i−1}) − (d_i − d_{i−1})| of
    consecutive writes (w: write start, d: due time). ``work_*`` is the time from a write's
    start to the end of that cycle's reads. Tracking errors are per joint, over the feedback
    samples; ``final_error_*`` compares the last present positions read with the last goal.
    ``stop_latency_s``: from :meth:`StopSignal.request` to the loop's exit (no write after).
    """

    stop_reason: str
    message: str
    samples_total: int
    samples_sent: int
    samples_skipped: int
    rate_hz: float
    achieved_rate_hz: float
    duration_s: float
    jitter_p50_s: float
    jitter_p99_s: float
    jitter_max_s: float
    lateness_max_s: float
    work_p50_s: float
    work_p99_s: float
    overruns: int
    retries: int
    comm_failures: int
    feedback_reads: int
    health_polls: int
    joint_names: tuple[str, ...]
    servo_ids: tuple[int, ...]
    tracking_error_max_rad: tuple[float, ...]
    tracking_error_rms_rad: tuple[float, ...]
    tracking_error_max_ticks: tuple[int, ...]
    tracking_error_rms_ticks: tuple[float, ...]
    final_positions: tuple[int, ...] | None
    final_error_ticks: tuple[int, ...] | None
    hold_goals: tuple[int, ...] | None
    hardware_errors: dict[int, int] = field(default_factory=dict)
    approach: bool = False
    released: bool = False
    fast_read: bool = False
    realtime: bool = False
    stop_latency_s: float | None = None

    @property
    def completed(self) -> bool:
        return self.stop_reason == "completed"

    def to_dict(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        data["hardware_errors"] = {str(k): v for k, v in self.hardware_errors.items()}
        for key, value in data.items():
            if isinstance(value, tuple):
                data[key] = list(value)
        return data


@contextlib.contextmanager
def _timer_slack(ns: int = 1000) -> Iterator[None]:
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
def _realtime_priority(enabled: bool) -> Iterator[bool]:
    """SCHED_FIFO for the calling thread inside the block (Linux); yields whether it is on."""
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


class _Stop(Exception):
    """Internal: leave the streaming loop with a reason."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason
        self.message = message


def _radians_per_tick(bus: ServoBus) -> NDArray[np.float64]:
    return np.array([2.0 * math.pi / s.ticks_per_turn for s in bus.servos])


def _percentile(values: NDArray[np.float64], q: float) -> float:
    return float(np.percentile(values, q)) if values.size else 0.0


def _check_positive(name: str, value: Any, *, allow_zero: bool = False,
                    allow_none: bool = False) -> None:
    if value is None and allow_none:
        return
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value < 0 or (value == 0 and not allow_zero):
        bound = "≥ 0" if allow_zero else "> 0"
        raise InputError(f"{name} must be a finite number {bound}, got {value!r}", field=name,
                         value=value)


def _start_gap(trajectory: Trajectory, bus: ServoBus,
               present: NDArray[np.int64]) -> NDArray[np.float64]:
    """Per-joint |present − first sample| in radians."""
    return np.abs(present - trajectory.ticks[0]) * _radians_per_tick(bus)


def _plan_approach(trajectory: Trajectory, bus: ServoBus,
                   present: NDArray[np.int64]) -> Trajectory:
    if trajectory.request is None:
        raise InputError("approach=True needs a trajectory that carries its PlanRequest "
                         "(plan it with robodcn.plan or load it with its arm)",
                         field="approach", value=True)
    joints = servo_units.ticks_to_radians(present, bus.servos)
    return plan_request(dataclasses.replace(trajectory.request,
                                            start_joints=tuple(float(q) for q in joints)))


def execute(trajectory: Trajectory, bus: ServoBus, *, feedback_every: int = 1,
            start_tolerance: float = 0.05, approach: bool = False, max_comm_failures: int = 3,
            tracking_limit: float | None = 0.25,
            stop: StopSignal | threading.Event | None = None,
            progress: Callable[[Progress], None] | None = None, release: bool = False,
            health_interval: float = 0.05, watchdog_ms: float | None = None,
            profile: StreamProfile | None = None, settle: float = 0.0,
            skip_late: bool = True, realtime: bool = False,
            clock: Callable[[], float] = time.perf_counter) -> ExecutionReport:
    """Stream ``trajectory`` to the servos on ``bus`` (module docstring for the rules).

    Parameters
    ----------
    trajectory : planned samples; its ``servo_ids`` must equal ``bus.ids`` (same order).
    bus : an open :class:`ServoBus`.
    feedback_every : read present positions every k-th sample (0: only at the end).
    start_tolerance : radians; largest |present − first sample| accepted per joint.
    approach : re-plan from the present joints instead of refusing when out of tolerance.
    max_comm_failures : consecutive failed transactions that stop the stream.
    tracking_limit : radians; None disables the tracking stop.
    stop : set from any thread to stop; the arm holds.
    progress : called with :class:`Progress` at most every 50 ms and at the end.
    release : torque off when finished or stopped (otherwise the servos hold).
    health_interval : seconds between Hardware Error Status / Bus Watchdog polls.
    watchdog_ms : Bus Watchdog timeout; None = max(250 ms, 10 periods); 0 = not armed.
    profile : passed to :meth:`ServoBus.configure` when the servos need configuring.
    settle : seconds to keep reading after the last sample until the arm is within one
        tick of the final goal (0: one read).
    skip_late : skip samples whose slot has passed (True) or send them late (False).
    realtime : run the calling thread under SCHED_FIFO while streaming (see above).
    clock : monotonic clock in seconds (real time: the waits sleep on it).

    Returns
    -------
    ExecutionReport; stops are reported, not raised. Refusals before the first write raise
    ServoMismatchError, TickLimitError, HardwareAlertError, StartMismatchError or InputError.
    """
    if not isinstance(trajectory, Trajectory):
        raise InputError(f"trajectory must be a robodcn Trajectory, got "
                         f"{type(trajectory).__name__}", field="trajectory", value=trajectory)
    if not isinstance(bus, ServoBus):
        raise InputError(f"bus must be a robodcn ServoBus, got {type(bus).__name__}",
                         field="bus", value=bus)
    if isinstance(feedback_every, bool) or not isinstance(feedback_every, int) \
            or feedback_every < 0:
        raise InputError(f"feedback_every must be an integer ≥ 0, got {feedback_every!r}",
                         field="feedback_every", value=feedback_every)
    if isinstance(max_comm_failures, bool) or not isinstance(max_comm_failures, int) \
            or max_comm_failures < 1:
        raise InputError(f"max_comm_failures must be an integer ≥ 1, got "
                         f"{max_comm_failures!r}", field="max_comm_failures",
                         value=max_comm_failures)
    _check_positive("start_tolerance", start_tolerance)
    _check_positive("tracking_limit", tracking_limit, allow_none=True)
    _check_positive("health_interval", health_interval)
    _check_positive("watchdog_ms", watchdog_ms, allow_zero=True, allow_none=True)
    _check_positive("settle", settle, allow_zero=True)
    if stop is not None and not (hasattr(stop, "is_set") and hasattr(stop, "wait")):
        raise InputError("stop must be a StopSignal or threading.Event", field="stop",
                         value=stop)
    if tuple(trajectory.servo_ids) != bus.ids:
        raise ServoMismatchError(
            f"the trajectory drives servo ids {list(trajectory.servo_ids)}, the bus has "
            f"{list(bus.ids)} (same ids in the same order needed)", field="servo_ids",
            value=list(trajectory.servo_ids))

    with bus.claim():
        # -- refusals: nothing has been written yet ---------------------------------------
        bus.verify()
        bus.check_ticks(trajectory.ticks)
        errors = bus.hardware_errors()
        if any(errors.values()):
            bad = {i: describe_hardware_error(e) for i, e in errors.items() if e}
            raise HardwareAlertError(
                f"servo(s) report a hardware error: {bad}; fix the cause and reboot the servo "
                "(Hardware Error Status clears only on reboot)", field="servos", value=errors)
        present = bus.read_positions()
        gap = _start_gap(trajectory, bus, present)
        approached = False
        if gap.max() > start_tolerance:
            if not approach:
                worst = int(np.argmax(gap))
                raise StartMismatchError(
                    f"the arm is {math.degrees(gap[worst]):.1f}° from the trajectory's start "
                    f"at joint {trajectory.joint_names[worst]!r} (present tick "
                    f"{int(present[worst])}, first sample {int(trajectory.ticks[0, worst])}; "
                    f"tolerance {math.degrees(start_tolerance):.1f}°); move it there first "
                    "or pass approach=True", field="start", value=gap.tolist())
            trajectory = _plan_approach(trajectory, bus, present)
            bus.check_ticks(trajectory.ticks)
            approached = True

        streamer = _Streamer(trajectory, bus, feedback_every=feedback_every,
                             max_comm_failures=max_comm_failures,
                             tracking_limit=tracking_limit, stop=stop, progress=progress,
                             health_interval=health_interval, skip_late=bool(skip_late),
                             clock=clock)
        # -- configure (first writes) and stream --------------------------------------------
        if not bus.configured or not all(bus.torque_enabled().values()):
            bus.configure(profile)
        period = 1.0 / trajectory.rate_hz
        if watchdog_ms is None:
            watchdog_ms = max(250.0, 10_000.0 * period)
        if watchdog_ms:
            bus.arm_watchdog(watchdog_ms)
        try:
            with _timer_slack(), _realtime_priority(realtime) as streamer.realtime:
                if streamer.realtime:
                    streamer.spin = SPIN_REALTIME_S
                streamer.run()
        except BaseException:
            streamer.finish(hold=True, release=release, settle=0.0)
            raise
        streamer.finish(hold=streamer.reason != "completed", release=release, settle=settle)
        return streamer.report(approached)


class _Streamer:
    """The streaming loop and its bookkeeping (one instance per execution)."""

    def __init__(self, trajectory: Trajectory, bus: ServoBus, *, feedback_every: int,
                 max_comm_failures: int, tracking_limit: float | None,
                 stop: _Waitable | None, progress: Callable[[Progress], None] | None,
                 health_interval: float, skip_late: bool,
                 clock: Callable[[], float]) -> None:
        self.trajectory = trajectory
        self.bus = bus
        self.ticks = trajectory.ticks
        self.n = len(trajectory.ticks)
        self.period = 1.0 / trajectory.rate_hz
        self.encoded = bus.encode_goals(trajectory.ticks)
        self.feedback_every = feedback_every
        self.max_comm_failures = max_comm_failures
        self.tracking_limit = tracking_limit
        self.stop = stop
        self.progress = progress
        self.health_every = max(1, round(health_interval / self.period))
        self.clock = clock
        self.skip_late = skip_late
        self.spin = SPIN_S
        self.rad_per_tick = _radians_per_tick(bus)
        self.tick_limit = (None if tracking_limit is None
                           else tracking_limit / self.rad_per_tick)
        self.retries_start = bus.retries_used
        # Per sent sample (preallocated: no appends in the loop).
        self.sent_index = [0] * self.n
        self.sent_at = [0.0] * self.n
        self.due_at = [0.0] * self.n
        self.work = [0.0] * self.n
        self.errors: list[NDArray[np.int64]] = []
        self.sent = 0
        self.skipped = 0
        self.overruns = 0
        self.comm_failures = 0
        self.consecutive_failures = 0
        self.feedback_reads = 0
        self.health_polls = 0
        self.last_goal: NDArray[np.int64] | None = None
        self.previous_goal: NDArray[np.int64] | None = None
        self.last_present: NDArray[np.int64] | None = None
        self.hardware: dict[int, int] = {}
        self.reason = "completed"
        self.message = "all samples sent"
        self.hold_goals: NDArray[np.int64] | None = None
        self.final: NDArray[np.int64] | None = None
        self.released = False
        self.realtime = False
        self.stop_latency: float | None = None
        self.t_start = 0.0
        self.t_end = 0.0
        self._last_progress = -math.inf

    # -- waiting --------------------------------------------------------------------------

    def _wait(self, due: float) -> bool:
        """Sleep until ``due``; True if a stop was requested meanwhile."""
        clock = self.clock
        remaining = due - clock() - self.spin
        if remaining > 0:
            if self.stop is not None:
                if self.stop.wait(remaining):
                    return True
            else:
                time.sleep(remaining)
        while clock() < due:
            pass
        return self.stop is not None and self.stop.is_set()

    # -- bus transactions that count as failures, not exceptions -------------------------

    def _failed(self, exc: BusError) -> None:
        self.comm_failures += 1
        self.consecutive_failures += 1
        if self.consecutive_failures >= self.max_comm_failures:
            raise _Stop("comm_failure", f"{self.consecutive_failures} consecutive "
                        f"communication failures; last: {exc.message}")

    def _alert(self, ids: Sequence[int]) -> None:
        try:
            self.hardware = self.bus.hardware_errors()
        except BusError:
            self.hardware = {i: -1 for i in ids}
        described = {i: describe_hardware_error(e) if e > 0 else "alert bit set"
                     for i, e in self.hardware.items() if e}
        raise _Stop("hardware_alert", f"hardware alert on servo(s) {described or list(ids)}")

    def _feedback(self, sample: int, goal: NDArray[np.int64]) -> None:
        try:
            present = self.bus.read_positions()
        except CommError as exc:
            self._failed(exc)
            return
        self.consecutive_failures = 0
        self.feedback_reads += 1
        self.last_present = present
        if self.bus.last_alert_ids:
            self._alert(self.bus.last_alert_ids)
        previous = self.previous_goal if self.previous_goal is not None else goal
        error = present - np.clip(present, np.minimum(previous, goal),
                                  np.maximum(previous, goal))
        self.errors.append(error)
        if self.tick_limit is not None:
            over = np.abs(error) > self.tick_limit
            if over.any():
                j = int(np.argmax(over))
                raise _Stop("tracking_error",
                            f"tracking error {abs(error[j]) * self.rad_per_tick[j]:.3f} rad "
                            f"({int(error[j])} ticks) at joint "
                            f"{self.trajectory.joint_names[j]!r}, sample {sample}, limit "
                            f"{self.tracking_limit:.3f} rad")

    def _health(self) -> None:
        self.health_polls += 1
        try:
            if self.health_polls % 2:
                errors = self.bus.hardware_errors()
                alerts = self.bus.last_alert_ids
                self.consecutive_failures = 0
                if any(errors.values()) or alerts:
                    self._alert(alerts or [i for i, e in errors.items() if e])
            else:
                self._check_watchdog()
        except CommError as exc:
            self._failed(exc)

    def _check_watchdog(self) -> None:
        status = self.bus.watchdog_status()
        self.consecutive_failures = 0
        tripped = [i for i, v in status.items() if v < 0]
        if tripped:
            raise _Stop("hardware_alert",
                        f"bus watchdog expired on servo(s) {tripped} (no instruction for "
                        f"{self.bus.watchdog_ms} ms); they stopped by themselves")

    # -- the loop -------------------------------------------------------------------------

    def run(self) -> None:
        bus, period, n, clock = self.bus, self.period, self.n, self.clock
        feedback_every = self.feedback_every
        watchdog_s = bus.watchdog_ms / 1000.0
        t0 = clock() + min(period, 0.002)
        self.t_start = t0
        i = 0
        last_write = t0
        try:
            while i < n:
                due = t0 + i * period
                if self.stop is not None and self.stop.is_set():
                    raise _Stop("stopped", self._stop_message())
                now = clock()
                if now < due:
                    if self._wait(due):
                        raise _Stop("stopped", self._stop_message())
                    now = clock()
                elif now > due:
                    self.overruns += 1
                    if self.skip_late and now - due >= period and i < n - 1:
                        j = min(n - 1, int((now - t0) / period))
                        self.skipped += j - i
                        i = j
                        due = t0 + i * period
                if watchdog_s and now - last_write > watchdog_s:
                    # The host stalled past the watchdog: the servos may have stopped.
                    try:
                        self._check_watchdog()
                    except CommError as exc:
                        self._failed(exc)
                start = clock()
                try:
                    bus.write_encoded(self.encoded[i])
                except CommError as exc:
                    self._failed(exc)
                    i += 1
                    continue
                last_write = start
                slot = self.sent
                self.sent_index[slot] = i
                self.sent_at[slot] = start
                self.due_at[slot] = due
                self.sent += 1
                goal = self.ticks[i]
                if (i + 1) % self.health_every == 0 and i != n - 1:
                    self._health()
                elif (feedback_every and i % feedback_every == 0) or i == n - 1:
                    self._feedback(i, goal)
                self.previous_goal = goal
                self.last_goal = goal
                self.work[slot] = clock() - start
                if self.progress is not None and start - self._last_progress >= \
                        PROGRESS_INTERVAL_S:
                    self._last_progress = start
                    self._report_progress(i, start)
                i += 1
        except _Stop as stop:
            self.reason = stop.reason
            self.message = stop.message
            requested = getattr(self.stop, "requested_at", None)
            if stop.reason == "stopped" and requested is not None:
                self.stop_latency = time.perf_counter() - requested
        self.t_end = clock()
        if self.progress is not None and self.sent:
            self._report_progress(self.sent_index[self.sent - 1], self.t_end)

    def _stop_message(self) -> str:
        reason = getattr(self.stop, "reason", None)
        return reason or "stop requested"

    def _report_progress(self, i: int, now: float) -> None:
        assert self.progress is not None
        present = None if self.last_present is None else tuple(int(v) for v in
                                                                 self.last_present)
        self.progress(Progress(i, self.n, now - self.t_start,
                               tuple(int(v) for v in self.ticks[i]), present))

    # -- after the loop -------------------------------------------------------------------

    def finish(self, *, hold: bool, release: bool, settle: float) -> None:
        """Hold (when stopped), disarm the watchdog, read the final positions, release."""
        bus = self.bus
        try:
            bus.disarm_watchdog()
        except BusError:
            pass  # a dead link cannot be disarmed; the hold below may still get through
        if hold:
            try:
                goals = bus.read_positions()
                self.last_present = goals
            except BusError:
                goals = self.last_goal if self.last_goal is not None else self.last_present
            if goals is not None:
                goals = np.clip(goals, bus.limits[:, 0], bus.limits[:, 1])
                try:
                    bus.write_encoded(bus.encode_goals(goals[None, :])[0])
                    self.hold_goals = goals
                except BusError:
                    pass
        self._final(settle, self.hold_goals if hold else self.last_goal)
        if release:
            try:
                bus.torque(False)
                self.released = True
            except BusError:
                pass

    def _final(self, settle: float, target: NDArray[np.int64] | None) -> None:
        deadline = time.perf_counter() + settle
        while True:
            try:
                self.final = self.bus.read_positions()
            except BusError:
                return
            if target is None or np.abs(self.final - target).max() <= 1 \
                    or time.perf_counter() >= deadline:
                return
            time.sleep(0.005)

    def report(self, approached: bool) -> ExecutionReport:
        sent = self.sent
        at = np.array(self.sent_at[:sent])
        due = np.array(self.due_at[:sent])
        jitter = np.abs(np.diff(at) - np.diff(due)) if sent > 1 else np.zeros(0)
        work = np.array(self.work[:sent])
        span = at[-1] - at[0] if sent > 1 else 0.0
        k = len(self.bus.ids)
        if self.errors:
            err = np.abs(np.array(self.errors, dtype=np.float64))
            max_ticks = err.max(axis=0)
            rms_ticks = np.sqrt(np.mean(err ** 2, axis=0))
        else:
            max_ticks = rms_ticks = np.zeros(k)
        final_error = None
        if self.final is not None and self.last_goal is not None:
            target = self.hold_goals if self.hold_goals is not None else self.last_goal
            final_error = tuple(int(v) for v in self.final - target)
        return ExecutionReport(
            stop_reason=self.reason, message=self.message, samples_total=self.n,
            samples_sent=sent, samples_skipped=self.skipped, rate_hz=self.trajectory.rate_hz,
            achieved_rate_hz=(sent - 1) / span if span > 0 else 0.0,
            duration_s=self.t_end - self.t_start if sent else 0.0,
            jitter_p50_s=_percentile(jitter, 50), jitter_p99_s=_percentile(jitter, 99),
            jitter_max_s=float(jitter.max()) if jitter.size else 0.0,
            lateness_max_s=float(np.max(at - due)) if sent else 0.0,
            work_p50_s=_percentile(work, 50), work_p99_s=_percentile(work, 99),
            overruns=self.overruns, retries=self.bus.retries_used - self.retries_start,
            comm_failures=self.comm_failures, feedback_reads=self.feedback_reads,
            health_polls=self.health_polls, joint_names=tuple(self.trajectory.joint_names),
            servo_ids=tuple(self.bus.ids),
            tracking_error_max_rad=tuple(float(v) for v in max_ticks * self.rad_per_tick),
            tracking_error_rms_rad=tuple(float(v) for v in rms_ticks * self.rad_per_tick),
            tracking_error_max_ticks=tuple(int(v) for v in max_ticks),
            tracking_error_rms_ticks=tuple(float(v) for v in rms_ticks),
            final_positions=None if self.final is None else tuple(int(v) for v in self.final),
            final_error_ticks=final_error,
            hold_goals=None if self.hold_goals is None else tuple(int(v)
                                                                  for v in self.hold_goals),
            hardware_errors=dict(self.hardware), approach=approached, released=self.released,
            fast_read=bool(self.bus.fast_read), realtime=self.realtime,
            stop_latency_s=self.stop_latency)


__all__ = ["STOP_REASONS", "ExecutionReport", "Progress", "StopSignal", "execute"]
