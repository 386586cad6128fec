"""A running execution: the stream on a thread, and the online operations applied to it.

``start(trajectory, bus, options)`` runs :func:`robodcn.stream.execute` on its own thread and
returns an :class:`Execution` at once (:func:`prepare`: not started, :meth:`Execution.run`
streams on the calling thread). The execution's sample source is an
:class:`~robodcn.stream.online.samples.OnlineSamples` chain: each operation plans a new
tail from the commanded state at a switch sample a few periods ahead and swaps it in before
the loop gets there (:mod:`robodcn.stream.online.switch`). Operations (thread-safe, from
any thread): :meth:`Execution.stop` (``"smooth"``: brake along the path, then hold;
``"hold"``: hold at once), :meth:`Execution.pause` / :meth:`Execution.resume`
(:mod:`~robodcn.stream.online.stop`), :meth:`Execution.set_speed`
(:mod:`~robodcn.stream.online.speed`) and :meth:`Execution.retarget`
(:mod:`~robodcn.stream.online.retarget`).

On an arm with torque limits (``max_torque_nm``) every law keeps |τ| ≤ τ_max on every joint
at every sample (the rigid-body inverse dynamics with the move's ``payload_kg``, default the
arm's: :class:`~robodcn.path_timing.torque.TorqueLimits` in the :class:`Timing`'s limits).
On an arm with jerk limits every law keeps them too, across the switch: the brake ramps
the path acceleration within the jerk bound, the re-timing starts from (σ̇, σ̈), and every
new tail is checked with the three samples before it. A retarget under jerk limits goes
through rest. Where the present path ends before a brake could stop, the move's own end is
the stop.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.bus import ServoBus
from robodcn.config import Arm
from robodcn.errors import InputError, RobodcnError
from robodcn.path_timing import JointLimits
from robodcn.path_timing.tool import ToolLimits
from robodcn.planner import PlanRequest, Trajectory, keepout
from robodcn.planner.path import user_pose
from robodcn.planner.validate import tool_limits
from robodcn.stream.online.counts import report_from
from robodcn.stream.online.planning_times import RETARGET_TO_DURATION, PlanningTimes
from robodcn.stream.online.retarget import Retargeting
from robodcn.stream.online.samples import OnlineSamples, Segment
from robodcn.stream.online.speed import KeepPlanned, resume_tail, speed_scale, speed_tail
from robodcn.stream.online.state import State
from robodcn.stream.online.stop import PathEnds, PauseKeeper, brake_to_rest, pause_hold
from robodcn.stream.online.switch import Switch, Switcher, SwitchMissed
from robodcn.stream.online.timing import Timing
from robodcn.stream.online_path import JointPath, brake_checked, retime
from robodcn.stream.options import ExecutionOptions
from robodcn.stream.report import ExecutionReport
from robodcn.stream.signal import StopSignal
from robodcn.stream.streamer import execute

log = logging.getLogger("robodcn.stream")

#: stop modes of :meth:`Execution.stop`
STOP_MODES = ("smooth", "hold")
#: GIL switch interval while an online execution streams (s)
SWITCH_INTERVAL_S = 0.0002
#: planning beside a running stream (which shares the interpreter) takes about this many
#: times as long as the warm-up's, before it: the first switches are placed from that
STREAM_SHARE = 2.0
#: how long an operation waits for the stream to start (s)
ATTACH_TIMEOUT_S = 10.0


def warm_up(trajectory: Trajectory, arm: Arm | None, planning_times: PlanningTimes) -> None:
    """Pay the first calls of the online laws before a stream starts: a re-timing and a
    brake on the plan's path, and (once per ``planning_times``) a retarget from the path's
    middle to its end, as fast as the limits allow and to a numeric duration, through the
    same code an operation runs (numpy's and the planner's first calls cost several times a
    later one's). Their times, × :data:`STREAM_SHARE`, are what the first retargets are
    placed from until one is measured (:meth:`PlanningTimes.seed`): a fixed first guess
    missed on a slow arm's path (the omx's 60 ms against 30), and every miss is planned
    again, on a loaded host past an operation's budget."""
    if arm is None:
        return
    limits = JointLimits.of(arm)
    rate = trajectory.rate_hz
    path, sigma = JointPath.of_samples(trajectory.joints)
    if path.length <= 0:
        return
    mid = float(sigma[len(sigma) // 2])
    try:
        retime(path, mid, 0.0, limits, rate)
        brake_checked(path, mid, 1e-3, limits.a, rate, limits.torque)
    except RobodcnError as exc:
        # a warm-up only pays first calls: it never fails the move it precedes
        log.debug("warm-up: re-timing the plan's path from s = %.3g refused: %s", mid, exc)
    q = trajectory.joints
    i = len(q) // 2
    if planning_times.warmed or limits.j is not None or i < 2:
        return
    planning_times.warmed = True
    state = State.of_history(i, q[i - 2:i + 1], path, float(sigma[i]), rate)
    end = tuple(float(v) for v in user_pose(arm, q[-1:])[0])
    try:
        took = time.perf_counter()
        tail = Retargeting(arm, Timing(limits, rate), None).tail(state, [None, end], {})
        took = time.perf_counter() - took
        planning_times.seed("retarget", False, STREAM_SHARE * took)
        # and one to a numeric duration (fitted in rounds: its own placement)
        duration = round(1.5 * sum(len(seg[0]) for seg in tail) / rate + 0.1, 2)
        took = time.perf_counter()
        Retargeting(arm, Timing(limits, rate), None).tail(state, [None, end],
                                                          {"duration": duration})
        took = time.perf_counter() - took
        planning_times.seed(RETARGET_TO_DURATION, False, STREAM_SHARE * took)
    except RobodcnError as exc:
        log.debug("warm-up: retarget from the path's middle refused: %s", exc)


class Execution:
    """A running execution (:func:`start`); every method is thread-safe.

    Attributes
    ----------
    status : "starting" | "running" | "paused" | "stopping" | "finished"
    speed : the present speed scale k (1: the plan's limits)
    paused : True while paused (or braking into a pause)
    report : the :class:`ExecutionReport` once finished (None before)
    error : the exception :func:`execute` raised (a refusal before any write), or None
    planning_times : the :class:`PlanningTimes` that places the switches (shared when the
        creator passed one)
    on_change : called with the operation's name after each switch (or None)
    budget_s : seconds an operation may spend planning, its attempts and the wait for
        another operation included: an attempt expected to end later is not started
        (:class:`~robodcn.stream.online.switch.SwitchMissed`, nothing changed). None (the
        default): no bound; a service sets one so every answer comes within a second.
    """

    def __init__(self, trajectory: Trajectory, bus: ServoBus, stop: StopSignal,
                 arm: Arm | None = None, *, options: ExecutionOptions | None = None,
                 planning_times: PlanningTimes | None = None,
                 present_ticks: ArrayLike | None = None) -> None:
        self.trajectory = trajectory
        self.bus = bus
        self.arm = arm if arm is not None else (
            trajectory.request.arm if trajectory.request is not None else None)
        self.stop_signal = stop
        self.status = "starting"
        self.speed = 1.0
        self.paused = False
        self.report: ExecutionReport | None = None
        self.error: BaseException | None = None
        self.on_change: Callable[[str], None] | None = None
        self.budget_s: float | None = None
        self.planning_times = planning_times if planning_times is not None else PlanningTimes()
        self._present_ticks = present_ticks
        self._smooth_stopped = False
        self._lock = threading.RLock()
        self._attached = threading.Event()
        self._done = threading.Event()
        self._stream: Any = None
        self._switcher: Switcher | None = None
        self._timing: Timing | None = None
        #: a retarget's time laws when it was told another payload (set while planning it)
        self._told: Timing | None = None
        self._thread: threading.Thread | None = None
        opts = ExecutionOptions.build(options)
        self._options = ExecutionOptions.build(opts, {"stop": stop, "attach": self._attach})

    # -- lifecycle ------------------------------------------------------------------------

    def _attach(self, stream: Any) -> None:
        """Called by the streamer before the first sample: take over its source."""
        planned = stream.source
        root = OnlineSamples.of_planned(planned, self.bus)
        stream.swap(root)
        if self.arm is None and planned.trajectory.request is not None:
            self.arm = planned.trajectory.request.arm
        if self.arm is not None:
            limits = JointLimits.of(self.arm, self._payload(planned.trajectory))
            tool = self._tool(planned.trajectory)
            if tool is not None:  # the move's tool_speed …: every online law keeps them
                limits = dataclasses.replace(limits, tool=tool)
            self._timing = Timing(limits, root.rate_hz)
            self._timing.register_law(root.path, root.sigma, 1.0)
            self._switcher = Switcher(stream, self.bus, self._timing, self.planning_times,
                                      self._done, self._lock)
        self._stream = stream
        self.status = "running"
        self._attached.set()

    def _payload(self, trajectory: Trajectory) -> float | None:
        """The payload the online laws' torque limits carry: the move's request's
        ``payload_kg`` (None without a request: the arm's)."""
        request = trajectory.request if trajectory.request is not None else (
            self.trajectory.request)
        return None if request is None else request.payload_kg

    def _tool(self, trajectory: Trajectory) -> ToolLimits | None:
        """The tool limits the online laws keep: the move's request's (None without a
        request or without any)."""
        request = trajectory.request if trajectory.request is not None else (
            self.trajectory.request)
        return None if request is None else tool_limits(request)

    def run(self) -> ExecutionReport | None:
        """Stream on the calling thread until the end (:func:`prepare`); the report, or
        raise what :func:`execute` raised."""
        # Planning runs on other threads while this one streams: a short GIL switch
        # interval keeps the loop's wake-ups on time (the default 5 ms is five periods).
        interval = sys.getswitchinterval()
        sys.setswitchinterval(min(interval, SWITCH_INTERVAL_S))
        try:
            report = execute(self.trajectory, self.bus, self._options,
                             present_ticks=self._present_ticks)
            if self._smooth_stopped and report.stop_reason == "completed":
                report = dataclasses.replace(
                    report, stop_reason="stopped",
                    message="stopped smoothly along the path (decelerated within the limits)")
            log.info("%s", report.headline)
            self.report = report
        except BaseException as exc:  # reported through .error and wait()
            self.error = exc
        finally:
            sys.setswitchinterval(interval)
            self.status = "finished"
            self.paused = False
            self._attached.set()
            self._done.set()
        return self.wait(0)

    def wait(self, timeout: float | None = None) -> ExecutionReport | None:
        """Block until finished (or ``timeout``); the report, or raise what execute raised."""
        self._done.wait(timeout)
        if self.error is not None:
            raise self.error
        return self.report

    @property
    def done(self) -> bool:
        return self._done.is_set()

    @property
    def stream(self) -> Any:
        """The streaming loop (:class:`~robodcn.stream.loop.Stream`) once attached."""
        return self._stream

    @property
    def switches(self) -> list[Switch]:
        """(request time, first changed sample, its due time, planning seconds, the planning
        time the switch was placed for) of every operation applied, on the stream's clock
        (planning seconds: real time), for latency measurements."""
        return [] if self._switcher is None else list(self._switcher.switches)

    @property
    def sample(self) -> int:
        """Index of the last sample sent (−1 before the first)."""
        return -1 if self._stream is None else self._stream.records.last_index()

    def sent(self) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """Every sample sent so far: indices, send times (the stream's clock) and the
        commanded joints (rad, before rounding to ticks)."""
        s = self._stream
        if s is None:
            return np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 0))
        n = s.records.count
        index = np.array(s.records.index[:n], dtype=np.int64)
        src = s.source
        joints = np.array([src.joint(int(i)) for i in index]) if n else np.zeros((0, 0))
        return index, np.array(s.records.at[:n]), joints

    def latencies(self) -> list[tuple[float, float, float, float]]:
        """Per operation applied: (planning s, request → due time of the first changed
        sample s, request → that sample actually sent s, the planning time the switch was
        placed for s). Sent − due is the loop's own lateness at that moment (a loaded
        machine); due ≈ placed-for + 2 periods."""
        index, at, _ = self.sent()
        out = []
        for requested, first, due, took, ahead in self.switches:
            hit = np.flatnonzero(index >= first)
            if hit.size:
                out.append((took, due - requested, float(at[hit[0]] - requested), ahead))
        return out

    def remaining(self, first: int, request: PlanRequest | None = None) -> Trajectory:
        """The commanded samples from ``first`` to the end as a Trajectory (t from 0): what a
        retarget put in place, for records and reports."""
        src: OnlineSamples = self._stream.source
        end = max(first + 1, src.end)
        index = range(first, end)
        joints = np.array([src.joint(i) for i in index])
        ticks = np.array([src.goal(i) for i in index])
        poses = user_pose(self.arm, joints)
        poses[:, -1] = np.unwrap(poses[:, -1])
        method = request.method if request is not None else "sclerp"
        if isinstance(method, tuple):
            method = list(method)
        return Trajectory(np.arange(len(joints)) / src.rate_hz, poses, joints, ticks,
                          src.joint_names, tuple(self.bus.ids), src.rate_hz, method, request)

    # -- applying an operation ------------------------------------------------------------

    @contextlib.contextmanager
    def _turn(self, what: str) -> Iterator[float]:
        """Hold the execution's lock for one operation ``what``, waited for :attr:`budget_s`
        at most (then SwitchMissed: nothing changed); yields when it was asked
        (``time.perf_counter``), which the budget counts from."""
        asked = time.perf_counter()
        if not self._lock.acquire(timeout=-1 if self.budget_s is None else self.budget_s):
            raise SwitchMissed(what, self.status, "another operation was being planned")
        try:
            yield asked
        finally:
            self._lock.release()

    def _apply(self, what: str, tail: Callable[[State], list[Segment]], *,
               hold: int = 0, measure: str | None = None, asked: float | None = None) -> int:
        """Plan ``tail`` at a switch ahead of the loop and swap it in (:class:`Switcher`;
        its planning measured as ``measure``, default ``what``; ``asked``: when the
        operation was asked, ``time.perf_counter``, default now); the first changed sample.
        InputError when the execution is not running;
        :class:`~robodcn.stream.online.switch.SwitchMissed` when no attempt landed (within
        :attr:`budget_s` from ``asked``)."""
        requested = self._options.clock.now()
        if not self._attached.wait(ATTACH_TIMEOUT_S) or self.done or self._switcher is None:
            raise InputError(f"cannot {what}: the execution is not running",
                             field="execution", value=self.status)
        first = self._switcher.apply(what, tail, requested=requested, hold=hold,
                                     speed=self.speed, status=self.status, measure=measure,
                                     budget=self.budget_s, asked=asked)
        if self.on_change is not None:
            self.on_change(what)
        return first

    def _need_arm(self, what: str) -> Timing | None:
        """The time laws (None before the stream started); InputError without an arm."""
        if self.arm is None and self._timing is None:
            raise InputError(f"cannot {what}: the trajectory carries no arm (plan it with "
                             "robodcn.plan or pass arm=)", field="arm", value=None)
        return self._timing

    def _laws(self) -> Timing:
        assert self._timing is not None
        return self._timing

    # -- operations -----------------------------------------------------------------------

    def stop(self, mode: str = "smooth", reason: str = "stop requested") -> None:
        """Stop: ``"smooth"`` brakes along the path then holds; ``"hold"`` holds at once."""
        if mode not in STOP_MODES:
            raise InputError(f"mode must be one of {', '.join(STOP_MODES)}, got {mode!r}",
                             field="mode", value=mode)
        if mode == "hold" or self.done or self._stream is None or self._timing is None:
            self.stop_signal.request(reason)
            return
        self.paused = False
        self._smooth_stopped = True
        self.status = "stopping"
        try:
            self._apply("stop smoothly", lambda st: brake_to_rest(self._laws(), st))
        except PathEnds:
            log.info("smooth stop: the move's own end is the fastest stop")
        except RobodcnError:
            self.stop_signal.request(reason)

    def pause(self) -> bool:
        """Brake along the path to rest and stay there (the stream goes on). Whether the
        move is paused as this turn ends (False: it reaches its own end first) — read in
        the turn, so a resume another thread asks right after cannot change the answer."""
        self._need_arm("pause")
        with self._turn("pause") as asked:
            if self.paused:
                return True
            rate = self._stream.source.rate_hz if self._stream else 1.0
            try:
                self._apply("pause", lambda st: brake_to_rest(self._laws(), st),
                            hold=pause_hold(rate), asked=asked)
            except PathEnds:
                log.info("pause: the move ends before a brake could stop it")
                return False
            self.paused = True
            self.status = "paused"
        assert self._switcher is not None
        PauseKeeper(self._switcher, lambda: self.paused, self._done)
        return True

    def resume(self) -> None:
        """Continue the same path from where the pause left it, timed from there."""
        self._need_arm("resume")
        with self._turn("resume") as asked:
            if not self.paused:
                return
            self.paused = False
            k = self.speed
            try:
                self._apply("resume", lambda st: resume_tail(self._laws(), st, k),
                            asked=asked)
            except KeepPlanned as exc:
                log.info("resume: %s; the held end of the path stands", exc.reason)
            self.status = "running"

    def set_speed(self, scale: float) -> None:
        """Re-time the rest of the path with the limits scaled by ``scale`` ∈ (0, 1].

        Near the end, where the move already brakes to its end at the full limits and no
        brake reaches the scaled ones first, the move ends as planned (``speed`` is still
        set: a resume uses it)."""
        k = speed_scale(scale)
        self._need_arm("change speed")
        with self._turn("change speed") as asked:
            self.speed = k
            if self.paused or self.status == "stopping" or self.done:
                return
            try:
                self._apply("change speed", lambda st: speed_tail(self._laws(), st, k),
                            asked=asked)
            except KeepPlanned as exc:
                log.info("speed %.3g: %s; the move ends as planned", k, exc.reason)

    def retarget(self, target: PlanRequest | Sequence[ArrayLike | None],
                 **plan_options: Any) -> int:
        """Replace the rest of the motion by a path to ``target``, from the commanded moving
        state (:mod:`~robodcn.stream.online.replacement`): it never visits the first of two
        or more waypoints (the caller's view of where the arm is); one waypoint is the goal
        from the present state; in a list a first None is the switch pose.

        ``target``: a PlanRequest (every plan field honoured: method, β, turn, blend,
        elbow, ``duration`` from the switch; or refused, InputError naming it: a uniform
        ``profile``, another ``rate_hz``, ``start_joints``, ``start_state``) or waypoints
        with ``plan_options`` (keywords of :func:`robodcn.plan`, the same rules). Returns
        the first changed sample; :meth:`report_from` it gives the new move's counts.
        Raises the planner's errors (nothing changes)."""
        self._need_arm("retarget")
        with self._turn("retarget") as asked:
            self.paused = False
            self._told = None
            first = self._apply("retarget", lambda st: self._retarget_tail(st, target,
                                                                           plan_options),
                                measure=_measured_as(target, plan_options), asked=asked)
            if self._told is not None:
                # the replacement was told another payload: the operations after it too
                self._timing = self._told
            self.status = "running"
            return first

    def report_from(self, first: int) -> ExecutionReport | None:
        """The report of the move that began at sample ``first`` (a retarget's first changed
        sample; 0: the whole stream): its own samples' counts (:func:`~robodcn.stream.
        online.counts.report_from`). None before the stream has ended."""
        if self.report is None or self._stream is None or first <= 0:
            return self.report
        return report_from(self.report, self._stream, first)

    def _retarget_tail(self, state: State, target: Any,
                       plan_options: dict[str, Any]) -> list[Segment]:
        """The new samples of a retarget from ``state`` (:class:`Retargeting`)."""
        assert self.arm is not None
        retargeting = Retargeting(self.arm, self._laws(), self._stream.source, self.speed)
        segments = retargeting.tail(state, target, plan_options)
        if segments:  # the moving start's blend or brake leaves the planned path: keep out
            # (from the switch state: sample 0 is the commanded joints there)
            keepout.check_joints(self.arm, np.vstack([state.q[None], *(seg[0] for seg in
                                                                       segments)]),
                                 retargeting.timing.rate)
        self._told = retargeting.timing if retargeting.timing is not self._timing else None
        return segments


