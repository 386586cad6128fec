"""A service move's record: its trajectory, lifecycle status and what was measured.

Lifecycle: ``queued`` → ``running`` (``following``: a follow session) → ``done`` |
``degraded`` | ``stopped`` | ``collision`` | ``fault`` | ``failed`` | ``replaced``
(:data:`robodcn.results.MoveState`). The :class:`~robodcn.controller.ArmController` owns
the records and changes them under its lock; :meth:`MoveRecord.snapshot` is the typed
:class:`~robodcn.results.MoveStatus` a surface turns into JSON.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn.planner import Trajectory
from robodcn.planner.recovery import Recovery
from robodcn.planner.tool_peak import tool_peak
from robodcn.results import ApproachInfo, ErrorDetail, MoveStatus, to_json
from robodcn.stream import ExecutionReport, Progress, StopSignal

#: Rows of a move's recording answered at most, the latest (one per feedback read: 2 minutes
#: at 100 Hz); the reads themselves are the execution's (its report's trace).
RECORD_SAMPLES = 12_000
#: Statuses of a move that has not finished.
ACTIVE = ("queued", "running", "following")


def move_status(report: ExecutionReport) -> str:
    """The move status of a finished execution: the report's ``outcome`` ("done" |
    "degraded" | "stopped" | "fault", :data:`robodcn.stream.OUTCOMES`)."""
    return report.outcome


def _reads(execution: Any) -> tuple[NDArray[np.int64], NDArray[np.float64],
                                    NDArray[np.int64]] | None:
    """(sample, t s since the first write's due time, present ticks) of every feedback read
    of ``execution`` so far: its report's trace once finished
    (:class:`robodcn.stream.ExecutionTrace`), else the rows its stream has recorded (a
    consistent prefix: a row is complete before the recorder counts it)."""
    report = getattr(execution, "report", None)
    trace = None if report is None else report.trace
    if trace is not None:
        return trace.sample, trace.t, trace.ticks
    recorder = getattr(getattr(getattr(execution, "stream", None), "feedback", None),
                       "trace", None)
    if recorder is None:
        return None
    n = recorder.count
    return recorder.sample[:n].copy(), recorder.t[:n].copy(), recorder.ticks[:n].copy()


@dataclass
class MoveRecord:
    """One move: its trajectory, status and, once finished, the execution report.

    ``progress`` is the fraction of samples sent (0..1). ``tracking_error`` (rad) is the
    largest over the joints of the streamer's tracking error (robodcn.stream.report
    ``tracking_error``: one definition for the live readout and the report): while the move
    runs that of the latest feedback, once it has finished the report's maximum. Times are
    Unix seconds. What it measured is :meth:`recording`: one row per feedback read.
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
    #: The running execution (robodcn.stream.start): pause, resume, speed, replace.
    execution: Any = field(default=None, repr=False)
    #: UNIX time (s) its first sample is due (a move body's ``start_at``); None: at once.
    start_at: float | None = None
    #: The recovery that opens the move (:class:`robodcn.planner.recovery.Recovery`), None
    #: when the arm started inside its limits.
    recovery: Recovery | None = None
    #: Sample of the execution where this move begins (a replacement starts mid-stream).
    offset: int = 0
    #: Sample where a replacement took the execution over (None: this move ran to its end).
    until: int | None = None
    #: Present Position read when the move was admitted (robodcn.admission), for the
    #: executor not to read it again; None: the executor reads it.
    present_ticks: tuple[int, ...] | None = field(default=None, repr=False)
    #: :meth:`tool`, once found
    _tool: dict[str, Any] | None = field(default=None, repr=False)

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
            paused=self.paused, speed_scale=self.speed_scale, tool=self.tool(),
            recovery=None if self.recovery is None else self.recovery.to_dict())

    def tool(self) -> dict[str, Any]:
        """The trajectory's :func:`~robodcn.planner.tool_peak.tool_peak` as JSON, found once
        (a status is asked for many times while the move runs)."""
        if self._tool is None:
            self._tool = tool_peak(self.trajectory).to_dict()
        return self._tool

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

    def replaced_by(self, new_id: str, trajectory: Trajectory, first: int) -> MoveRecord:
        """End this move ``replaced`` at sample ``first`` and return the running record of
        its replacement ``new_id`` (``trajectory``: its samples from ``first``), which takes
        over its execution and stop signal. Call with the controller's lock held."""
        now = time.time()
        new = MoveRecord(id=new_id, trajectory=trajectory, status="running", started=now,
                         execution=self.execution, offset=first, stop_signal=self.stop_signal)
        new.prepared.set()
        self.status, self.until, self.finished = "replaced", first, now
        self.done.set()
        return new

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

    def recording(self) -> list[tuple[float, tuple[int, ...]]]:
        """What this move measured: one row per feedback read, (seconds since its first
        sample, present ticks) — the reads after its samples ``offset`` to ``until`` (the
        rest of the execution belongs to the move that replaced it), then, for the move
        that ended the execution, the final read after the stream (at the stream's end,
        ``duration_s``). The latest :data:`RECORD_SAMPLES` rows."""
        reads = None if self.execution is None else _reads(self.execution)
        if reads is None:
            return []
        sample, t, ticks = reads
        keep = sample >= self.offset
        if self.until is not None:
            keep &= sample < self.until
        start = self.start_s()
        rows = [(float(at) - start, tuple(int(v) for v in k))
                for at, k in zip(t[keep].tolist(), ticks[keep].tolist(), strict=True)]
        report = self.report
        # the final read's stream time is the whole execution's end (a replacement's own
        # report counts from its switch)
        whole = getattr(self.execution, "report", None) or report
        if self.until is None and report is not None and report.final_positions is not None:
            end = float(whole.duration_s) - start
            if not rows or end > rows[-1][0]:
                rows.append((end, tuple(int(v) for v in report.final_positions)))
        return rows[-RECORD_SAMPLES:]

    def start_s(self) -> float:
        """Stream time (s) of the move's first sample: 0, or where a replacement began."""
        return self.offset / self.trajectory.rate_hz
