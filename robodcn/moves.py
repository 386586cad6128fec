"""A service move's record: its trajectory, lifecycle status and what was measured.

Lifecycle: ``queued`` → ``running`` → ``done`` | ``degraded`` | ``stopped`` | ``collision``
| ``fault`` | ``failed`` | ``replaced`` (:data:`robodcn.results.MoveState`). The
:class:`~robodcn.controller.ArmController` owns the records and changes them under its
lock; :meth:`MoveRecord.snapshot` is the typed :class:`~robodcn.results.MoveStatus` a
surface turns into JSON.
"""

from __future__ import annotations

import collections
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from robodcn.planner import Trajectory
from robodcn.results import ApproachInfo, ErrorDetail, MoveStatus, to_json
from robodcn.stream import ExecutionReport, Progress, StopSignal

#: Measured samples kept per move, the latest (progress reports come at most every 50 ms:
#: the last 10 minutes or more); with the controller's ``history`` this bounds its memory.
RECORD_SAMPLES = 12_000
#: Statuses of a move that has not finished.
ACTIVE = ("queued", "running")


def move_status(report: ExecutionReport) -> str:
    """The move status of a finished execution: the report's ``outcome`` ("done" |
    "degraded" | "stopped" | "fault", :data:`robodcn.stream.OUTCOMES`)."""
    return report.outcome


def _measured() -> collections.deque[tuple[float, tuple[int, ...]]]:
    return collections.deque(maxlen=RECORD_SAMPLES)


@dataclass
class MoveRecord:
    """One move: its trajectory, status and, once finished, the execution report.

    ``progress`` is the fraction of samples sent (0..1). ``tracking_error`` (rad) is the
    largest over the joints of the streamer's tracking error (robodcn.stream.report
    ``tracking_error``: one definition for the live readout and the report): while the move
    runs that of the latest feedback, once it has finished the report's maximum. Times are
    Unix seconds. ``measured`` holds (seconds since the first write, present ticks) of each
    progress report with a read, then the final read (the latest RECORD_SAMPLES).
    """

    id: str
    trajectory: Trajectory
    status: str = "queued"
    created: float = field(default_factory=time.time)
    started: float | None = None
    finished: float | None = None
    progress: float = 0.0
    elapsed: float = 0.0
    tracking_error: float | None = None
    report: ExecutionReport | None = None
    #: Why it failed or faulted: an error body (robodcn.errors.RobodcnError.to_dict()).
    error: dict[str, Any] | None = None
    #: The report as JSON when execute() raised (a lost device): what the controller saw.
    fault_report: dict[str, Any] | None = None
    stop_signal: StopSignal = field(default_factory=StopSignal, repr=False)
    done: threading.Event = field(default_factory=threading.Event, repr=False)
    #: Set once ``execution`` is there (or the move has ended without one).
    prepared: threading.Event = field(default_factory=threading.Event, repr=False)
    latest: Progress | None = field(default=None, repr=False)
    measured: collections.deque[tuple[float, tuple[int, ...]]] = field(
        default_factory=_measured, repr=False)
    #: The running execution (robodcn.stream.start): pause, resume, speed, replace.
    execution: Any = field(default=None, repr=False)
    #: Sample of the execution where this move begins (a replacement starts mid-stream).
    offset: int = 0
    #: Present Position read when the move was admitted (robodcn.admission), for the
    #: executor not to read it again; None: the executor reads it.
    present_ticks: tuple[int, ...] | None = field(default=None, repr=False)

    @property
    def active(self) -> bool:
        return self.status in ACTIVE

    @property
    def paused(self) -> bool:
        """Running and paused (or braking into a pause)."""
        return bool(self.active and self.execution is not None and self.execution.paused)

    @property
    def speed_scale(self) -> float:
        """The execution's speed scale k (1 for a queued move: it starts at the plan's)."""
        return 1.0 if self.execution is None else float(self.execution.speed)

    def snapshot(self) -> MoveStatus:
        """The move as it is now (call under the controller's lock for a consistent one)."""
        report = self.fault_report if self.report is None else self.report.to_dict()
        return MoveStatus(
            id=self.id, status=self.status, progress=self.progress,
            elapsed=self.elapsed, duration=self.trajectory.duration,
            samples=len(self.trajectory.t), tracking_error=self.tracking_error,
            approach=self.approach(), created=self.created, started=self.started,
            finished=self.finished, report=report,
            error=None if self.error is None else ErrorDetail.of(self.error),
            paused=self.paused, speed_scale=self.speed_scale)

    def to_dict(self) -> dict[str, Any]:
        """:meth:`snapshot` as JSON (``GET /v1/moves/{id}``)."""
        return to_json(self.snapshot())

    def approach(self) -> ApproachInfo | None:
        """The approach the streamer inserted, else the one the trajectory opens with."""
        inserted = None if self.report is None else self.report.approach
        if inserted is not None and inserted.samples:
            return ApproachInfo(inserted.samples, inserted.duration_s)
        n = int(getattr(self.trajectory, "approach_samples", 0) or 0)
        return ApproachInfo(n, n / self.trajectory.rate_hz) if n else None

    def failure(self) -> str:
        """The status of a move that raised: ``fault`` once a sample went out (the arm
        moved), ``failed`` before."""
        return "failed" if self.latest is None else "fault"

    def known_report(self, error: dict[str, Any]) -> dict[str, Any]:
        """What is known of a move that execute() could not report on (a lost device): the
        report's keys from the latest progress and ``error``'s code and message."""
        p = self.latest
        return {"outcome": "fault", "stop_reason": error["code"], "message": error["message"],
                "samples_total": len(self.trajectory.t),
                "samples_sent": 0 if p is None else p.sample + 1,
                "duration_s": self.elapsed, "last_goals": None if p is None else
                list(p.goals), "last_present": None if p is None or p.present is None else
                list(p.present)}

    def start_s(self) -> float:
        """Stream time (s) of the move's first sample: 0, or where a replacement began."""
        return self.offset / self.trajectory.rate_hz
