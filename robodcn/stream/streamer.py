"""Execute a :class:`~robodcn.planner.Trajectory` on a :class:`~robodcn.bus.ServoBus` in real time.

``execute(trajectory, bus, options)`` (:class:`~robodcn.stream.options.ExecutionOptions`,
or the same options as keywords) checks before the first write, streams one Sync Write of
goal ticks per sample on an absolute schedule, reads back present positions every k samples,
polls servo health, stops and holds on the first fault, and returns an
:class:`ExecutionReport`. The steps, one module each:

Before any write (:mod:`robodcn.stream.preflight`)
    the servos are the trajectory's, its ticks inside their limits, no hardware error, the
    arm within ``start_tolerance`` of the first sample (or, with ``approach=True``, the
    request planned again from the present joints: ``ExecutionReport.approach``). A caller
    that has just read Present Position passes it as ``present_ticks`` (bus order): it is
    not read again. A rate above what the bus carries is a
    :class:`~robodcn.stream.rate.RateWarning`, kept in the report.

Schedule (:mod:`robodcn.stream.loop`)
    sample i is due at t0 + i/rate on the execution's clock (:mod:`robodcn.stream.clock`:
    real time by default, virtual time in tests); late samples are skipped (or all sent
    with ``skip_late=False``); the thread's timer slack is 1 µs while streaming.

Feedback and health (:mod:`robodcn.stream.feedback`)
    positions every ``feedback_every``-th sample and on the last, tracking error against
    the plan, currents and the collision stop, health polls every ``health_interval``.

Stops (``stop_reason``)
    "stopped" (a :class:`StopSignal`/``threading.Event`` set from any thread; acted on within
    one period), "comm_failure" (``max_comm_failures`` consecutive failed transactions, each
    after the bus's own retries; at once when the serial device is lost), "hardware_alert"
    (Alert bit, non-zero Hardware Error Status or an expired Bus Watchdog),
    "tracking_error" (|error| above ``tracking_limit`` rad on any joint), "collision", else
    "completed". ``ExecutionReport.outcome`` sums it up: "done" (every sample sent and
    the arm at rest within its in-position tolerance of the goal,
    :mod:`robodcn.stream.in_position`), "degraded" (completed with samples skipped or out
    of position), "stopped", "fault", "collision". On every
    stop the arm holds (:mod:`robodcn.stream.finish`).

Bus Watchdog
    armed for the execution (``watchdog_ms``; default max(250 ms, 10 periods), at most
    2.54 s) so servos stop by themselves if this process dies or stalls; disarmed at the end.
    In position mode a servo already holds its last goal when the stream stops; the
    watchdog additionally freezes any profile in progress, so a generous timeout costs
    little and does not trip on a host that is merely slow for a moment.

Real-time priority
    with ``realtime=True`` the calling thread runs under SCHED_FIFO (priority
    ``REALTIME_PRIORITY``) for the execution and gets its old policy back afterwards; where
    that is not permitted a RuntimeWarning says so and the stream runs at normal priority.

Threading
    ``execute`` holds the bus (:meth:`ServoBus.claim`) for its whole duration: the calling
    thread owns the port; other threads get BusyError from the bus and stop through the
    stop signal.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

from numpy.typing import ArrayLike

from robodcn.bus import ServoBus
from robodcn.planner import Trajectory
from robodcn.stream.feedback import CommFailures, Feedback
from robodcn.stream.finish import CATCH_UP_SETTLE_S, IN_POSITION_SETTLE_S, finish
from robodcn.stream.loop import PROGRESS_INTERVAL_S, Stream
from robodcn.stream.options import ExecutionOptions
from robodcn.stream.preflight import arm_watchdog, check_arguments, preflight
from robodcn.stream.realtime import SPIN_REALTIME_S, realtime_priority, timer_slack
from robodcn.stream.report import ExecutionReport
from robodcn.stream.source import PlannedSamples
from robodcn.stream.summary import build_report

log = logging.getLogger("robodcn.stream")

#: Seconds before ``start_at`` the Bus Watchdog is armed and the loop takes over (its wait
#: for the first sample stays well inside the watchdog's ≥ 250 ms).
START_ARM_LEAD_S = 0.1


def execute(trajectory: Trajectory, bus: ServoBus, options: ExecutionOptions | None = None,
            *, present_ticks: ArrayLike | None = None, **kwargs: Any) -> ExecutionReport:
    """Stream ``trajectory`` to the servos on ``bus`` (module docstring for the rules).

    Parameters
    ----------
    trajectory : planned samples; its ``servo_ids`` must equal ``bus.ids`` (same order).
    bus : an open :class:`ServoBus`.
    options : :class:`ExecutionOptions` (default: all defaults).
    present_ticks : Present Position (k,) ticks in bus order that the caller has just read
        (and planned from); None reads them. The start checks work from them.
    kwargs : fields of :class:`ExecutionOptions` or of its hooks (``stop``, ``progress``,
        ``attach``), over ``options`` (an unknown name or a bad value is an InputError).

    Returns
    -------
    ExecutionReport; stops are reported, not raised (a lost serial device too: outcome
    "fault"). Refusals before the first write raise ServoMismatchError, TickLimitError,
    HardwareAlertError, StartMismatchError, CommError or InputError.
    """
    opts = ExecutionOptions.build(options, kwargs)
    present = check_arguments(trajectory, bus, opts, present_ticks)
    with bus.claim():
        prepared = preflight(trajectory, bus, opts, present)
        trajectory = prepared.trajectory
        source = PlannedSamples(trajectory, bus, compensation=opts.compensation,
                                present=prepared.present)
        failures = CommFailures(bus, opts.max_comm_failures)
        feedback = Feedback(bus, opts, trajectory, failures, opts.clock, len(source))
        issued = prepared.warnings + tuple(feedback.plan_limits(trajectory, opts,
                                                                source.period))
        stream = Stream(source, bus, opts, feedback, failures)
        if opts.start_at is not None:
            # preflight is done: wait for start_at here, then arm the watchdog, so the
            # loop's wait for its first sample stays short of the watchdog
            ahead = opts.start_at - time.time() - START_ARM_LEAD_S
            if ahead > 0:
                (opts.stop or threading.Event()).wait(ahead)
        arm_watchdog(bus, opts, source.period)
        log.info("streaming %d samples at %g Hz to servos %s", len(source),
                 trajectory.rate_hz, list(bus.ids))

        def end(*, hold: bool, settle: float) -> Any:
            return finish(bus, opts.clock, hold=hold, release=opts.release, settle=settle,
                          last_goal=stream.last_goal, last_present=feedback.last_present,
                          hardware=(feedback.hardware if opts.recover
                                    and stream.ending.reason == "hardware_alert" else None))

        try:
            with timer_slack(), realtime_priority(opts.realtime) as stream.realtime:
                if stream.realtime:
                    stream.spin = SPIN_REALTIME_S
                if opts.attach is not None:
                    opts.attach(stream)
                stream.run()
        except BaseException:
            end(hold=True, settle=0.0)
            raise
        completed = stream.ending.reason == "completed"
        settle = max(opts.settle, CATCH_UP_SETTLE_S) if stream.caught_up else opts.settle
        if completed:   # where the arm comes to rest is what the in-position check reads
            settle = max(settle, IN_POSITION_SETTLE_S)
        done = end(hold=not completed, settle=settle)
        report = build_report(stream, feedback, done, prepared.approach, issued)
        # the stream's own view: a smooth stop runs its brake to the end ("completed"), so
        # the caller that asked for it logs the move's headline (Execution, a follow session)
        log.debug("stream ended: %s", report.headline)
        return report


__all__ = ["PROGRESS_INTERVAL_S", "execute"]
