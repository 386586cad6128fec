"""ArmController: the single owner of a ServoBus in a long-running service.

Every port access runs on one worker thread (robodcn.bus is single-threaded by design): a
move is :func:`robodcn.stream.execute` on that thread, and an idle state read is a job
queued to it. Other threads only start moves, read records, request stops and read the
streamer's latest feedback, all under one lock that is never held across I/O.

Move lifecycle: ``queued`` → ``running`` → ``done`` | ``stopped`` | ``failed``. One move at a
time: :meth:`ArmController.start_move` raises :class:`~robodcn.errors.BusyError` while
another is queued or running. The most recent ``history`` moves are kept for
:meth:`ArmController.move`.
"""

from __future__ import annotations

import collections
import contextlib
import itertools
import logging
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robodcn import kinematics, servo_units
from robodcn.bus import ServoBus, describe_hardware_error
from robodcn.config import Arm
from robodcn.errors import BusyError, CommError, InputError, RobodcnError
from robodcn.planner import Trajectory
from robodcn.stream import ExecutionReport, Progress, StopSignal, execute

log = logging.getLogger("robodcn.controller")

#: Options the service passes to :func:`robodcn.stream.execute` unless overridden: a move
#: starts wherever the arm is (the streamer prepends an approach) and the arm holds after.
DEFAULT_EXECUTE: dict[str, Any] = {"approach": True, "release": False}
#: Seconds :meth:`ArmController.state` waits for an idle bus read.
STATE_TIMEOUT = 5.0
_STATUS = {"completed": "done", "stopped": "stopped", "collision": "collision"}


