"""What the streaming loop reads back: present positions, tracking, collisions, health.

Present positions are read after the write on every ``feedback_every``-th sample and on the
last one (0: only at the end), in one place (:meth:`Feedback.read`). Tracking error
(:func:`robodcn.stream.report.tracking_error`, the same for Progress and the report) of
joint j is how far the present position lies outside the last planned step, [previous
planned goal, the plan at the end of the read] (the plan, not the compensated goals actually
sent: :mod:`robodcn.stream.compensation`). With the feedback map
(:meth:`ServoBus.read_feedback`) the same packet brings velocities, currents and hardware
errors: peaks per joint in the report and the collision stop ("collision": |current| above
its threshold at that sample — from the current the plan needs there, gravity included — for
``collision_cycles`` reads, reported with joint, current, sample, time and pose;
:mod:`robodcn.stream.collision`). A collision or tracking stop backs off before it ends the
loop (:meth:`Feedback.back_off`: the goals become where the arm is, with the gravity lead
when compensating), so the servos stop pushing against what holds them. Every read is
recorded in preallocated arrays (:mod:`robodcn.stream.trace`). Every ``health_interval``
seconds the loop polls Hardware Error Status (70) and Bus Watchdog (98) in turn
(:meth:`Feedback.health`): Fast Sync Read hides a servo's Alert bit in the SDK, so the bus
decodes the ERR bytes itself. A stop is a :class:`~robodcn.stream.report.StreamStop`
carrying its reason and data.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from robodcn.bus import Feedback as BusFeedback
from robodcn.bus import ServoBus, describe_hardware_error
from robodcn.errors import BusError, CommError
from robodcn.planner import Trajectory
from robodcn.planner.path import user_pose
from robodcn.servo_units import radians_per_tick
from robodcn.stream.clock import Clock
from robodcn.stream.collision import (
    SLEW_QUIET_S,
    ChainThresholds,
    predicted_currents,
    threshold_profile,
)
from robodcn.stream.compensation import holding_goals
from robodcn.stream.options import ExecutionOptions
from robodcn.stream.report import StreamStop, tracking_error
from robodcn.stream.trace import TraceRecorder

log = logging.getLogger("robodcn.stream")


def _pose_text(pose: Sequence[float]) -> str:
    """A tool pose for a message: x, y, θ (planar) or x, y, z, pitch (a yawed arm)."""
    if len(pose) == 4:
        return (f"x {pose[0]:.3f} m, y {pose[1]:.3f} m, z {pose[2]:.3f} m, "
                f"pitch {math.degrees(pose[3]):.1f}°")
    return f"x {pose[0]:.3f} m, y {pose[1]:.3f} m, θ {math.degrees(pose[2]):.1f}°"


def _alert_seen(ids: Sequence[int], alert_ids: Sequence[int], fb: Any,
                sample: int) -> tuple[list[int], str]:
    """The servos a feedback read flagged and how: the Alert bit of their status packets
    and the Hardware Error Status bytes of the feedback map, with that read's positions."""
    parts = []
    if alert_ids:
        parts.append(f"Alert bit in the status of servo(s) {list(alert_ids)}")
    flagged = list(alert_ids)
    if fb is not None and fb.hardware_errors.any():
        errors = {int(i): int(e) for i, e in zip(ids, fb.hardware_errors, strict=True) if e}
        parts.append(f"feedback Hardware Error Status {errors}")
        flagged = flagged or list(errors)
    if fb is not None:
        parts.append(f"present {[int(v) for v in fb.positions]}")
    return flagged, f"feedback read at sample {sample}: " + ", ".join(parts)


class Timeline(Protocol):
    """What a read needs of the loop: where the plan is now (its clock and source)."""

    source: Any
    n: int
    period: float
    t_start: float


class CommFailures:
    """Failed transactions: counted, and a stop after ``limit`` in a row (at once when the
    serial device is lost)."""

    def __init__(self, bus: ServoBus, limit: int) -> None:
        self.bus = bus
        self.limit = limit
        self.total = 0
        self.in_a_row = 0

    def ok(self) -> None:
        self.in_a_row = 0

    def failed(self, exc: BusError) -> None:
        self.total += 1
        self.in_a_row += 1
        log.debug("communication failure %d in a row: %s", self.in_a_row, exc.message)
        if self.bus.lost:
            raise StreamStop("comm_failure", exc.message)
        if self.in_a_row >= self.limit:
            raise StreamStop("comm_failure", f"{self.in_a_row} consecutive communication "
                             f"failures; last: {exc.message}")