def _measured_as(target: Any, plan_options: dict[str, Any]) -> str:
    """The planning times a retarget to ``target`` is placed from: those of a retarget to a
    numeric duration (its law fitted in rounds) or of one as fast as the limits allow."""
    duration = target.duration if isinstance(target, PlanRequest) else plan_options.get(
        "duration", "auto")
    return "retarget" if duration == "auto" else RETARGET_TO_DURATION


def prepare(trajectory: Trajectory, bus: ServoBus, options: ExecutionOptions | None = None,
            *, arm: Arm | None = None, planning_times: PlanningTimes | None = None,
            present_ticks: ArrayLike | None = None, **kwargs: Any) -> Execution:
    """An :class:`Execution` of ``trajectory`` not yet started: :meth:`Execution.run` streams
    it on the calling thread (a service's bus worker), :func:`start` on a thread of its own.

    Options as :func:`robodcn.stream.execute` (the stop signal is the execution's: one is
    made when none is given; ``present_ticks`` as there). ``planning_times``: where the
    switches are placed from — pass one :class:`PlanningTimes` to every execution of a
    process so each places its first operations from measurements (default: a new one)."""
    opts = ExecutionOptions.build(options, kwargs)
    stop = opts.stop if isinstance(opts.stop, StopSignal) else StopSignal()
    execution = Execution(trajectory, bus, stop, arm, options=opts,
                          planning_times=planning_times, present_ticks=present_ticks)
    warm_up(trajectory, execution.arm, execution.planning_times)
    return execution


def start(trajectory: Trajectory, bus: ServoBus, options: ExecutionOptions | None = None,
          *, arm: Arm | None = None, planning_times: PlanningTimes | None = None,
          present_ticks: ArrayLike | None = None, **kwargs: Any) -> Execution:
    """Start streaming ``trajectory`` on its own thread; the :class:`Execution` at once.

    Same options as :func:`prepare`. Refusals before the first write are raised by
    :meth:`Execution.wait` (and kept in ``Execution.error``)."""
    execution = prepare(trajectory, bus, options, arm=arm, planning_times=planning_times,
                        present_ticks=present_ticks, **kwargs)
    thread = threading.Thread(target=execution.run, daemon=True, name="robodcn-stream")
    execution._thread = thread
    thread.start()
    return execution


__all__ = ["STOP_MODES", "Execution", "prepare", "start", "warm_up"]
