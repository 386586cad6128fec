"""The :class:`~robodcn.stream.report.ExecutionReport` of a finished stream, from its loop
records, its feedback and its end (one function: every count in one place)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn.stream.feedback import Feedback
from robodcn.stream.finish import Finished
from robodcn.stream.in_position import PositionMiss, position_misses, tolerance_ticks
from robodcn.stream.loop import Stream
from robodcn.stream.report import Approach, ExecutionReport, near_limits
from robodcn.stream.trace import ExecutionTrace


def _percentile(values: NDArray[np.float64], q: float) -> float:
    return float(np.percentile(values, q)) if values.size else 0.0


def _floats(values: Any) -> tuple[float, ...] | None:
    return None if values is None else tuple(float(v) for v in values)


def _thresholds(fb: Feedback) -> tuple[float | None, ...] | None:
    return None if fb.threshold is None else tuple(
        float(v) if math.isfinite(v) else None for v in fb.threshold)


def _near_limits(stream: Stream, fb: Feedback) -> tuple[dict[str, Any], ...]:
    """Where a limit came within 10 % (:func:`robodcn.stream.report.near_limits`)."""
    k = len(stream.bus.ids)
    names = fb.joint_names
    reads = np.array(fb.read_samples, dtype=np.int64)
    series: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
    if fb.tracking_limit is not None and fb.errors:
        series["tracking_error"] = (np.abs(np.array(fb.errors)) * fb.rad_per_tick,
                                    np.full(k, fb.tracking_limit))
    out = near_limits(names, reads, reads * stream.period, series)
    if fb.currents:
        samples = np.array(fb.feedback_samples, dtype=np.int64)
        currents = np.array(fb.currents)
        more = {}
        if stream.bus.current_limits is not None:
            more["current"] = (currents, np.array(stream.bus.current_limits))
        if fb.threshold is not None:
            more["collision_current"] = (currents, fb.threshold)
        out += near_limits(names, samples, samples * stream.period, more)
    return out


def _trace(fb: Feedback, current_limits: tuple[float, ...] | None) -> ExecutionTrace:
    """``ExecutionReport.trace``: the recorded reads with the limits they face."""
    return fb.trace.trace(fb.joint_names, tracking_limit_rad=fb.tracking_limit,
                          current_limit_a=_floats(current_limits),
                          collision_threshold_a=_thresholds(fb),
                          predicted_current_a=fb.predicted)


def _in_position(stream: Stream, fb: Feedback, done: Finished
                 ) -> tuple[tuple[int, ...] | None, tuple[int, ...] | None,
                            tuple[PositionMiss, ...]]:
    """(goal ticks, tolerance ticks, misses) of a completed stream: the final read against
    the source's last goal (the plan's last sample, :mod:`robodcn.stream.in_position`);
    (None, None, ()) for a stream that stopped or whose final read failed."""
    if stream.ending.reason != "completed" or done.final is None or stream.n < 1:
        return None, None, ()
    bus = stream.bus
    goal = np.asarray(stream.source.goal(stream.n - 1), dtype=np.int64)
    tolerance = tolerance_ticks(bus.servos, fb.arm)
    misses = position_misses(done.final, goal, tolerance, bus.servos, fb.joint_names)
    return (tuple(int(v) for v in goal), tuple(int(v) for v in tolerance), misses)


def build_report(stream: Stream, fb: Feedback, done: Finished, approach: Approach | None,
                 issued: tuple[dict[str, Any], ...]) -> ExecutionReport:
    """The report of a finished stream (``issued``: the warnings of its set-up)."""
    bus, rec = stream.bus, stream.records
    sent = rec.count
    at = np.array(rec.at[:sent])
    due = np.array(rec.due[:sent])
    jitter = np.abs(np.diff(at) - np.diff(due)) if sent > 1 else np.zeros(0)
    work = np.array(rec.work[:sent])
    span = at[-1] - at[0] if sent > 1 else 0.0
    k = len(bus.ids)
    if fb.errors:
        err = np.abs(np.array(fb.errors, dtype=np.float64))
        max_ticks = err.max(axis=0)
        rms_ticks = np.sqrt(np.mean(err ** 2, axis=0))
    else:
        max_ticks = rms_ticks = np.zeros(k)
    final_error = None
    if done.final is not None and stream.last_goal is not None:
        target = done.hold_goals if done.hold_goals is not None else stream.last_goal
        final_error = tuple(int(v) for v in done.final - target)
    skipped = stream.skipped_late + stream.failed_writes
    ending = stream.ending
    message = ending.message
    if ending.reason == "completed" and skipped:
        message = (f"completed with {skipped} of {stream.n} samples skipped "
                   f"({stream.skipped_late} late, {stream.failed_writes} failed writes)")
    if done.hold_failed is not None:
        message += f"; the hold was not written ({done.hold_failed})"
    goal, tolerance, misses = _in_position(stream, fb, done)

    def peak(rows: list[NDArray[np.float64]]) -> tuple[float, ...] | None:
        return None if not rows else tuple(float(v) for v in np.max(rows, axis=0))

    def ints(values: Any) -> tuple[int, ...] | None:
        return None if values is None else tuple(int(v) for v in values)

    return ExecutionReport(
        stop_reason=ending.reason, message=message, stop_detail=ending.detail,
        samples_total=stream.n, samples_sent=sent, skipped=skipped,
        skipped_late=stream.skipped_late, rate_hz=stream.rate_hz,
        achieved_rate_hz=(sent - 1) / span if span > 0 else 0.0,
        duration_s=stream.t_end - stream.t_start if sent else 0.0,
        jitter_p50_s=_percentile(jitter, 50), jitter_p99_s=_percentile(jitter, 99),
        jitter_max_s=float(jitter.max()) if jitter.size else 0.0,
        lateness_max_s=float(np.max(at - due)) if sent else 0.0,
        work_p50_s=_percentile(work, 50), work_p99_s=_percentile(work, 99),
        overruns=stream.overruns, retries=bus.retries_used - stream.retries_start,
        comm_failures=stream.failures.total, feedback_reads=fb.reads,
        health_polls=fb.health_polls, joint_names=fb.joint_names,
        servo_ids=tuple(bus.ids),
        tracking_error_max_rad=tuple(float(v) for v in max_ticks * fb.rad_per_tick),
        tracking_error_rms_rad=tuple(float(v) for v in rms_ticks * fb.rad_per_tick),
        tracking_error_max_ticks=tuple(round(float(v)) for v in max_ticks),
        tracking_error_rms_ticks=tuple(float(v) for v in rms_ticks),
        final_positions=ints(done.final), final_error_ticks=final_error,
        hold_goals=ints(done.hold_goals), hold_failed=done.hold_failed,
        hardware_errors=dict(fb.hardware), approach=approach, released=done.released,
        fast_read=bool(bus.fast_read), realtime=stream.realtime,
        stop_latency_s=stream.stop_latency, warnings=issued,
        velocity_peak_rad_s=peak(fb.velocities), current_peak_a=peak(fb.currents),
        current_limit_a=_floats(bus.current_limits),
        predicted_current_peak_a=(None if fb.predicted is None else tuple(
            float(v) for v in np.abs(fb.predicted).max(axis=0))),
        collision_threshold_a=_thresholds(fb),
        collision=fb.collision, recovered=tuple(done.recovered),
        compensation=stream.source.compensated, tracking_limit_rad=fb.tracking_limit,
        near_limits=_near_limits(stream, fb), goal_ticks=goal, in_position_ticks=tolerance,
        out_of_position=misses, trace=_trace(fb, bus.current_limits))


__all__ = ["build_report"]
