"""Execute a :class:`~robodcn.planner.Trajectory` on a :class:`~robodcn.bus.ServoBus` in real time.

``execute(trajectory, bus, options)`` (:class:`~robodcn.stream.options.ExecutionOptions`,
or the same options as keywords) checks before the first write, streams one Sync Write of
goal ticks per sample on an absolute schedule, reads back present positions every k samples,
polls servo health, stops and holds on the first fault, and returns an
:class:`ExecutionReport`.

Before any write
    the servos that answer are the trajectory's (ids, models: :meth:`ServoBus.verify`); every
    tick is inside the servo limits; no servo reports a hardware error; the present
    positions are within ``start_tolerance`` of the first sample. Otherwise the call raises
    (ServoMismatchError, TickLimitError, HardwareAlertError, StartMismatchError), or, with
    ``approach=True``, re-plans the request from the present joints
    (:func:`robodcn.present.plan_from_present`: the planner prepends a joint-space
    approach, reported as ``ExecutionReport.approach``). When the rate needs more wire time
    a sample than the bus has at its baud (:func:`robodcn.stream.rate.check_rate`), a
    :class:`~robodcn.stream.rate.RateWarning` is issued and kept in the report.

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
    the last one (0: only at the end), in one place (``_Streamer._feedback``). Tracking
    error (:func:`robodcn.stream.report.tracking_error`, the same for Progress and the
    report) of joint j is how far the present position lies outside the last planned
    step, [previous planned goal, the plan at the end of the read] (the plan, not the
    compensated goals actually sent: :mod:`robodcn.stream.compensation`). With the
    feedback map (:meth:`ServoBus.read_feedback`) the same packet brings velocities,
    currents and hardware errors: peaks per joint in the report and the collision stop
    ("collision": |current| above its threshold for ``collision_cycles`` reads, reported
    with joint, current, sample, time and pose; :mod:`robodcn.stream.collision`). Every
    read is recorded (time, ticks, tracking error, current) in preallocated arrays:
    ``ExecutionReport.trace`` (:mod:`robodcn.stream.trace`). Fast Sync Read
    hides a servo's Alert bit in the SDK, so the bus decodes the per-servo ERR bytes
    itself, and every ``health_interval`` seconds the streamer polls Hardware Error Status
    (70) and Bus Watchdog (98) in turn. A cycle reads at most once: a health poll takes the
    place of that cycle's position read (the last sample always reads positions), so no
    cycle carries two round trips.

Stops (``stop_reason``)
    "stopped" (a :class:`StopSignal`/``threading.Event`` set from any thread; acted on within
    one period), "comm_failure" (``max_comm_failures`` consecutive failed transactions, each
    after the bus's own retries; at once when the serial device is lost), "hardware_alert"
    (Alert bit, non-zero Hardware Error Status or an expired Bus Watchdog),
    "tracking_error" (|error| above ``tracking_limit`` rad on any joint), else "completed".
    ``ExecutionReport.outcome`` sums it up: "done" (every sample sent), "degraded"
    (completed with samples skipped), "stopped", "fault". On every stop the arm holds: the
    Bus Watchdog is disarmed (which also makes goals writable after a trip) and the freshly
    read present positions become the goals (if they cannot be read, the last goals sent:
    the arm is already within a sample of them, so it does not reverse). Torque goes off
    only with ``release=True`` (also after a completed move). With the device lost, none
    of this can reach the servos: the Bus Watchdog stops them by themselves.

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

import logging
import math
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn.bus import (
    ADDR_GOAL_POSITION,
    ADDR_PRESENT_POSITION,
    ADDR_TORQUE_ENABLE,
    FEEDBACK_LENGTH,
    ServoBus,
    describe_hardware_error,
)
from robodcn.errors import (
    BusError,
    CommError,
    HardwareAlertError,
    InputError,
    ServoMismatchError,
    StartMismatchError,
)
from robodcn.kinematics import fk
from robodcn.planner import Trajectory
from robodcn.present import Approach, approach_of, plan_from_present
from robodcn.servo_units import ticks_to_radians
from robodcn.stream.collision import predicted_currents, thresholds
from robodcn.stream.options import ExecutionOptions
from robodcn.stream.rate import check_rate
from robodcn.stream.realtime import SPIN_REALTIME_S, SPIN_S, realtime_priority, timer_slack
from robodcn.stream.report import ExecutionReport, Progress, near_limits, tracking_error
from robodcn.stream.signal import Waitable
from robodcn.stream.source import PlannedSamples
from robodcn.stream.trace import ExecutionTrace, TraceRecorder

log = logging.getLogger("robodcn.stream")

#: Hardware Error Status bit of an overload (what ``recover=True`` acts on).
OVERLOAD_BIT = 0x20
#: Minimum time between progress callbacks (s).
PROGRESS_INTERVAL_S = 0.05
#: A final reading one tick off its target counts once unchanged for this long (s).
REST_S = 0.05


class _Stop(Exception):
    """Internal: leave the streaming loop with a reason."""

    def __init__(self, reason: str, message: str, detail: dict[str, Any] | None = None) -> None:
        super().__init__(message)
        self.reason = reason
        self.message = message
        self.detail = detail


def _radians_per_tick(bus: ServoBus) -> NDArray[np.float64]:
    return np.array([2.0 * math.pi / s.ticks_per_turn for s in bus.servos])


def _percentile(values: NDArray[np.float64], q: float) -> float:
    return float(np.percentile(values, q)) if values.size else 0.0


def _plan_approach(trajectory: Trajectory, bus: ServoBus,
                   present: NDArray[np.int64]) -> Trajectory:
    request = trajectory.request
    if request is None:
        raise InputError("approach=True needs a trajectory that carries its PlanRequest "
                         "(plan it with robodcn.plan or load it with its arm)",
                         field="approach", value=True)
    return plan_from_present(request.arm, bus, request,
                             joints=ticks_to_radians(present, bus.servos))


def execute(trajectory: Trajectory, bus: ServoBus, options: ExecutionOptions | None = None,
            **kwargs: Any) -> ExecutionReport:
    """Stream ``trajectory`` to the servos on ``bus`` (module docstring for the rules).

    Parameters
    ----------
    trajectory : planned samples; its ``servo_ids`` must equal ``bus.ids`` (same order).
    bus : an open :class:`ServoBus`.
    options : :class:`ExecutionOptions` (default: all defaults).
    kwargs : fields of :class:`ExecutionOptions`, over ``options`` (an unknown name or a
        bad value is an InputError naming it).

    Returns
    -------
    ExecutionReport; stops are reported, not raised (a lost serial device too: outcome
    "fault"). Refusals before the first write raise ServoMismatchError, TickLimitError,
    HardwareAlertError, StartMismatchError, CommError or InputError.
    """
    opts = ExecutionOptions.build(options, kwargs)
    if not isinstance(trajectory, Trajectory):
        raise InputError(f"trajectory must be a robodcn Trajectory, got "
                         f"{type(trajectory).__name__}", field="trajectory", value=trajectory)
    if not isinstance(bus, ServoBus):
        raise InputError(f"bus must be a robodcn ServoBus, got {type(bus).__name__}",
                         field="bus", value=bus)
    if tuple(trajectory.servo_ids) != bus.ids:
        raise ServoMismatchError(
            f"the trajectory drives servo ids {list(trajectory.servo_ids)}, the bus has "
            f"{list(bus.ids)} (same ids in the same order needed)", field="servo_ids",
            value=list(trajectory.servo_ids))

    if opts.collision_current is not None and len(opts.collision_current) != len(bus.ids):
        raise InputError(f"collision_current needs {len(bus.ids)} currents (A, one per "
                         f"joint), got {list(opts.collision_current)}",
                         field="collision_current", value=list(opts.collision_current))
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
        gap = np.abs(present - trajectory.ticks[0]) * _radians_per_tick(bus)
        approach: Approach | None = None
        if gap.max() > opts.start_tolerance:
            if not opts.approach:
                worst = int(np.argmax(gap))
                raise StartMismatchError(
                    f"the arm is {math.degrees(gap[worst]):.1f}° from the trajectory's start "
                    f"at joint {trajectory.joint_names[worst]!r} (present tick "
                    f"{int(present[worst])}, first sample {int(trajectory.ticks[0, worst])}; "
                    f"tolerance {math.degrees(opts.start_tolerance):.1f}°); move it there "
                    "first or pass approach=True", field="start", value=gap.tolist())
            trajectory = _plan_approach(trajectory, bus, present)
            bus.check_ticks(trajectory.ticks)
            approach = approach_of(trajectory) or Approach(0, 0.0)
            log.info("approach inserted: %d samples, %.3f s", approach.samples,
                     approach.duration_s)
        issued = []
        profile_rdt = 0 if opts.profile is None else opts.profile.return_delay_us
        rate = check_rate(trajectory.rate_hz, len(bus.ids), bus.baud,
                          feedback_every=opts.feedback_every, fast_read=bus.fast_read,
                          return_delay_us=profile_rdt, item_bytes=FEEDBACK_LENGTH)
        if rate is not None:
            log.warning("%s", rate.info.message)
            warnings.warn(rate, stacklevel=2)
            issued.append(rate.to_dict())

        # -- configure (first writes) and stream --------------------------------------------
        if not bus.configured or not all(bus.torque_enabled().values()):
            bus.configure(opts.profile)
        source = PlannedSamples(trajectory, bus, compensation=opts.compensation)
        streamer = _Streamer(source, bus, opts)
        streamer.plan_limits(trajectory, opts)
        period = 1.0 / trajectory.rate_hz
        watchdog_ms = opts.watchdog_ms
        if watchdog_ms is None:
            watchdog_ms = max(250.0, 10_000.0 * period)
        if watchdog_ms:
            bus.arm_watchdog(watchdog_ms)
        log.info("streaming %d samples at %g Hz to servos %s", len(streamer.source),
                 trajectory.rate_hz, list(bus.ids))
        try:
            with timer_slack(), realtime_priority(opts.realtime) as streamer.realtime:
                if streamer.realtime:
                    streamer.spin = SPIN_REALTIME_S
                if opts.attach is not None:
                    opts.attach(streamer)
                streamer.run()
        except BaseException:
            streamer.finish(hold=True, release=opts.release, settle=0.0)
            raise
        streamer.finish(hold=streamer.reason != "completed", release=opts.release,
                        settle=opts.settle)
        report = streamer.report(approach, tuple(issued) + tuple(streamer.warnings))
        log.info("%s", report.headline)
        return report


class _Streamer:
    """The streaming loop and its bookkeeping (one instance per execution)."""

    def __init__(self, source: PlannedSamples, bus: ServoBus, opts: ExecutionOptions) -> None:
        #: The sample source; re-read at every sample, so it may be replaced between two.
        self.source = source
        self.bus = bus
        self.n = len(source)
        self.period = source.period
        self.rate_hz = source.rate_hz
        self.joint_names = source.joint_names
        self.feedback_every = opts.feedback_every
        self.max_comm_failures = opts.max_comm_failures
        self.tracking_limit = opts.tracking_limit
        self.stop: Waitable | None = opts.stop
        self.progress: Callable[[Progress], None] | None = opts.progress
        self.health_every = max(1, round(opts.health_interval / self.period))
        self.clock = opts.clock
        self.skip_late = opts.skip_late
        self.spin = SPIN_S
        self.rad_per_tick = _radians_per_tick(bus)
        self.tick_limit = (None if self.tracking_limit is None
                           else self.tracking_limit / self.rad_per_tick)
        self.retries_start = bus.retries_used
        # Per sent sample (preallocated: no appends in the loop).
        self.sent_index = [0] * self.n
        self.sent_at = [0.0] * self.n
        self.due_at = [0.0] * self.n
        self.work = [0.0] * self.n
        self.errors: list[NDArray[np.float64]] = []
        self.sent = 0
        self.skipped_late = 0
        self.failed_writes = 0
        self.overruns = 0
        self.comm_failures = 0
        self.consecutive_failures = 0
        self.feedback_reads = 0
        self.health_polls = 0
        self.last_goal: NDArray[np.int64] | None = None
        self.previous_goal: NDArray[np.int64] | None = None
        self.last_present: NDArray[np.int64] | None = None
        self.last_error: NDArray[np.float64] | None = None
        self.hardware: dict[int, int] = {}
        self.reason = "completed"
        self.message = "all samples sent"
        #: What stopped the stream, as data (SI) for the surfaces to word in their units.
        self.stop_detail: dict[str, Any] | None = None
        self.hold_goals: NDArray[np.int64] | None = None
        self.final: NDArray[np.int64] | None = None
        self.released = False
        self.realtime = False
        self.stop_latency: float | None = None
        self.t_start = 0.0
        self.t_end = 0.0
        self._last_progress = -math.inf
        # Richer feedback (one Fast Sync Read of the Indirect Data block), collision stop.
        self.velocities: list[NDArray[np.float64]] = []
        self.currents: list[NDArray[np.float64]] = []
        self.feedback_samples: list[int] = []
        self.read_samples: list[int] = []
        self.collision_on = opts.collision
        self.collision_cycles = opts.collision_cycles
        self.collision_given = opts.collision_current
        self.threshold: NDArray[np.float64] | None = None
        self.predicted: NDArray[np.float64] | None = None
        self.over = np.zeros(len(bus.ids), dtype=np.int64)
        self.collision: dict[str, Any] | None = None
        self.recover = opts.recover
        self.recovered: list[dict[str, Any]] = []
        #: Warnings found when the stream was set up (added to the report's ``warnings``).
        self.warnings: list[dict[str, Any]] = []
        self.poses = source.trajectory.poses
        request = source.trajectory.request
        self.arm = None if request is None else request.arm
        #: Every feedback read (:mod:`robodcn.stream.trace`), for ``ExecutionReport.trace``.
        self.trace = TraceRecorder(self.n, [s.direction for s in bus.servos], self.rad_per_tick)

    def plan_limits(self, trajectory: Trajectory, opts: ExecutionOptions) -> None:
        """Predicted currents along the plan and the collision thresholds (A per joint)."""
        request = trajectory.request
        arm = None if request is None else request.arm
        self.predicted = predicted_currents(trajectory.joints, self.period, self.bus.servos, arm)
        limits = self.bus.current_limits or tuple(2.3 for _ in self.bus.ids)
        if opts.collision_current is not None:     # its length was checked by execute
            self.threshold = np.asarray(opts.collision_current, dtype=np.float64)
        else:
            self.threshold = thresholds(self.predicted, limits, arm, self.bus.position_d_gains)
        off = [self.joint_names[j] for j in np.nonzero(np.isinf(self.threshold))[0]]
        if off and opts.collision:
            message = (f"collision stop off for joint(s) {off}: their servos have a Position "
                       "D Gain, whose kick on each streamed goal step reads as current at the "
                       "limit; set collision_current_a per joint to use one")
            log.warning("%s", message)
            self.warnings.append({"code": "collision_stop_off", "message": message})

    def swap(self, source: Any) -> None:
        """Replace the sample source between two samples (any thread; online operations).

        The per-sample records grow first, then the source, then the loop's bound: a loop
        that still runs to the old bound reads the new source, which answers every index."""
        grow = len(source) - len(self.sent_index)
        if grow > 0:
            self.sent_index.extend([0] * grow)
            self.sent_at.extend([0.0] * grow)
            self.due_at.extend([0.0] * grow)
            self.work.extend([0.0] * grow)
        self.source = source
        self.n = len(source)

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
        log.debug("communication failure %d in a row: %s", self.consecutive_failures,
                  exc.message)
        if self.bus.lost:
            raise _Stop("comm_failure", exc.message)
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
        """The one place feedback is read and checked: present positions and, with the
        feedback map (:meth:`ServoBus.read_feedback`), velocities, currents and hardware
        errors from the same packet; tracking error against the plan; the collision stop."""
        try:
            if self.bus.feedback_mapped:
                fb = self.bus.read_feedback()
                present = fb.positions
            else:
                fb = None
                present = self.bus.read_positions()
        except CommError as exc:
            self._failed(exc)
            return
        self.consecutive_failures = 0
        self.feedback_reads += 1
        self.last_present = present
        error = tracking_error(present, self.previous_goal, self._plan_at_read(sample, goal))
        self.trace.record(sample, self.clock() - self.t_start, present, error,
                          None if fb is None else fb.currents)
        if fb is not None:
            self.velocities.append(np.abs(fb.velocities))
            self.currents.append(np.abs(fb.currents))
            self.feedback_samples.append(sample)
        if self.bus.last_alert_ids or (fb is not None and fb.hardware_errors.any()):
            self._alert(self.bus.last_alert_ids
                        or [i for i, e in zip(self.bus.ids, fb.hardware_errors, strict=True)
                            if e])
        if fb is not None and self.collision_on and self.threshold is not None:
            self._collision(sample, np.abs(fb.currents))
        self.last_error = error
        self.errors.append(error)
        self.read_samples.append(sample)
        if self.tick_limit is not None:
            over = np.abs(error) > self.tick_limit
            if over.any():
                j = int(np.argmax(over))
                value = float(abs(error[j]) * self.rad_per_tick[j])
                raise _Stop("tracking_error",
                            f"tracking error {value:.3f} rad "
                            f"({int(error[j])} ticks) at joint "
                            f"{self.joint_names[j]!r}, sample {sample}, limit "
                            f"{self.tracking_limit:.3f} rad",
                            {"quantity": "tracking_error", "joint": self.joint_names[j],
                             "sample": int(sample), "value": value, "ticks": int(error[j]),
                             "limit": float(self.tracking_limit), "unit": "rad"})

    def _plan_at_read(self, sample: int, goal: NDArray[np.int64]) -> NDArray[np.float64]:
        """The plan where it is at the end of this read (ticks, linear between samples):
        a read that lands late on a loaded host compares with where the plan is by then,
        so host lateness does not pass for servo lag (never earlier than ``goal``)."""
        s = (self.clock() - self.t_start) / self.period
        if s <= sample:
            return goal.astype(np.float64)
        source = self.source
        s = min(s, self.n - 1)
        lo = int(s)
        hi = min(lo + 1, self.n - 1)
        below = source.goal(lo)
        return below + (s - lo) * (source.goal(hi) - below).astype(np.float64)

    def _collision(self, sample: int, current: NDArray[np.float64]) -> None:
        """Stop when a joint's |current| stayed above its threshold for N reads in a row."""
        assert self.threshold is not None
        above = current > self.threshold
        self.over = np.where(above, self.over + 1, 0)
        hit = self.over >= self.collision_cycles
        if hit.any():
            j = int(np.argmax(hit))
            pose = self._pose_at(sample)
            self.collision = {
                "joint": self.joint_names[j], "servo_id": int(self.bus.ids[j]),
                "current_a": float(current[j]), "threshold_a": float(self.threshold[j]),
                "sample": int(sample), "time_s": sample * self.period,
                "pose": [float(pose[0]), float(pose[1]), float(pose[2])]}
            raise _Stop("collision",
                        f"collision at joint {self.joint_names[j]!r}: current "
                        f"{current[j]:.2f} A above {self.threshold[j]:.2f} A for "
                        f"{self.collision_cycles} cycles at sample {sample} "
                        f"(t = {sample * self.period:.3f} s, pose x {pose[0]:.3f} m, "
                        f"y {pose[1]:.3f} m, θ {math.degrees(pose[2]):.1f}°)")

    def _pose_at(self, sample: int) -> NDArray[np.float64]:
        """Planned tool pose of sample i: the trajectory's, or of the commanded joints when
        an online operation swapped the source (its samples may outrun the plan's)."""
        joint = getattr(self.source, "joint", None)
        if joint is not None and self.arm is not None:
            return fk(self.arm.links, np.asarray(joint(sample))[None, :])[0]
        return self.poses[min(sample, len(self.poses) - 1)]

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
            while i < self.n:
                n = self.n  # a swapped source may change the bound (swap)
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
                        self.skipped_late += j - i
                        i = j
                        due = t0 + i * period
                if watchdog_s and now - last_write > watchdog_s:
                    # The host stalled past the watchdog: the servos may have stopped.
                    try:
                        self._check_watchdog()
                    except CommError as exc:
                        self._failed(exc)
                source = self.source
                start = clock()
                try:
                    bus.write_encoded(source.encoded(i))
                except CommError as exc:
                    self.failed_writes += 1
                    self._failed(exc)
                    i += 1
                    continue
                last_write = start
                slot = self.sent
                self.sent_index[slot] = i
                self.sent_at[slot] = start
                self.due_at[slot] = due
                self.sent += 1
                goal = source.goal(i)
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
            self.stop_detail = stop.detail
            requested = getattr(self.stop, "requested_at", None)
            if stop.reason == "stopped" and requested is not None:
                self.stop_latency = time.perf_counter() - requested
            log.info("stream stopped (%s): %s", stop.reason, stop.message)
        self.t_end = clock()
        if self.progress is not None and self.sent:
            self._report_progress(self.sent_index[self.sent - 1], self.t_end)

    def _stop_message(self) -> str:
        reason = getattr(self.stop, "reason", None)
        return reason or "stop requested"

    def _report_progress(self, i: int, now: float) -> None:
        assert self.progress is not None
        present = error = None
        if self.last_present is not None:
            present = tuple(int(v) for v in self.last_present)
        if self.last_error is not None:
            error = tuple(float(v) for v in np.abs(self.last_error) * self.rad_per_tick)
        self.progress(Progress(i, self.n, now - self.t_start,
                               tuple(int(v) for v in self.source.goal(i)), present, error))

    # -- after the loop -------------------------------------------------------------------

    def finish(self, *, hold: bool, release: bool, settle: float) -> None:
        """Hold (when stopped), disarm the watchdog, read the final positions, release.

        Nothing here raises a BusError: with the link down each step is skipped."""
        bus = self.bus
        try:
            bus.disarm_watchdog()
        except BusError:
            pass  # a dead link cannot be disarmed; the hold below may still get through
        if self.recover and self.reason == "hardware_alert" and not bus.lost:
            self._recover()
        if hold and not bus.lost:
            try:
                goals = bus.read_positions()
                self.last_present = goals
            except BusError:
                goals = self.last_goal if self.last_goal is not None else self.last_present
            if goals is not None and not bus.lost:
                goals = np.clip(goals, bus.limits[:, 0], bus.limits[:, 1])
                try:
                    bus.write_encoded(bus.encode_goals(goals[None, :])[0])
                    self.hold_goals = goals
                except BusError:
                    pass
        if not bus.lost:
            self._final(settle, self.hold_goals if hold else self.last_goal)
        if release and not bus.lost:
            try:
                bus.torque(False)
                self.released = True
            except BusError:
                pass

    def _recover(self) -> None:
        """Overload recovery: reboot each servo reporting overload, hold it where it is
        (goal := present position), torque on again; report it. Never resumes the motion."""
        overloaded = [i for i, e in self.hardware.items() if e > 0 and e & OVERLOAD_BIT]
        if not overloaded:
            return
        bus = self.bus
        for servo_id in overloaded:
            entry: dict[str, Any] = {"servo_id": servo_id,
                                     "hardware_error": int(self.hardware[servo_id])}
            try:
                bus.reboot([servo_id])
                present = int.from_bytes(bus.read(servo_id, ADDR_PRESENT_POSITION, 4),
                                         "little", signed=True)
                bus.write(servo_id, ADDR_GOAL_POSITION, list(present.to_bytes(4, "little",
                                                                              signed=True)))
                bus.write(servo_id, ADDR_TORQUE_ENABLE, [1])
                entry.update(recovered=True, position=present)
            except BusError as exc:
                entry.update(recovered=False, error=exc.message)
            log.warning("overload recovery of servo %d: %s", servo_id, entry)
            self.recovered.append(entry)
        try:
            bus.configure()   # the rebooted servos came back at RAM defaults
        except BusError:
            pass

    def _final(self, settle: float, target: NDArray[np.int64] | None) -> None:
        """Read the final positions, for up to ``settle`` seconds, until the arm is on its
        target or at rest within one tick of it.

        One tick off is returned only at rest (the same reading for :data:`REST_S`): a
        motor still closing its last tick would otherwise be reported a tick short of
        where it comes to rest."""
        now = time.perf_counter()
        deadline = now + settle
        last, since = None, now
        while True:
            try:
                self.final = self.bus.read_positions()
            except BusError:
                return
            now = time.perf_counter()
            if last is None or not np.array_equal(self.final, last):
                last, since = self.final, now
            if target is None or now >= deadline:
                return
            error = np.abs(self.final - target).max()
            if error == 0 or (error <= 1 and now - since >= REST_S):
                return
            time.sleep(0.005)

    def _near_limits(self) -> tuple[dict[str, Any], ...]:
        """Where a limit came within 10 % (:func:`robodcn.stream.report.near_limits`)."""
        k = len(self.bus.ids)
        reads = np.array(self.read_samples, dtype=np.int64)
        series: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
        if self.tracking_limit is not None and self.errors:
            series["tracking_error"] = (np.abs(np.array(self.errors)) * self.rad_per_tick,
                                        np.full(k, self.tracking_limit))
        fb = np.array(self.feedback_samples, dtype=np.int64)
        if self.currents and self.bus.current_limits is not None:
            series["current"] = (np.array(self.currents), np.array(self.bus.current_limits))
        out = near_limits(tuple(self.joint_names), reads, reads * self.period,
                          {q: v for q, v in series.items() if q == "tracking_error"})
        if self.currents:
            currents = np.array(self.currents)
            more = {}
            if "current" in series:
                more["current"] = series["current"]
            if self.threshold is not None:
                more["collision_current"] = (currents, self.threshold)
            out += near_limits(tuple(self.joint_names), fb, fb * self.period, more)
        return out

    def report(self, approach: Approach | None,
               issued: tuple[dict[str, Any], ...]) -> ExecutionReport:
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
        skipped = self.skipped_late + self.failed_writes
        message = self.message

        def peak(rows: list[NDArray[np.float64]]) -> tuple[float, ...] | None:
            return None if not rows else tuple(float(v) for v in np.max(rows, axis=0))

        if self.reason == "completed" and skipped:
            message = (f"completed with {skipped} of {self.n} samples skipped "
                       f"({self.skipped_late} late, {self.failed_writes} failed writes)")
        return ExecutionReport(
            stop_reason=self.reason, message=message, stop_detail=self.stop_detail,
            samples_total=self.n,
            samples_sent=sent, skipped=skipped, skipped_late=self.skipped_late,
            rate_hz=self.rate_hz,
            achieved_rate_hz=(sent - 1) / span if span > 0 else 0.0,
            duration_s=self.t_end - self.t_start if sent else 0.0,
            jitter_p50_s=_percentile(jitter, 50), jitter_p99_s=_percentile(jitter, 99),
            jitter_max_s=float(jitter.max()) if jitter.size else 0.0,
            lateness_max_s=float(np.max(at - due)) if sent else 0.0,
            work_p50_s=_percentile(work, 50), work_p99_s=_percentile(work, 99),
            overruns=self.overruns, retries=self.bus.retries_used - self.retries_start,
            comm_failures=self.comm_failures, feedback_reads=self.feedback_reads,
            health_polls=self.health_polls, joint_names=tuple(self.joint_names),
            servo_ids=tuple(self.bus.ids),
            tracking_error_max_rad=tuple(float(v) for v in max_ticks * self.rad_per_tick),
            tracking_error_rms_rad=tuple(float(v) for v in rms_ticks * self.rad_per_tick),
            tracking_error_max_ticks=tuple(round(float(v)) for v in max_ticks),
            tracking_error_rms_ticks=tuple(float(v) for v in rms_ticks),
            final_positions=None if self.final is None else tuple(int(v) for v in self.final),
            final_error_ticks=final_error,
            hold_goals=None if self.hold_goals is None else tuple(int(v)
                                                                  for v in self.hold_goals),
            hardware_errors=dict(self.hardware), approach=approach, released=self.released,
            fast_read=bool(self.bus.fast_read), realtime=self.realtime,
            stop_latency_s=self.stop_latency, warnings=issued,
            velocity_peak_rad_s=peak(self.velocities),
            current_peak_a=peak(self.currents),
            current_limit_a=(None if self.bus.current_limits is None
                             else tuple(float(v) for v in self.bus.current_limits)),
            predicted_current_peak_a=(None if self.predicted is None else tuple(
                float(v) for v in np.abs(self.predicted).max(axis=0))),
            collision_threshold_a=(None if self.threshold is None else tuple(
                float(v) if math.isfinite(v) else None for v in self.threshold)),
            collision=self.collision, recovered=tuple(self.recovered),
            compensation=self.source.compensated, tracking_limit_rad=self.tracking_limit,
            near_limits=self._near_limits(), trace=self._trace())

    def _trace(self) -> ExecutionTrace:
        """``ExecutionReport.trace``: the recorded reads with the limits they face."""
        limits = None if self.bus.current_limits is None else tuple(
            float(v) for v in self.bus.current_limits)
        threshold = None if self.threshold is None else tuple(
            float(v) if math.isfinite(v) else None for v in self.threshold)
        return self.trace.trace(self.joint_names, tracking_limit_rad=self.tracking_limit,
                                current_limit_a=limits, collision_threshold_a=threshold,
                                predicted_current_a=self.predicted)