@dataclass
class MoveRecord:
    """One move: its trajectory, status and, once finished, the execution report.

    ``progress`` is the fraction of samples sent (0..1). ``tracking_error`` (rad) is, while
    the move runs, the largest |present − goal| over the joints at the latest feedback
    (present read just after that goal was sent), and once it has finished the report's
    largest tracking error (present − the previous goal, robodcn.stream). Times are Unix
    seconds.
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
    error: dict[str, Any] | None = None
    stop_signal: StopSignal = field(default_factory=StopSignal, repr=False)
    done: threading.Event = field(default_factory=threading.Event, repr=False)
    latest: Progress | None = field(default=None, repr=False)

    @property
    def active(self) -> bool:
        return self.status in ("queued", "running")

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "status": self.status, "progress": self.progress,
                "elapsed": self.elapsed, "duration": self.trajectory.duration,
                "samples": len(self.trajectory.t), "tracking_error": self.tracking_error,
                "created": self.created, "started": self.started, "finished": self.finished,
                "report": None if self.report is None else self.report.to_dict(),
                "error": self.error}


class ArmController:
    """Runs moves and state reads for ``arm`` on ``bus`` from one worker thread.

    Parameters
    ----------
    arm : Arm
    bus : an open, verified ServoBus for the arm's servos (the controller does not close it)
    history : how many moves :meth:`move` remembers
    execute_options : keyword arguments for :func:`robodcn.stream.execute`, over
        :data:`DEFAULT_EXECUTE`
    """

    def __init__(self, arm: Arm, bus: ServoBus, *, history: int = 64,
                 execute_options: dict[str, Any] | None = None) -> None:
        if tuple(bus.ids) != arm.servo_ids:
            raise InputError(f"the bus drives servo ids {list(bus.ids)}, arm {arm.name!r} has "
                             f"{list(arm.servo_ids)}", field="bus", value=list(bus.ids))
        if isinstance(history, bool) or not isinstance(history, int) or history < 1:
            raise InputError(f"history must be a positive integer, got {history!r}",
                             field="history", value=history)
        self.arm = arm
        self.bus = bus
        self.history = history
        self.execute_options = {**DEFAULT_EXECUTE, **(execute_options or {})}
        for key in ("stop", "progress"):
            if key in self.execute_options:
                raise InputError(f"execute_options may not set {key!r}: the controller owns it",
                                 field=f"execute_options.{key}", value=None)
        self._lock = threading.Lock()
        self._moves: collections.OrderedDict[str, MoveRecord] = collections.OrderedDict()
        self._current: MoveRecord | None = None
        #: Thread holding :meth:`admitting` (reading the pose and planning a move), or None.
        self._admitting: int | None = None
        self._ids = itertools.count(1)
        self._closed = False
        self._rad_per_tick = np.array([2.0 * np.pi / s.ticks_per_turn for s in arm.servos])
        #: The newest positions known without a read (feedback, goals, final reads).
        self._last_ticks: tuple[int, ...] | None = None
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="robodcn-arm")

    # -- moves --------------------------------------------------------------------------------

    @property
    def busy(self) -> bool:
        """A move is queued or running."""
        with self._lock:
            return self._current is not None

    def _check_free(self) -> None:
        """BusyError while a move is queued or running, or another thread is admitting one;
        InputError once closed. Call with ``self._lock`` held."""
        if self._closed:
            raise InputError("the controller is closed", field="controller", value=None)
        if self._current is not None:
            raise self._busy(self._current)
        if self._admitting not in (None, threading.get_ident()):
            raise BusyError("another move request is being planned: wait for it (GET "
                            "/v1/moves) or stop it (POST /v1/stop)", field="move", value=None)

    @contextlib.contextmanager
    def admitting(self) -> Iterator[None]:
        """Hold the arm for one move request, from reading its present pose to
        :meth:`start_move`: a second request meanwhile gets BusyError (409) at once, instead
        of waiting behind the first move and then starting from wherever that one ended."""
        with self._lock:
            self._check_free()
            self._admitting = threading.get_ident()
        try:
            yield
        finally:
            with self._lock:
                self._admitting = None

    def start_move(self, trajectory: Trajectory) -> MoveRecord:
        """Queue ``trajectory`` for execution on the worker thread; returns its record.

        Raises BusyError while another move is queued or running, InputError when the
        trajectory drives other servos than the arm's or the controller is closed.
        """
        if not isinstance(trajectory, Trajectory):
            raise InputError(f"trajectory must be a Trajectory, got {type(trajectory).__name__}",
                             field="trajectory", value=None)
        if tuple(trajectory.servo_ids) != self.arm.servo_ids:
            raise InputError(f"the trajectory drives servo ids {list(trajectory.servo_ids)}, "
                             f"arm {self.arm.name!r} has {list(self.arm.servo_ids)}",
                             field="servo_ids", value=list(trajectory.servo_ids))
        with self._lock:
            self._check_free()
            record = MoveRecord(id=str(next(self._ids)), trajectory=trajectory)
            self._current = record
            self._moves[record.id] = record
            self._trim()
        self._worker.submit(self._run, record)
        return record

    @staticmethod
    def _busy(current: MoveRecord) -> BusyError:
        return BusyError(f"move {current.id} is {current.status}: wait for it (GET "
                         f"/v1/moves/{current.id}) or stop it (POST /v1/stop)",
                         field="move", value=current.id)

    def _trim(self) -> None:
        while len(self._moves) > self.history:
            oldest = next(iter(self._moves.values()))
            if oldest.active:
                break
            self._moves.popitem(last=False)

    def move(self, move_id: str) -> MoveRecord | None:
        """The record of a recent move, or None when unknown (or forgotten)."""
        with self._lock:
            return self._moves.get(str(move_id))

    def move_info(self, move_id: str) -> dict[str, Any] | None:
        """A consistent JSON-ready snapshot of a move (:meth:`MoveRecord.to_dict`), or None."""
        with self._lock:
            record = self._moves.get(str(move_id))
            return None if record is None else record.to_dict()

    def moves(self) -> list[MoveRecord]:
        """Remembered moves, oldest first."""
        with self._lock:
            return list(self._moves.values())

    def wait(self, move_id: str, timeout: float | None = None) -> MoveRecord:
        """Block until the move has finished (or ``timeout``); returns its record."""
        record = self.move(move_id)
        if record is None:
            raise InputError(f"no move {move_id!r}", field="id", value=move_id)
        record.done.wait(timeout)
        return record

    def stop(self, *, wait: float = 1.0) -> dict[str, Any]:
        """Stop the current move, if any; the streamer holds the arm where it is.

        Thread-safe; sets the move's stop signal (acted on within one sample period) and
        waits up to ``wait`` seconds for the hold to be written. Returns ``{"stopped": bool,
        "move": id | None, "status": ...}``.
        """
        with self._lock:
            record = self._current
        if record is None:
            return {"stopped": False, "move": None, "status": None}
        record.stop_signal.request("stop requested")
        record.done.wait(wait)
        with self._lock:
            return {"stopped": True, "move": record.id, "status": record.status}

    def _on_progress(self, record: MoveRecord, p: Progress) -> None:
        error = None
        if p.present is not None:
            diff = np.abs(np.subtract(p.present, p.goals, dtype=np.int64))
            error = float(np.max(diff * self._rad_per_tick))
        with self._lock:
            record.latest = p
            self._last_ticks = p.present or p.goals
            record.progress = p.sample / max(1, p.samples_total - 1)
            record.elapsed = p.elapsed_s
            if error is not None:
                record.tracking_error = error

    def _run(self, record: MoveRecord) -> None:
        with self._lock:
            record.status = "running"
            record.started = time.time()
        try:
            report = execute(record.trajectory, self.bus, stop=record.stop_signal,
                             progress=lambda p: self._on_progress(record, p),
                             **self.execute_options)
        except RobodcnError as exc:
            log.info("move %s refused: %s", record.id, exc.message)
            self._finish(record, "failed", None, exc.to_dict())
        except Exception as exc:  # a bug: keep the service up, say what happened
            log.exception("move %s crashed", record.id)
            self._finish(record, "failed", None, {"code": "internal", "message":
                                                  f"{type(exc).__name__}: {exc}",
                                                  "field": None})
        else:
            status = _STATUS.get(report.stop_reason, "failed")
            error = None if status != "failed" else {
                "code": report.stop_reason, "message": report.message, "field": None}
            self._finish(record, status, report, error)

    def _finish(self, record: MoveRecord, status: str, report: ExecutionReport | None,
                error: dict[str, Any] | None) -> None:
        with self._lock:
            record.status = status
            record.report = report
            record.error = error
            record.finished = time.time()
            if report is not None:
                final = report.final_positions or report.hold_goals
                if final is not None:
                    self._last_ticks = tuple(final)
                record.elapsed = report.duration_s
                if report.completed:
                    record.progress = 1.0
                if report.tracking_error_max_rad:
                    record.tracking_error = max(report.tracking_error_max_rad)
            if self._current is record:
                self._current = None
            self._trim()
        record.done.set()

    # -- state ----------------------------------------------------------------------------------

    def _state_from(self, ticks: Any, *, torque: bool | None, alerts: dict[int, int],
                    source: str, move: str | None) -> dict[str, Any]:
        ticks = np.asarray(ticks, dtype=np.int64)
        joints = servo_units.ticks_to_radians(ticks[None, :], self.arm.servos)[0]
        pose = kinematics.fk(self.arm.links, joints[None, :])[0]
        return {"joints": joints.tolist(), "pose": pose.tolist(), "ticks": ticks.tolist(),
                "joint_names": list(self.arm.joint_names), "torque": torque,
                "alerts": {str(i): describe_hardware_error(e) for i, e in alerts.items() if e},
                "moving": move is not None, "move": move, "source": source}

    def _read_state(self) -> dict[str, Any]:
        with self.bus.claim():
            ticks = self.bus.read_positions()
            torque = all(self.bus.torque_enabled().values())
            alerts = self.bus.hardware_errors()
        with self._lock:
            self._last_ticks = tuple(int(v) for v in ticks)
        return self._state_from(ticks, torque=torque, alerts=alerts, source="bus", move=None)

    def state(self) -> dict[str, Any]:
        """Present joints (rad), pose (FK), ticks, torque, hardware alerts.

        While a move runs: from the streamer's latest feedback (the last goals before the
        first read), without touching the port. Otherwise one read on the worker thread.
        Raises BusError (CommError when the read does not finish within 5 s).
        """
        with self._lock:
            if self._closed:
                raise InputError("the controller is closed", field="controller", value=None)
            record = self._current
            # Before the first feedback of a move: the last positions known.
            ticks = self._last_ticks if record is not None else None
            if record is not None and ticks is None:
                ticks = tuple(record.trajectory.ticks[0])
        if record is not None:
            return self._state_from(ticks, torque=True, alerts={}, source="stream",
                                    move=record.id)
        future = self._worker.submit(self._read_state)
        try:
            return future.result(STATE_TIMEOUT)
        except FutureTimeout:
            raise CommError(f"reading the arm's state took over {STATE_TIMEOUT:g} s",
                            field="bus", value=None) from None

    def present_joints(self) -> np.ndarray:
        """The arm's present joint angles (k,) rad, read on the worker thread.

        Raises BusyError while a move is queued or running (the arm is not where it will
        start from), BusError when the servos do not answer.
        """
        with self._lock:
            self._check_free()
        future = self._worker.submit(self._read_ticks)
        try:
            ticks = future.result(STATE_TIMEOUT)
        except FutureTimeout:
            raise CommError(f"reading the arm's position took over {STATE_TIMEOUT:g} s",
                            field="bus", value=None) from None
        return servo_units.ticks_to_radians(ticks[None, :], self.arm.servos)[0]

    def _read_ticks(self) -> np.ndarray:
        ticks = self.bus.read_positions()
        with self._lock:
            self._last_ticks = tuple(int(v) for v in ticks)
        return ticks

    def close(self, *, timeout: float = 5.0) -> None:
        """Stop any move (the arm holds), finish the worker thread. Idempotent.

        The bus stays open: whoever opened it closes it.
        """
        with self._lock:
            self._closed = True
            record = self._current
        if record is not None:
            record.stop_signal.request("the service is shutting down")
            record.done.wait(timeout)
        self._worker.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> ArmController:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
