"""ArmController: the single owner of a ServoBus in a long-running service.

Every port access runs on one worker thread (:class:`robodcn.bus_worker.BusWorker`;
robodcn.bus is single-threaded by design): a move is streamed on that thread
(:func:`robodcn.stream.online.prepare`), so the running move can be stopped smoothly,
paused, resumed, re-timed and replaced from the request threads
(:meth:`ArmController.stop_move`, :meth:`~ArmController.pause`,
:meth:`~ArmController.resume`, :meth:`~ArmController.set_speed`,
:meth:`~ArmController.replace_move`), and an idle state read is a job queued to it. Other
threads only start moves, read records, request stops and read the streamer's latest
feedback, all under one lock that is never held across I/O.

A move's record and lifecycle are :class:`robodcn.moves.MoveRecord`'s (the finished
status is the report's outcome; ``fault`` is a bus or servo fault after motion began,
``failed`` a refusal before any sample was sent). One move at a time:
:meth:`ArmController.start_move` raises :class:`~robodcn.errors.BusyError` while another is
queued or running; a surface admits a move through :func:`robodcn.admission.admit` (read
the present state once, plan once, start). The most recent ``history`` moves are kept for
:meth:`ArmController.move`, each with what was measured while it ran. Answers are the typed
results of :mod:`robodcn.results` (MoveStatus, State, StopAnswer); the surfaces turn them
into JSON.

Servo admin (:meth:`ArmController.set_torque`, :meth:`ArmController.reboot`,
:meth:`ArmController.gripper`) runs on the same worker thread through
:mod:`robodcn.servo_admin` and :mod:`robodcn.workflow.admin`, refused (BusyError) while a
move runs; torque off on an arm under gravity needs ``confirm``. A stop
(:meth:`ArmController.stop`) halts a gripper action too (:class:`robodcn.servo_admin.Halt`).

Losing the serial device is a bus fault, never a crash (:mod:`robodcn.bus_worker`): the
move ends ``fault`` with a report of what was sent, reads raise CommError (503), and the
next request after a fault reopens and re-verifies the port;
:meth:`ArmController.check_bus` (``GET /healthz``) says why the arm cannot be driven now.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import itertools
import logging
import threading
import time
from collections.abc import Iterator
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from robodcn import servo_admin, servo_units
from robodcn.bus import ServoBus, describe_hardware_error
from robodcn.bus_worker import DEVICE_ERRORS, STATE_TIMEOUT, BusWorker, device_fault
from robodcn.config import Arm
from robodcn.errors import (
    BusError,
    BusyError,
    CommError,
    HardwareAlertError,
    InputError,
    NoMoveError,
    RobodcnError,
)
from robodcn.moves import RECORD_SAMPLES, MoveRecord, move_status
from robodcn.planner import Trajectory
from robodcn.planner.recovery import Recovery
from robodcn.results import MoveStatus, RebootAnswer, State, StopAnswer, TorqueAnswer
from robodcn.stream import (
    STOP_MODES,
    ExecutionOptions,
    ExecutionReport,
    Follower,
    Progress,
    StopSignal,
)
from robodcn.stream.online import Execution, PlanningTimes, SwitchMissed, Turns, prepare
from robodcn.workflow import poses
from robodcn.workflow.gripper import GripperResult, GripperState, read_gripper_state

log = logging.getLogger("robodcn.controller")

#: Options the service executes with unless overridden: a move starts wherever the arm is
#: (the streamer prepends an approach if it has moved since planning) and the arm holds after.
DEFAULT_EXECUTE = ExecutionOptions(approach=True, release=False)
#: Seconds an online operation on a queued move waits for its stream to start (then 409):
#: with the operation's own planning, the answer stays within a second.
QUEUED_WAIT = 0.4
#: Seconds before a move's ``start_at`` its stream is prepared (preflight: the start check,
#: configuring the servos): more than that takes on a loaded host; the streamer then waits
#: for start_at itself before it arms the Bus Watchdog.
START_LEAD_S = 1.0
#: Seconds a replacement waits for another being planned (then 409): a queue of them would
#: hold each answer for the planning of all before it.
REPLACE_WAIT = 0.2
#: Seconds ``GET /healthz``'s check of an idle bus may take (:meth:`ArmController.
#: check_bus`): a reopen and verify after a fault, or one read of the servos' alerts.
HEALTH_TIMEOUT = 1.0
#: Seconds an online operation may plan, its attempts and waits included (Execution.
#: budget_s; then 409, nothing changed): with the waits above, answers within 1.5 s. A
#: retarget of the OM-X plans in ~0.15–0.3 s on a quiet host (holding-torque, keep-out and
#: tool checks included): 0.5 s refused it whenever the host was busy.
OPERATION_BUDGET_S = 1.0


class CarriedLoad(Protocol):
    """A simulated arm that carries what each move declares (robodcn.simulated.SimulatedArm):
    :meth:`carry` before the move streams, :meth:`reported` names the load in its report."""

    def carry(self, payload_kg: float | None) -> float | None: ...

    def reported(self, report: ExecutionReport, trajectory: Trajectory
                 ) -> ExecutionReport: ...


class ArmController:
    """Runs moves and state reads for ``arm`` on ``bus`` from one worker thread.

    Parameters
    ----------
    arm : Arm
    bus : an open, verified ServoBus for the arm's servos (the controller does not close it)
    history : how many moves :meth:`move` remembers
    execute_options : :class:`~robodcn.stream.ExecutionOptions`, or a dict of its fields
        over :data:`DEFAULT_EXECUTE` (``stop`` and ``progress`` are the controller's)
    simulated : the dry run's simulated arm (``serve --sim``): it carries the payload each
        move declares before the move streams, and the report names it (issue 27 §2)
    """

    def __init__(self, arm: Arm, bus: ServoBus, *, history: int = 64,
                 execute_options: ExecutionOptions | dict[str, Any] | None = None,
                 simulated: CarriedLoad | None = None) -> None:
        if tuple(bus.ids) != arm.servo_ids:
            raise InputError(f"the bus drives servo ids {list(bus.ids)}, arm {arm.name!r} has "
                             f"{list(arm.servo_ids)}", field="bus", value=list(bus.ids))
        if isinstance(history, bool) or not isinstance(history, int) or history < 1:
            raise InputError(f"history must be a positive integer, got {history!r}",
                             field="history", value=history)
        self.arm = arm
        self.bus = bus
        self.history = history
        if isinstance(execute_options, ExecutionOptions):
            options = execute_options
        else:
            given = dict(execute_options or {})
            for key in ("stop", "progress"):
                if key in given:
                    raise InputError(f"execute_options may not set {key!r}: the controller "
                                     "owns it", field=f"execute_options.{key}", value=None)
            options = ExecutionOptions.build(DEFAULT_EXECUTE, given)
        if options.stop is not None or options.progress is not None:
            raise InputError("execute_options may not set stop or progress: the controller "
                             "owns them", field="execute_options", value=None)
        self.execute_options = options
        self.simulated = simulated
        self._lock = threading.Lock()
        self._moves: collections.OrderedDict[str, MoveRecord] = collections.OrderedDict()
        self._current: MoveRecord | None = None
        #: Thread holding :meth:`admitting` (reading the pose and planning a move), or None.
        self._admitting: int | None = None
        #: The stop signal of the lowering a torque off or a reboot runs first, or None.
        self._lowering: StopSignal | None = None
        #: Replacements take turns, from the request to the switch (robodcn.admission).
        self.replacements = Turns(REPLACE_WAIT, "another replacement is being planned")
        self._ids = itertools.count(1)
        self._closed = False
        #: The newest positions known without a read (feedback, goals, final reads).
        self._last_ticks: tuple[int, ...] | None = None
        self._worker = BusWorker(bus)
        #: Where every move's online operations place their switches from (measured once
        #: for the service, not again per move).
        self._planning_times = PlanningTimes()
        #: Admin actions under way or queued that a stop halts (the gripper's).
        self._halts: set[servo_admin.Halt] = set()

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
        :meth:`start_move` (:func:`robodcn.admission.admit`): a second request meanwhile
        gets BusyError (409) at once, instead of waiting behind the first move and then
        starting from wherever that one ended."""
        with self._lock:
            self._check_free()
            self._admitting = threading.get_ident()
        try:
            yield
        finally:
            with self._lock:
                self._admitting = None

    def start_move(self, trajectory: Trajectory, *,
                   present_ticks: tuple[int, ...] | None = None,
                   start_at: float | None = None,
                   recovery: Recovery | None = None) -> MoveRecord:
        """Queue ``trajectory`` for execution on the worker thread; returns its record.

        ``present_ticks``: Present Position as read for planning it (admission), so the
        executor need not read it again; None when the executor is to read it.
        ``start_at``: UNIX time (s) its first sample is due (None: at once); the worker
        waits (stoppable) until :data:`START_LEAD_S` before it, then prepares the stream,
        which waits for ``start_at`` after its preflight and puts the first sample then.
        ``recovery``: the recovery that opens ``trajectory`` (admission), kept in the record.

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
        record = self._queue(trajectory, present_ticks, start_at, recovery)
        self._worker.submit(self._run, record)
        return record

    def _queue(self, trajectory: Trajectory, present_ticks: tuple[int, ...] | None,
               start_at: float | None, recovery: Recovery | None = None) -> MoveRecord:
        """A new current move's record (BusyError while another is queued or running)."""
        with self._lock:
            self._check_free()
            record = MoveRecord(id=str(next(self._ids)), trajectory=trajectory,
                                present_ticks=present_ticks, start_at=start_at,
                                recovery=recovery)
            self._current = record
            self._moves[record.id] = record
            self._trim()
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

    def move_info(self, move_id: str) -> MoveStatus | None:
        """A consistent snapshot of a move (:meth:`MoveRecord.snapshot`), or None."""
        with self._lock:
            record = self._moves.get(str(move_id))
            return None if record is None else record.snapshot()

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

    def request_stop(self, reason: str = "stop requested") -> None:
        """Signal the current move to stop, without a lock or a wait (signal handlers)."""
        record, lowering = self._current, self._lowering
        if record is not None:
            record.stop_signal.request(reason)
        if lowering is not None:
            lowering.request(reason)

    def stop(self, *, wait: float = 1.0) -> StopAnswer:
        """Stop everything that moves: the current move, if any (the streamer holds the arm
        where it is), a torque off's or a reboot's lowering, and a gripper action (its goal
        := where the jaws are, within one poll of the action).

        Thread-safe; sets the move's stop signal (acted on within one sample period) and the
        gripper action's halt, and waits until both have ended (at most ``wait`` seconds in
        all). ``stopped`` says what holds now: a gripper action was halted, or the move has
        ended with its hold written. A move that has not ended within ``wait``, or whose
        hold the servos did not take (a stalled or lost bus: ``hold_failed`` says why; the
        move ends ``fault`` and only the servos' Bus Watchdog stops them), is not
        ``stopped``.
        """
        with self._lock:
            record = self._current
            lowering = self._lowering
            halts = list(self._halts)
        for halt in halts:
            halt.requested.set()
        if lowering is not None:       # a torque off or a reboot lowering the arm first
            lowering.request("stop requested")
        if record is not None:
            record.stop_signal.request("stop requested")
        deadline = time.monotonic() + wait
        gripper = False
        for halt in halts:
            halt.ended.wait(max(0.0, deadline - time.monotonic()))
            gripper = gripper or halt.halted
        if record is None:
            return StopAnswer(stopped=gripper or lowering is not None, move=None,
                              status=None, gripper=gripper)
        record.done.wait(max(0.0, deadline - time.monotonic()))
        with self._lock:
            held, failed = self._held(record)
            return StopAnswer(stopped=held or gripper, move=record.id, status=record.status,
                              gripper=gripper, hold_failed=failed)

    @staticmethod
    def _held(record: MoveRecord) -> tuple[bool, str | None]:
        """Whether ``record`` has ended holding (its hold written, or it never moved), and
        why not when its hold failed. Call with ``self._lock`` held."""
        if not record.done.is_set():
            return False, None
        report = record.report
        if report is not None:
            return report.hold_failed is None, report.hold_failed
        if record.status == "fault" and record.error is not None:
            return False, f"the move ended before its hold: {record.error.get('message')}"
        return record.status == "failed", None

    # -- online operations (robodcn.stream.online): stop modes, pause, speed, replace ------

    def _live(self) -> tuple[MoveRecord, Execution]:
        """The running move and its execution; NoMoveError when none runs.

        A queued move is waited for until its stream is prepared (:data:`QUEUED_WAIT` at
        most: the worker starts it at once unless a bus read is in flight)."""
        with self._lock:
            record = self._current
        if record is not None:
            record.prepared.wait(QUEUED_WAIT)
        execution = None if record is None else record.execution
        if record is None or execution is None or record.done.is_set():
            raise NoMoveError("no move is running", field="move", value=None)
        return record, execution

    @staticmethod
    def _raced(record: MoveRecord, execution: Execution, exc: InputError) -> RobodcnError:
        """The error of an online operation that lost a race with the stream: NoMoveError
        when the move has ended meanwhile, BusyError when no switch could be placed ahead
        of the stream in time (409 both: nothing changed, nothing was wrong with the
        request); else ``exc`` itself."""
        if execution.done or record.done.is_set():
            return NoMoveError(f"move {record.id} has ended: {exc.message}", field="move",
                               value=record.id)
        if isinstance(exc, SwitchMissed):
            return BusyError(f"move {record.id}: {exc.message}; nothing changed, try again",
                             field="move", value=record.id)
        return exc

    def _online(self, record: MoveRecord, execution: Execution, op: Any) -> Any:
        """``op()`` on the running execution, its lost races 409 (:meth:`_raced`)."""
        try:
            return op()
        except InputError as exc:
            raced = self._raced(record, execution, exc)
            if raced is exc:
                raise
            raise raced from exc

    def stop_move(self, mode: str = "smooth", *, wait: float = 1.0) -> StopAnswer:
        """Stop the current move: ``"smooth"`` decelerates along its path within the limits
        and holds there, ``"hold"`` holds where the arm is at once (:meth:`stop`).

        A smooth stop answers once its brake is in the stream (the move then ends
        ``stopped`` at rest), without waiting for the arm to get there; a hold once it is
        written (at most ``wait`` seconds)."""
        if mode not in STOP_MODES:
            raise InputError(f"mode must be one of {', '.join(STOP_MODES)}, got {mode!r}",
                             field="mode", value=mode)
        with self._lock:
            record = self._current
        execution = None if record is None else record.execution
        if mode == "hold" or record is None or execution is None:
            return self.stop(wait=wait)
        execution.stop("smooth")
        with self._lock:
            return StopAnswer(stopped=True, move=record.id, status=record.status)

    def _snapshot(self, record: MoveRecord) -> MoveStatus:
        with self._lock:
            return record.snapshot()

    def pause(self) -> MoveStatus:
        """Pause the running move (a smooth stop on its path; the stream goes on).

        Raises NoMoveError (409) when nothing runs, or when the move reaches its own end
        before a brake could stop it (it ends at rest, not paused)."""
        record, execution = self._live()
        if not self._online(record, execution, execution.pause):
            raise NoMoveError(f"move {record.id} ends before a pause could stop it: it comes "
                              "to rest at its own end", field="move", value=record.id)
        # the state this pause made (a resume another client asks at once comes after it)
        snap = self._snapshot(record)
        return dataclasses.replace(snap, paused=True) if snap.status == "running" else snap

    def resume(self) -> MoveStatus:
        """Resume a paused move along the same path, timed from rest."""
        record, execution = self._live()
        self._online(record, execution, execution.resume)
        return self._snapshot(record)

    def set_speed(self, scale: float) -> MoveStatus:
        """Re-time the rest of the running move with the limits scaled by ``scale``."""
        record, execution = self._live()
        self._online(record, execution, lambda: execution.set_speed(scale))
        return self._snapshot(record)

    def replace_move(self, request: Any) -> MoveRecord:
        """Retarget the running move to ``request`` (a PlanRequest) from its moving state:
        a new move record (running), the old one ends ``replaced``. Raises NoMoveError when
        nothing runs, BusyError when another replacement is being planned for longer than
        :data:`REPLACE_WAIT` (:attr:`replacements`) or no switch landed within
        :data:`OPERATION_BUDGET_S`, the planner's errors when the new path cannot be planned
        (the old move goes on unchanged). Answers once the new samples are in the stream,
        not when the arm gets to them."""
        with self.replacements.take():
            record, execution = self._live()
            first = self._online(record, execution, lambda: execution.retarget(request))
            trajectory = execution.remaining(first, request)
            with self._lock:
                if self._current is not record or record.done.is_set() or execution.done:
                    # the stream ended meanwhile (its report is the old move's): nothing to
                    # take over, and no record that would never finish
                    raise NoMoveError(f"move {record.id} ended before the replacement could "
                                      "take over; start the new move without replace",
                                      field="move", value=record.id)
                new = record.replaced_by(str(next(self._ids)), trajectory, first)
                self._current = new
                self._moves[new.id] = new
                self._trim()
            return new

    # -- follow a stream of targets (robodcn.stream.following) -----------------------------

    def start_follow(self, trajectory: Trajectory, *, space: str = "joints",
                     timeout_s: float | None = None, payload_kg: float | None = None,
                     present_ticks: tuple[int, ...] | None = None) -> MoveRecord:
        """Open a follow session: one move record (status ``following``) whose stream the
        worker runs until :meth:`follow_end` or a stop (:class:`~robodcn.stream.Follower`;
        ``trajectory``: its rest samples where the arm is,
        :func:`~robodcn.stream.following.rest_trajectory`). The arguments are checked
        here (InputError naming the field); BusyError while another move runs."""
        self.check_follow(space, timeout_s)
        record = self._queue(trajectory, present_ticks, None)
        options = ExecutionOptions.build(
            self.execute_options,
            {"stop": record.stop_signal,
             "progress": lambda p: self._on_progress(self._live_of(record), p)})

        def make(rec: MoveRecord) -> Follower:
            return Follower(self.bus, self.arm, rec.trajectory, space=space,
                            timeout_s=timeout_s, payload_kg=payload_kg, options=options,
                            present_ticks=rec.present_ticks)
        self._worker.submit(self._run, record, make)
        return record

    def check_follow(self, space: str, timeout_s: float | None) -> None:
        """A follow session's arguments (InputError naming ``space`` or ``timeout_s``)."""
        Follower.check(self.arm, space, timeout_s)

    def _session(self) -> tuple[MoveRecord, Follower]:
        """The running follow session; NoMoveError (409) when none runs."""
        with self._lock:
            record = self._current
        if record is not None:
            record.prepared.wait(QUEUED_WAIT)
        follower = None if record is None else record.execution
        if record is None or not isinstance(follower, Follower) or record.done.is_set():
            raise NoMoveError("no follow session is open (POST /v1/follow opens one)",
                              field="follow", value=None if record is None else record.id)
        return record, follower

    def follow_target(self, joints: Any = None, pose: Any = None,
                      velocity: Any = None) -> int:
        """Hand the running follow session a target (:meth:`Follower.target`); its sequence
        number. InputError naming ``joints``/``pose``/``velocity`` (the session goes on to
        the previous target), NoMoveError when no session runs."""
        _, follower = self._session()
        return follower.target(joints=joints, pose=pose, velocity=velocity)

    def follow_end(self) -> MoveStatus:
        """End the follow session at rest on its last target (the move ends ``done``);
        answers at once, the record's status is ``following`` until the arm is there."""
        record, follower = self._session()
        follower.end()
        return self._snapshot(record)

    # -- the worker: streaming a move ---------------------------------------------------------

    def _on_progress(self, record: MoveRecord, p: Progress) -> None:
        error = None
        if p.tracking_error_rad:
            error = float(np.max(np.abs(p.tracking_error_rad)))
        with self._lock:
            record.latest = p
            self._last_ticks = p.present or p.goals
            # of the samples planned for this move (an online re-timing may stream more or
            # fewer: a smooth stop ends early, a slower speed runs longer)
            planned = max(1, len(record.trajectory.t) - 1)
            record.progress = min(1.0, max(0.0, (p.sample - record.offset) / planned))
            record.elapsed = p.elapsed_s
            if error is not None:
                record.tracking_error = error

    def _prepare(self, record: MoveRecord) -> Execution:
        """The execution of a planned move (its online operations from the request
        threads: pause, speed, replace)."""
        execution = prepare(record.trajectory, self.bus, self.execute_options,
                            start_at=record.start_at, stop=record.stop_signal,
                            progress=lambda p: self._on_progress(self._live_of(record), p),
                            arm=self.arm, planning_times=self._planning_times,
                            present_ticks=record.present_ticks)
        execution.budget_s = OPERATION_BUDGET_S
        return execution

    def _run(self, record: MoveRecord, make: Any = None) -> None:
        """Stream ``record`` on this (the worker) thread: the execution ``make(record)``
        builds (default :meth:`_prepare`; a follow session's :class:`~robodcn.stream.
        Follower`), run to its end."""
        with self._lock:
            record.status = "running" if make is None else "following"
            record.started = time.time()
        worker = self._worker
        try:
            worker.recover()
            if record.start_at is not None:
                record.stop_signal.wait(max(0.0, record.start_at - START_LEAD_S - time.time()))
            if self.simulated is not None and record.trajectory is not None:
                # the dry run carries what the move declares
                request = record.trajectory.request
                self.simulated.carry(None if request is None else request.payload_kg)
            execution = (make or self._prepare)(record)
            with self._lock:
                record.execution = execution
            record.prepared.set()
            report = execution.run()
        except RobodcnError as exc:
            if isinstance(exc, BusError):
                worker.mark_fault(exc.message)
            log.info("move %s ended: %s", record.id, exc.message)
            self._finish(record, None, None, exc.to_dict())
        except DEVICE_ERRORS as exc:
            fault = device_fault(self.bus, exc)
            worker.mark_fault(fault.message)
            log.warning("move %s: %s", record.id, fault.message)
            self._finish(record, None, None, fault.to_dict())
        except Exception as exc:  # a bug: keep the service up, say what happened
            log.exception("move %s crashed", record.id)
            self._finish(record, None, None, {
                "code": "internal", "message": f"{type(exc).__name__}: {exc}", "field": None})
        else:
            status = move_status(report)
            if status == "fault":
                worker.mark_fault(f"move {record.id} ended in a fault: {report.message}")
            else:
                worker.fault = None
            error = None if status != "fault" else {
                "code": report.stop_reason, "message": report.message, "field": None}
            self._finish(record, status, report, error)

    def _live_of(self, record: MoveRecord) -> MoveRecord:
        """The record now running ``record``'s execution (a replacement), else ``record``
        (read ``self._current`` under the lock for a decision that must hold)."""
        current = self._current
        if current is not None and current.execution is not None \
                and current.execution is record.execution:
            return current
        return record

    def _finish(self, record: MoveRecord, status: str | None, report: ExecutionReport | None,
                error: dict[str, Any] | None) -> None:
        """End the move running ``record``'s execution (``record``, or the replacement that
        took it over); ``status`` None: failed or fault (:meth:`MoveRecord.failure`)."""
        with self._lock:
            record = self._live_of(record)
            if report is not None and record.offset and record.execution is not None:
                # A replacement's counts are its own samples', not the replaced move's.
                report = record.execution.report_from(record.offset)
                if status in ("done", "degraded"):
                    status = move_status(report)
            if status is None:
                status = record.failure()
            if report is not None and self.simulated is not None:
                report = self.simulated.reported(report, record.trajectory)
            record.status = status
            record.report = report
            record.error = error
            if isinstance(record.execution, Follower):
                # a follow session's record is what it commanded (its rest plan before)
                record.trajectory = record.execution.commanded()
                record._tool = None
            if report is None and status == "fault" and error is not None:
                record.fault_report = record.known_report(error)
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
        if report is not None and report.out_of_position:
            log.warning("move %s: %s", record.id, report.headline)
        record.prepared.set()
        record.done.set()

    # -- state ----------------------------------------------------------------------------------

    def _state_from(self, ticks: Any, *, torque: bool | None, alerts: dict[int, int],
                    source: str, record: MoveRecord | None,
                    gripper: GripperState | None = None,
                    feedback: tuple[Any, Any] | None = None) -> State:
        """``feedback``: the (shaft velocities rad/s, currents A) read with ``ticks``, bus
        order, signed as the servos report them (:func:`servo_units.joint_velocities`,
        :func:`servo_units.joint_efforts`), or None."""
        ticks = np.asarray(ticks, dtype=np.int64)
        joints = servo_units.ticks_to_radians(ticks[None, :], self.arm.servos)[0]
        pose = poses.tool_pose(self.arm, joints)
        velocities = efforts = None
        if feedback is not None:
            velocities = servo_units.joint_velocities(feedback[0], self.arm.servos).tolist()
            efforts = servo_units.joint_efforts(feedback[1], self.arm.servos).tolist()
        return State(
            joints=joints.tolist(), pose=pose.tolist(), ticks=ticks.tolist(),
            joint_names=list(self.arm.joint_names), torque=torque,
            alerts={str(i): describe_hardware_error(e) for i, e in alerts.items() if e},
            moving=record is not None, move=None if record is None else record.id,
            source=source,  # type: ignore[arg-type]
            paused=False if record is None else record.paused,
            speed_scale=None if record is None else record.speed_scale,
            gripper_width_m=None if gripper is None else gripper.width_m,
            holding=None if gripper is None else gripper.holding,
            velocities=velocities, efforts=efforts)

    def _read_state(self) -> State:
        with self.bus.claim():
            feedback = None
            if self.bus.feedback_mapped:    # the Indirect Data block: velocity and current
                fb = self.bus.read_feedback()
                ticks, feedback = fb.positions, (fb.velocities, fb.currents)
            else:
                ticks = self.bus.read_positions()
            torque = all(self.bus.torque_enabled().values())
            alerts = self.bus.hardware_errors()
            jaws = None if self.arm.gripper is None else \
                read_gripper_state(self.bus, self.arm.gripper)
        with self._lock:
            self._last_ticks = tuple(int(v) for v in ticks)
        return self._state_from(ticks, torque=torque, alerts=alerts, source="bus", record=None,
                                gripper=jaws, feedback=feedback)

    def state(self) -> State:
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
            latest = None if record is None else record.latest
        if record is not None:
            feedback = None
            if latest is not None and latest.velocities is not None \
                    and latest.present is not None:
                feedback = (latest.velocities, latest.currents)
            return self._state_from(ticks, torque=True, alerts={}, source="stream",
                                    record=record, feedback=feedback)
        return self._worker.call(self._read_state, "reading the arm's state")

    def check_bus(self, timeout: float = HEALTH_TIMEOUT) -> None:
        """Raise the BusError that makes the arm undrivable now, if any: the bus lost or
        faulted, or a servo reporting a hardware error (``GET /healthz``'s 503).

        While a move runs, the stream watches the bus: the last fault known, if any (none:
        a fault ends the move). While an admin job runs, likewise. Otherwise one job on the
        worker thread, of at most ``timeout`` seconds: after a fault it reopens and
        re-verifies the port (CommError while the device is still gone), then reads every
        servo's Hardware Error Status (HardwareAlertError naming the servos and bits).
        """
        with self._lock:
            if self._closed:
                raise InputError("the controller is closed", field="controller", value=None)
            moving = self._current is not None
        worker = self._worker
        probed, alerts = (False, None) if moving else worker.call_if_idle(
            self._read_alerts, "checking the servo bus", timeout)
        if not probed:  # the stream or an admin job has the port: what it found
            if worker.fault is not None:
                raise CommError(worker.fault, field="bus", value=self.bus.port)
            return
        if alerts:
            named = dict(zip(self.arm.servo_ids, self.arm.joint_names, strict=True))
            which = "; ".join(f"servo {i} ({named.get(i, '?')}): {describe_hardware_error(e)}"
                              for i, e in sorted(alerts.items()))
            raise HardwareAlertError(f"hardware error on {which}: the servo has switched its "
                                     "torque off; clear it with a reboot (POST /v1/reboot)",
                                     field="bus", value={str(i): e for i, e in alerts.items()})

    def _read_alerts(self) -> dict[int, int]:
        with self.bus.claim():
            return {i: e for i, e in self.bus.hardware_errors().items() if e}

    def present_ticks(self) -> NDArray[np.int64]:
        """The arm's Present Position (k,) ticks, read once on the worker thread.

        Raises BusyError while a move is queued or running (the arm is not where it will
        start from), BusError when the servos do not answer.
        """
        with self._lock:
            self._check_free()
        return self._worker.call(self._read_ticks, "reading the arm's position")

    def present_joints(self) -> NDArray[np.float64]:
        """The arm's present joint angles (k,) rad (:meth:`present_ticks` converted)."""
        ticks = self.present_ticks()
        return servo_units.ticks_to_radians(ticks[None, :], self.arm.servos)[0]

    def recording(self, move_id: str) -> list[tuple[float, tuple[int, ...]]] | None:
        """What a move measured so far, one row per feedback read (:meth:`MoveRecord.
        recording`: s since its first sample, present ticks), or None for an unknown move
        (robodcn.workflow.record turns them into JSON or CSV)."""
        with self._lock:
            record = self._moves.get(str(move_id))
        return None if record is None else record.recording()

    # -- servo admin ----------------------------------------------------------------------------

    def _admin(self, fn: Any, what: str, timeout: float | None = None) -> Any:
        """Run an admin job on the worker thread, refused (BusyError) while a move runs."""
        with self._lock:
            self._check_free()

        def job() -> Any:
            with self.bus.claim():
                return fn()

        return self._worker.call(job, what, timeout)

    def set_torque(self, on: bool, joint: str | None = None, *,
                   confirm: bool = False) -> TorqueAnswer:
        """Torque on (holding where the arm is) or off, for ``joint`` or every joint
        (:func:`robodcn.servo_admin.set_torque`: torque off on an arm under gravity needs
        ``confirm``, GravityReleaseError 409 otherwise, and lowers the arm to its rest pose
        first).

        Raises InputError for an unknown joint or a non-boolean ``on``/``confirm``,
        BusyError while a move runs, BusError (a lowering that ended in a fault: torque
        stays on)."""
        servo_admin.check_torque(self.arm, on, joint, confirm)  # refused before the bus
        return self._releasing(lambda: servo_admin.set_torque(
            self.bus, self.arm, on, joint, confirm=confirm,
            execute_options=self._release_options()))

    def _release_options(self) -> dict[str, Any]:
        """The execute options of a lowering before torque off: the service's clock,
        compensation and tracking limit, and a stop signal :meth:`stop` requests."""
        signal = StopSignal()
        with self._lock:
            self._lowering = signal
        options = self.execute_options
        return {"compensation": options.compensation, "tracking_limit": options.tracking_limit,
                "clock": options.clock, "stop": signal}

    def _releasing(self, job: Any) -> Any:
        """``job`` (a guarded torque off or reboot, which may lower the arm first) on the
        worker thread; :meth:`stop` stops its lowering meanwhile."""
        try:
            return self._admin(job, "releasing the arm", timeout=servo_admin.RELEASE_TIMEOUT)
        finally:
            with self._lock:
                self._lowering = None

    def gripper(self, command: str | None = None, *,
                width_m: float | None = None) -> GripperResult:
        """Drive the arm's ``[gripper]`` to ``command`` ("open" | "close") or a jaw width
        ``width_m`` (m) and wait until the jaws rest (:func:`robodcn.servo_admin.gripper`).

        Raises InputError (field "gripper": the arm has none; "command" or "width_m": a
        bad goal), all before the bus; BusyError while a move runs; BusError."""
        servo_admin.gripper_goal(self.arm, command, width_m)  # refused before the bus
        halt = servo_admin.Halt()  # what a stop sets: the jaws halt where they are
        with self._lock:
            self._halts.add(halt)
        try:
            return self._admin(lambda: servo_admin.gripper(self.bus, self.arm, command,
                                                           width_m, halt),
                               "driving the gripper", timeout=servo_admin.GRIPPER_TIMEOUT)
        finally:
            with self._lock:
                self._halts.discard(halt)
            halt.ended.set()  # a job refused or failed before it ran: nothing to wait for

    def reboot(self, joint: str | None = None, *, confirm: bool = False) -> RebootAnswer:
        """Reboot ``joint``'s servo, or every servo (clears hardware errors; torque is off
        afterwards, so on an arm under gravity it needs ``confirm`` and lowers the arm to
        its rest pose first: :func:`robodcn.servo_admin.reboot`)."""
        servo_admin.check_torque(self.arm, False, joint, confirm)  # refused before the bus
        return self._releasing(lambda: servo_admin.reboot(
            self.bus, self.arm, joint, confirm=confirm,
            execute_options=self._release_options()))

    def _read_ticks(self) -> NDArray[np.int64]:
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
        self._worker.shutdown()

    def __enter__(self) -> ArmController:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


__all__ = ["DEFAULT_EXECUTE", "DEVICE_ERRORS", "RECORD_SAMPLES", "STATE_TIMEOUT",
           "ArmController", "MoveRecord", "move_status"]