class Feedback:
    """The reads of one execution and what they found (peaks, errors, the collision)."""

    def __init__(self, bus: ServoBus, opts: ExecutionOptions, trajectory: Trajectory,
                 failures: CommFailures, clock: Clock, samples: int) -> None:
        self.bus = bus
        self.failures = failures
        self.clock = clock
        self.joint_names = tuple(trajectory.joint_names)
        self.rad_per_tick = radians_per_tick(bus.servos)
        self.tracking_limit = opts.tracking_limit
        self.tick_limit = (None if self.tracking_limit is None
                           else self.tracking_limit / self.rad_per_tick)
        self.collision_on = opts.collision
        self.collision_cycles = opts.collision_cycles
        request = trajectory.request
        self.arm = None if request is None else request.arm
        self.payload_kg = None if request is None else getattr(request, "payload_kg", None)
        self.compensation = opts.compensation
        #: per-sample thresholds (n, k) along the plan (:func:`threshold_profile`)
        self.threshold_at: NDArray[np.float64] | None = None
        #: the thresholds along an online chain's tails (None with configured thresholds)
        self.chain: ChainThresholds | None = None
        self.poses = trajectory.poses
        self.reads = 0
        self.health_polls = 0
        self.last_present: NDArray[np.int64] | None = None
        #: the last feedback read's (signed) shaft velocities and currents, with the map
        self.last_feedback: BusFeedback | None = None
        self.last_error: NDArray[np.float64] | None = None
        self.hardware: dict[int, int] = {}
        self.errors: list[NDArray[np.float64]] = []
        self.read_samples: list[int] = []
        # richer feedback (one Fast Sync Read of the Indirect Data block), collision stop
        self.velocities: list[NDArray[np.float64]] = []
        self.currents: list[NDArray[np.float64]] = []
        self.feedback_samples: list[int] = []
        self.threshold: NDArray[np.float64] | None = None
        self.predicted: NDArray[np.float64] | None = None
        self.over = np.zeros(len(bus.ids), dtype=np.int64)
        #: the collision count stays 0 up to this sample (a goal the loop slewed: SLEW_QUIET_S)
        self.quiet_until = -1
        self.quiet_samples = 0
        self.collision: dict[str, Any] | None = None
        #: every feedback read (:mod:`robodcn.stream.trace`), for ``ExecutionReport.trace``
        self.trace = TraceRecorder(samples, [s.direction for s in bus.servos],
                                   self.rad_per_tick)

    def plan_limits(self, trajectory: Trajectory, opts: ExecutionOptions,
                    period: float) -> list[dict[str, Any]]:
        """Predicted currents along the plan and the collision thresholds (A per joint);
        the warnings they give (a joint whose stop is off)."""
        self.predicted = predicted_currents(trajectory.joints, period, self.bus.servos,
                                            self.arm, self.payload_kg)
        self.quiet_samples = math.ceil(SLEW_QUIET_S / period)
        limits = self.bus.current_limits or tuple(2.3 for _ in self.bus.ids)
        if opts.collision_current is not None:     # its length was checked before
            self.threshold = np.asarray(opts.collision_current, dtype=np.float64)
        else:
            self.threshold_at = threshold_profile(self.predicted, period, limits, self.arm,
                                                  self.bus.position_d_gains)
            self.threshold = (self.threshold_at.max(axis=0) if len(self.threshold_at)
                              else np.full(len(self.bus.ids), np.inf))
            self.chain = ChainThresholds(period, self.bus.servos, self.arm, self.payload_kg,
                                         limits, self.bus.position_d_gains)
        off = [self.joint_names[j] for j in np.nonzero(np.isinf(self.threshold))[0]]
        if not (off and opts.collision):
            return []
        message = (f"collision stop off for joint(s) {off}: their servos have a Position "
                   "D Gain, whose kick on each streamed goal step reads as current at the "
                   "limit; set collision_current_a per joint to use one")
        log.warning("%s", message)
        return [{"code": "collision_stop_off", "message": message}]

    # -- reads ----------------------------------------------------------------------------

    def slewed(self, sample: int) -> None:
        """The goal written for ``sample`` was slewed by the loop: no collision counted
        for :data:`~robodcn.stream.collision.SLEW_QUIET_S` from it."""
        self.quiet_until = sample + self.quiet_samples

    def read(self, timeline: Timeline, sample: int, goal: NDArray[np.int64],
             previous_goal: NDArray[np.int64] | None) -> None:
        """The one place feedback is read and checked: present positions and, with the
        feedback map, velocities, currents and hardware errors from the same packet;
        tracking error against the plan; the collision stop."""
        bus = self.bus
        try:
            if bus.feedback_mapped:
                fb = bus.read_feedback()
                present = fb.positions
            else:
                fb = None
                present = bus.read_positions()
        except CommError as exc:
            self.failures.failed(exc)
            return
        if bus.last_alert_ids or (fb is not None and fb.hardware_errors.any()):
            # a stop, or a misread reply: then nothing of this read counts
            self.alert(*_alert_seen(bus.ids, bus.last_alert_ids, fb, sample))
            return
        self.failures.ok()
        self.reads += 1
        self.last_present = present
        error = self._tracking_error(present, previous_goal, goal,
                                     self.plan_at_read(timeline, sample, goal))
        self.trace.record(sample, self.clock.now() - timeline.t_start, present, error,
                          None if fb is None else fb.currents)
        if fb is not None:
            self.last_feedback = fb
            self.velocities.append(np.abs(fb.velocities))
            self.currents.append(np.abs(fb.currents))
            self.feedback_samples.append(sample)
        self.last_error = error
        self.errors.append(error)
        self.read_samples.append(sample)
        try:
            if fb is not None and self.collision_on and self.threshold is not None:
                self._collision(timeline, sample, np.abs(fb.currents))
            if self.tick_limit is not None:
                self._tracking(sample, error)
        except StreamStop:
            self.back_off(present)
            raise

    def back_off(self, present: NDArray[np.int64]) -> None:
        """Goals where the arm is (``present``, with the static gravity lead when
        compensating: :func:`robodcn.stream.compensation.holding_goals`), written at once;
        a failed write is left to the hold of :mod:`robodcn.stream.finish`."""
        bus = self.bus
        goals = np.clip(present, bus.limits[:, 0], bus.limits[:, 1])
        if self.compensation:
            goals = holding_goals(self.arm, bus.servos, goals, bus.limits,
                                  bus.position_p_gains, self.payload_kg)
        try:
            bus.write_goals(goals)
        except BusError as exc:
            log.debug("back-off write failed: %s", exc.message)

    @staticmethod
    def _tracking_error(present: NDArray[np.int64], previous_goal: NDArray[np.int64] | None,
                        goal: NDArray[np.int64],
                        plan: NDArray[np.float64]) -> NDArray[np.int64]:
        """:func:`~robodcn.stream.report.tracking_error` against the span of the previous
        goal, the goal just written and the plan at the end of the read: a read that lands
        late (the host stalled between the write and the read) widens the span toward the
        plan, never shifts it off the goal the servos were given — on the first sample too,
        where there is no previous goal (a stall there once read as 224 ticks of error)."""
        first = goal if previous_goal is None else previous_goal
        lo = np.minimum(np.minimum(first, goal), plan)
        hi = np.maximum(np.maximum(first, goal), plan)
        return tracking_error(present, lo, hi)

    def plan_at_read(self, timeline: Timeline, sample: int,
                     goal: NDArray[np.int64]) -> NDArray[np.float64]:
        """The plan where it is at the end of this read (ticks, linear between samples):
        a read that lands late on a loaded host compares with where the plan is by then,
        so host lateness does not pass for servo lag (never earlier than ``goal``)."""
        s = (self.clock.now() - timeline.t_start) / timeline.period
        if s <= sample:
            return goal.astype(np.float64)
        source, n = timeline.source, timeline.n
        s = min(s, n - 1)
        lo = int(s)
        hi = min(lo + 1, n - 1)
        below = source.goal(lo)
        return below + (s - lo) * (source.goal(hi) - below).astype(np.float64)

    def _tracking(self, sample: int, error: NDArray[np.float64]) -> None:
        assert self.tick_limit is not None and self.tracking_limit is not None
        over = np.abs(error) > self.tick_limit
        if not over.any():
            return
        j = int(np.argmax(over))
        value = float(abs(error[j]) * self.rad_per_tick[j])
        raise StreamStop("tracking_error",
                         f"tracking error {value:.3f} rad ({int(error[j])} ticks) at joint "
                         f"{self.joint_names[j]!r}, sample {sample}, limit "
                         f"{self.tracking_limit:.3f} rad",
                         {"quantity": "tracking_error", "joint": self.joint_names[j],
                          "sample": int(sample), "value": value, "ticks": int(error[j]),
                          "limit": float(self.tracking_limit), "unit": "rad"})

    def _collision(self, timeline: Timeline, sample: int,
                   current: NDArray[np.float64]) -> None:
        """Stop when a joint's |current| stayed above its threshold for N reads in a row."""
        assert self.threshold is not None
        threshold = self.threshold
        source = timeline.source
        if self.threshold_at is not None and len(self.threshold_at):
            if self.chain is not None and getattr(source, "prev", None) is not None:
                # an online chain's samples are no longer all the plan's: the threshold
                # of what it commands there (robodcn.stream.collision.ChainThresholds)
                threshold = self.chain.at(source, sample)
            else:  # the plan's own samples: the threshold of this sample
                threshold = self.threshold_at[min(sample, len(self.threshold_at) - 1)]
        above = current > threshold
        if sample <= self.quiet_until:  # the servo chases a goal the loop slewed
            above = np.zeros_like(above)
        self.over = np.where(above, self.over + 1, 0)
        hit = self.over >= self.collision_cycles
        if not hit.any():
            return
        j = int(np.argmax(hit))
        self.threshold = threshold       # the report's: the thresholds in force at the stop
        period = timeline.period
        pose = self._pose_at(timeline.source, sample)
        self.collision = {
            "joint": self.joint_names[j], "servo_id": int(self.bus.ids[j]),
            "current_a": float(current[j]), "threshold_a": float(threshold[j]),
            "sample": int(sample), "time_s": sample * period,
            "pose": [float(v) for v in pose]}
        raise StreamStop("collision",
                         f"collision at joint {self.joint_names[j]!r}: current "
                         f"{current[j]:.2f} A above {threshold[j]:.2f} A for "
                         f"{self.collision_cycles} cycles at sample {sample} "
                         f"(t = {sample * period:.3f} s, pose {_pose_text(pose)})")

    def _pose_at(self, source: Any, sample: int) -> NDArray[np.float64]:
        """Planned tool pose of sample i: the trajectory's, or of the commanded joints when
        an online operation swapped the source (its samples may outrun the plan's)."""
        joint = getattr(source, "joint", None)
        if joint is not None and self.arm is not None:
            return user_pose(self.arm, np.asarray(joint(sample))[None, :])[0]
        return self.poses[min(sample, len(self.poses) - 1)]

    # -- health ---------------------------------------------------------------------------

    def alert(self, ids: Sequence[int], seen: str = "") -> None:
        """Stop on a hardware alert of ``ids``, confirmed by reading what each servo reports
        (Hardware Error Status stays set until a reboot: e-manual "Shutdown(63)"); ``seen``:
        how the alert showed, for the message.

        An alert that the confirming read does not show (every servo 0, no Alert bit in its
        status) was not the servos' but a reply misread — a straggler of an earlier read
        that timed out, taken for this one's answer (status packets carry no sequence
        number; a Bus Watchdog poll's 50 read as Hardware Error Status): it counts as a
        communication failure (:class:`CommFailures`), not a stop."""
        try:
            self.hardware = self.bus.hardware_errors()
        except BusError as exc:
            self.hardware = {i: -1 for i in ids}
            seen = f"{seen}; Hardware Error Status unreadable: {exc.message}".lstrip("; ")
        described = {i: describe_hardware_error(e) if e > 0 else "alert bit set"
                     for i, e in self.hardware.items() if e}
        if not described and not self.bus.last_alert_ids:
            log.warning("hardware alert not confirmed (Hardware Error Status reads 0 on "
                        "every servo): a misread reply, counted as a communication "
                        "failure: %s", seen)
            self.failures.failed(CommError(f"a read showed a hardware alert that Hardware "
                                           f"Error Status does not ({seen})", field="bus",
                                           value=list(ids)))
            return
        message = f"hardware alert on servo(s) {described or list(ids)}"
        raise StreamStop("hardware_alert", f"{message}: {seen}" if seen else message)

    def health(self) -> None:
        """One health poll in place of a position read: Hardware Error Status and the Bus
        Watchdog in turn."""
        self.health_polls += 1
        try:
            if self.health_polls % 2:
                errors = self.bus.hardware_errors()
                alerts = self.bus.last_alert_ids
                self.failures.ok()
                if any(errors.values()) or alerts:
                    self.alert(alerts or [i for i, e in errors.items() if e],
                               f"health poll: Alert bit of {list(alerts)}, Hardware Error "
                               f"Status {errors}")
            else:
                self.check_watchdog()
        except CommError as exc:
            self.failures.failed(exc)

    def check_watchdog(self) -> None:
        """Stop when a servo's Bus Watchdog expired (it stopped by itself)."""
        status = self.bus.watchdog_status()
        self.failures.ok()
        tripped = [i for i, v in status.items() if v < 0]
        if tripped:
            raise StreamStop("hardware_alert",
                             f"bus watchdog expired on servo(s) {tripped} (no instruction "
                             f"for {self.bus.watchdog_ms} ms); they stopped by themselves")


__all__ = ["CommFailures", "Feedback", "Timeline"]
