"""What an execution reports: live :class:`Progress` and the final :class:`ExecutionReport`.

Both use one definition of tracking error (:func:`tracking_error`), and the report's
``outcome`` and ``headline`` are derived from its counts, so a report never says more than
happened.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn.stream.in_position import PositionMiss, misses_text
from robodcn.stream.trace import ExecutionTrace

STOP_REASONS = ("completed", "stopped", "comm_failure", "hardware_alert", "tracking_error",
                "collision")
#: ``ExecutionReport.outcome``: every sample sent and the arm in position / completed with
#: samples left out or out of position / stopped on request / stopped by a bus, servo or
#: tracking fault / stopped by the collision stop.
OUTCOMES = ("done", "degraded", "stopped", "fault", "collision")


@dataclass(frozen=True)
class Approach:
    """A joint-space approach at the start of a trajectory: ``samples`` periods long (sample 0
    to sample ``samples``, where the planned path begins), ``duration_s`` seconds."""

    samples: int
    duration_s: float

    def to_dict(self) -> dict[str, Any]:
        return {"samples": self.samples, "duration_s": self.duration_s}


def approach_of(trajectory: Any) -> Approach | None:
    """The joint-space approach the planner put at the start of ``trajectory``, or None.

    The planner records it (:attr:`Trajectory.approach_samples`, the sample periods of the
    approach from the request's start_joints, whatever law times it: the uniform profiles'
    quintic or the time-optimal law of ``profile="optimal"``); a plan without one starts
    on the path itself.
    """
    n = int(getattr(trajectory, "approach_samples", 0) or 0)
    if n <= 0:
        return None
    return Approach(samples=n, duration_s=float(n) / trajectory.rate_hz)


@dataclass(frozen=True)
class Ending:
    """Why a stream ended: ``reason`` (:data:`STOP_REASONS`), a message, and what stopped
    it as data (SI units) for the surfaces to word in their units, or None."""

    reason: str = "completed"
    message: str = "all samples sent"
    detail: dict[str, Any] | None = None


class StreamStop(Exception):
    """Raised inside the streaming loop (its feedback, health and failure checks) to end it
    with an :class:`Ending`; the loop catches it, nothing outside sees it."""

    def __init__(self, reason: str, message: str, detail: dict[str, Any] | None = None) -> None:
        super().__init__(message)
        self.ending = Ending(reason, message, detail)


def tracking_error(present: NDArray[np.int64], previous_goal: NDArray[np.int64] | None,
                   goal: NDArray[np.int64]) -> NDArray[np.int64]:
    """Tracking error (ticks, signed, per joint): how far ``present`` lies outside the last
    commanded step [previous goal, goal].

    e = p − clip(p, min(g₋, g), max(g₋, g)): a servo that follows within one sample
    (instantly, or a period behind) has error 0; one that lags or overshoots by more has
    the excess. Without a previous goal the step is the goal alone (e = p − g).
    """
    previous = goal if previous_goal is None else previous_goal
    return present - np.clip(present, np.minimum(previous, goal), np.maximum(previous, goal))


@dataclass(frozen=True)
class Progress:
    """What a progress callback receives: sample index (of n), seconds since the first write,
    last goals sent and last present positions read (ticks, bus order; None before any),
    and the tracking error of that read (rad per joint, :func:`tracking_error`; None before
    any read) — the same definition the final report uses; with the feedback map, that
    read's shaft velocities (rad/s) and currents (A), signed as the servos report them
    (:class:`robodcn.bus.feedback.Feedback`; None before any or without the map)."""

    sample: int
    samples_total: int
    elapsed_s: float
    goals: tuple[int, ...]
    present: tuple[int, ...] | None
    tracking_error_rad: tuple[float, ...] | None = None
    velocities: tuple[float, ...] | None = None
    currents: tuple[float, ...] | None = None


#: A limit counts as approached at this share of it (within 10 %).
NEAR_SHARE = 0.9


def near_limits(joint_names: tuple[str, ...], samples: NDArray[np.int64],
                times: NDArray[np.float64],
                series: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]],
                share: float = NEAR_SHARE) -> tuple[dict[str, Any], ...]:
    """Where each joint's quantity first came within 10 % of its limit, and its peak.

    ``series`` maps a quantity ("tracking_error" rad, "current" A, "collision_current" A)
    to (|values| (m, k) per feedback read, limits (k,)); ``samples`` (m,) are the reads'
    sample indices, ``times`` their planned times. One entry per joint and quantity with
    value ≥ share·limit: joint, quantity, sample, time_s, value (there), peak, limit.
    """
    out = []
    for quantity, (values, limits) in series.items():
        if not len(values):
            continue
        near = values >= share * np.asarray(limits)[None, :]
        for j in np.nonzero(near.any(axis=0))[0]:
            first = int(np.argmax(near[:, j]))
            out.append({"joint": joint_names[j], "quantity": quantity,
                        "sample": int(samples[first]), "time_s": float(times[first]),
                        "value": float(values[first, j]), "peak": float(values[:, j].max()),
                        "limit": float(limits[j])})
    return tuple(out)


def outcome_of(stop_reason: str, skipped: int, out_of_position: bool = False,
               hold_failed: bool = False) -> str:
    """``"done"``, ``"degraded"``, ``"stopped"`` or ``"fault"`` (see :data:`OUTCOMES`):
    a completed stream is ``done`` only with no sample skipped and the arm in position; a
    stop whose hold was not written (``hold_failed``) is a ``fault``, not ``stopped``."""
    if stop_reason == "completed":
        return "done" if skipped == 0 and not out_of_position else "degraded"
    if stop_reason in ("stopped", "collision") and not hold_failed:
        return stop_reason
    return "fault"


@dataclass
class ExecutionReport:
    """The outcome of :func:`execute`; ``to_dict()`` is JSON-ready.

    ``outcome`` (:data:`OUTCOMES`) and ``headline`` say what happened in one word and one
    line; ``completed`` is true only when every sample was sent and the arm came to rest in
    position (``out_of_position`` lists the joints that did not,
    :mod:`robodcn.stream.in_position`; ``goal_ticks`` is the goal they are measured from,
    the plan's last sample, and ``in_position_ticks`` each joint's tolerance). ``skipped``
    counts the samples not sent before the loop ended: left out because their slot had passed
    (``skipped_late``) or because their write failed. ``samples_skipped`` is the same
    count under its older name. ``approach`` is the joint-space approach the streamer
    inserted (None when it streamed the trajectory as given). ``warnings`` are the
    warnings issued before streaming (``{"code", "message"}``, e.g. a rate above what the
    bus carries).

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
    skipped: int
    skipped_late: int
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
    approach: Approach | None = None
    released: bool = False
    fast_read: bool = False
    realtime: bool = False
    stop_latency_s: float | None = None
    warnings: tuple[dict[str, str], ...] = ()
    #: Per joint over the feedback reads (None without the feedback map): peak |velocity|
    #: (rad/s), peak |current| (A) and the servo's current limit (A).
    velocity_peak_rad_s: tuple[float, ...] | None = None
    current_peak_a: tuple[float, ...] | None = None
    current_limit_a: tuple[float, ...] | None = None
    #: Per joint: the plan's predicted peak |current| and the collision thresholds (A;
    #: None for a joint whose stop is off, :mod:`robodcn.stream.collision`).
    predicted_current_peak_a: tuple[float, ...] | None = None
    collision_threshold_a: tuple[float | None, ...] | None = None
    #: Where a collision stopped the move: joint, servo_id, current_a, threshold_a,
    #: sample, time_s, pose [x, y, θ] (m, m, rad).
    collision: dict[str, Any] | None = None
    #: Servos rebooted by the overload recovery (``recover=True``).
    recovered: tuple[dict[str, Any], ...] = ()
    #: True when the goals sent were the tracking-compensated ones.
    compensation: bool = False
    #: The tracking-error stop limit, rad (None: no stop).
    tracking_limit_rad: float | None = None
    #: Where a limit came within 10 % (:func:`near_limits`), for the dry run's plot.
    near_limits: tuple[dict[str, Any], ...] = ()
    #: Every feedback read (time, ticks, tracking error, current) with the limits, for the
    #: plot (:class:`~robodcn.stream.trace.ExecutionTrace`); not in ``to_dict()`` unless
    #: asked for (it grows with the motion).
    #: What stopped the stream, as data in SI units (e.g. a tracking-error stop: quantity,
    #: joint, sample, value, ticks, limit, unit), or None.
    stop_detail: dict[str, Any] | None = None
    #: The goal a completed move is measured from (the plan's last sample, ticks), each
    #: joint's in-position tolerance (ticks) and the joints that rested beyond it
    #: (:class:`~robodcn.stream.in_position.PositionMiss`); None / () when not measured.
    goal_ticks: tuple[int, ...] | None = None
    in_position_ticks: tuple[int, ...] | None = None
    out_of_position: tuple[PositionMiss, ...] = ()
    #: Why the hold of a stopped stream was not written (:mod:`robodcn.stream.finish`: the
    #: device lost, the write failed or not confirmed by a read-back), or None: such a stop
    #: is a ``fault`` (only the servos' Bus Watchdog stops them).
    hold_failed: str | None = None
    #: A dry run on firmware_sim's physics: the payload (kg, at the tool point) the
    #: simulated arm carried, and the one the plan declared (``payload_kg``, its torque
    #: limits and compensation); None on a real arm (robodcn.simulated.SimulatedArm.carry).
    sim_payload_kg: float | None = None
    planned_payload_kg: float | None = None
    trace: ExecutionTrace | None = field(default=None, repr=False, compare=False)

    @property
    def outcome(self) -> str:
        return outcome_of(self.stop_reason, self.skipped, bool(self.out_of_position),
                          self.hold_failed is not None)

    @property
    def completed(self) -> bool:
        """True only when the run ended normally with every sample sent, in position."""
        return self.outcome == "done"

    @property
    def samples_skipped(self) -> int:
        return self.skipped

    @property
    def headline(self) -> str:
        """One line from the counts: "completed: all 2001 samples sent", "completed with 105
        of 2001 samples skipped", "stopped after 812 of 2001 samples: stop requested"."""
        total = self.samples_total
        if self.outcome == "done":
            return f"completed: all {total} samples sent"
        if self.outcome == "degraded":
            parts = []
            if self.skipped:
                parts.append(f"with {self.skipped} of {total} samples skipped")
            if self.out_of_position:
                parts.append("out of position: " + misses_text(self.out_of_position))
            return "completed " + "; ".join(parts)
        return f"{self.outcome} after {self.samples_sent} of {total} samples: {self.message}"

    def to_dict(self, *, trace: bool = False) -> dict[str, Any]:
        """JSON-ready; ``trace=True`` adds ``trace`` (:meth:`ExecutionTrace.to_dict`)."""
        data = dataclasses.asdict(dataclasses.replace(self, trace=None))
        del data["trace"]
        if trace:
            data["trace"] = None if self.trace is None else self.trace.to_dict()
        data["hardware_errors"] = {str(k): v for k, v in self.hardware_errors.items()}
        data["approach"] = None if self.approach is None else self.approach.to_dict()
        data["warnings"] = [dict(w) for w in self.warnings]
        data["recovered"] = [dict(r) for r in self.recovered]
        data["near_limits"] = [dict(n) for n in self.near_limits]
        data["out_of_position"] = [m.to_dict() for m in self.out_of_position]
        for key, value in data.items():
            if isinstance(value, tuple):
                data[key] = list(value)
        data.update(outcome=self.outcome, completed=self.completed, headline=self.headline,
                    samples_skipped=self.skipped)
        return data


__all__ = ["NEAR_SHARE", "OUTCOMES", "STOP_REASONS", "Approach", "Ending", "ExecutionReport",
           "Progress", "StreamStop", "approach_of", "near_limits", "outcome_of",
           "tracking_error"]
