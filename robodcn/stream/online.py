"""Online execution: a running stream's path re-timed or replaced while it runs.

``start(trajectory, bus, options)`` runs :func:`robodcn.stream.execute` on its own thread and
returns an :class:`Execution` at once. The execution's sample source is an
:class:`OnlineSamples` chain: each operation plans a new tail from the commanded state at a
switch sample a few periods ahead (joint position, velocity and acceleration as streamed,
finite differences of the goals) and swaps it in before the loop gets there, so no sample
is left out or sent twice (:meth:`_Streamer.swap`). Operations (thread-safe, from any
thread):

* :meth:`Execution.stop` — ``"smooth"``: the fastest brake along the present path
  (:func:`robodcn.stream.online_path.brake`), then the arm holds the last goal; ``"hold"``:
  the stop signal, the arm holds where it is at once (as :func:`execute` always did).
* :meth:`Execution.pause` — a smooth stop that keeps the stream alive (the last goal is
  repeated); :meth:`Execution.resume` times the rest of the same path from there.
* :meth:`Execution.set_speed` — re-times the rest of the path with the limits scaled
  (v·k, a·k², j·k³, as ros2_controllers' joint_trajectory_controller speed_scaling), after a
  brake along the path if the present speed is over what the scaled limits allow.
* :meth:`Execution.retarget` — a new path from the switch pose to new waypoints (the
  planner's geometry, bent at its start to the present direction of motion:
  :func:`~robodcn.stream.online_path.blend_start`), timed time-optimally from the moving
  state (TOPP-RA, :func:`robodcn.path_timing.time_optimal`).

On an arm with jerk limits (``max_jerk_deg_s3``) every law keeps them too, across the
switch: the brake is :func:`~robodcn.stream.online_path.brake_jerk` (from the commanded path
acceleration σ̈ at the switch, ramping it within the jerk bound), the re-timing starts from
(σ̇, σ̈) under the jerk limits, and every new tail is checked with the three samples before
it (finite-difference velocity, acceleration and jerk). A speed change the jerk limits
cannot join to the moving state brakes to rest and re-times from there. A retarget under
jerk limits always goes through rest: it brakes to rest along the present path and leaves
from there (:meth:`Execution._retarget_through_rest`; why in :meth:`_retarget_tail`).
Where the present path ends before a brake could stop, the move's own end is the stop.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import sys
import threading
import time
import types
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import kinematics, servo_units
from robodcn.bus import ServoBus
from robodcn.errors import (
    AccelerationLimitError,
    InputError,
    RobodcnError,
    VelocityLimitError,
)
from robodcn.planner import PlanRequest, Trajectory

try:  # planning from a moving state in the planner (profile "optimal")
    from robodcn.planner import StartState
except ImportError:  # pragma: no cover - a planner without it: the own retarget only
    StartState = None  # type: ignore[assignment,misc]
from robodcn.stream.online_path import (
    RETIME_SHARE,
    JointPath,
    Limits,
    blend_start,
    brake,
    brake_jerk_checked,
    check_limits_named,
    controllable_speed,
    evenly_spaced,
    retime,
)
from robodcn.stream.options import ExecutionOptions
from robodcn.stream.report import ExecutionReport
from robodcn.stream.signal import StopSignal

log = logging.getLogger("robodcn.stream")

#: stop modes of :meth:`Execution.stop`
STOP_MODES = ("smooth", "hold")
#: samples of rest a paused stream keeps ahead of itself (extended while paused)
PAUSE_AHEAD_S = 1.0
#: geometry of a retarget: sampled at this rate over this many seconds (quintic, slow)
GEOMETRY_RATE_HZ = 200.0
GEOMETRY_DURATION_S = 5.0
#: arc-length samples a jerk-limited retarget keeps of that geometry
GEOMETRY_SAMPLES = 400
#: reachability stages of the quick checks while choosing a retarget's start blend
SEARCH_STAGES = 200
#: attempts of an online operation before "the stream ran ahead of planning"; after a miss
#: the switch is placed this many times further ahead than the miss measured
SWITCH_TRIES = 8
SWITCH_MARGIN = 1.5
#: re-timings tried by a speed change or resume, braking further between them
RETIME_TRIES = 8
#: GIL switch interval while an online execution streams (s)
SWITCH_INTERVAL_S = 0.0002
#: first guesses of the planning time of each operation on a jerk-limited arm (s): its
#: laws take longer, and a first switch placed too close is planned twice
JERK_PLAN_S = {"retarget": 0.12, "stop smoothly": 0.03, "pause": 0.03, "resume": 0.1,
               "change speed": 0.15}
#: rest a retarget's end keeper keeps ahead of the loop while the retarget plans (s)
KEEP_AHEAD_S = 0.1


#: planning times of this process's last operations, per operation and kind of arm (jerk
#: limits or not): a new execution places its first switches from them instead of a guess
_SEEN_PLAN_S: dict[tuple[str, bool], list[float]] = {}
_SEEN_LOCK = threading.Lock()
#: set once a retarget was planned in this process (the first one pays the planner's and
#: numpy's first-call costs: :meth:`Execution.warm_up` pays them before a stream starts)
_RETARGET_WARM = threading.Event()


class _EndKeeper:
    """While a retarget plans, the present move's end (at rest) is held on: the source is
    extended by repeats of its last goal whenever less than :data:`KEEP_AHEAD_S` of it is
    left, so a retarget that takes longer than the move has left leaves from its end
    instead of finding the stream finished."""

    def __init__(self, execution: Execution, streamer: Any) -> None:
        self.execution = execution
        self.streamer = streamer
        self.stopped = False
        self._thread = threading.Thread(target=self._run, daemon=True, name="robodcn-keep")

    def __enter__(self) -> _EndKeeper:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        with self.execution._swap_lock:
            self.stopped = True
        self._thread.join()

    def _run(self) -> None:
        ex, streamer = self.execution, self.streamer
        while True:
            with ex._swap_lock:
                if self.stopped or ex.done or streamer.t_end != 0.0:
                    return
                src: OnlineSamples = streamer.source
                rate = src.rate_hz
                if len(src) - ex.sample < KEEP_AHEAD_S * rate:
                    streamer.swap(src.held(src.hold + math.ceil(2 * KEEP_AHEAD_S * rate)))
            time.sleep(KEEP_AHEAD_S / 10)


class _PlanEnds(Exception):
    """The present path ends before a jerk-limited brake could stop: its end is the stop."""


class OnlineSamples:
    """A sample source whose tail an online operation replaces (stream/source.py protocol).

    Samples i < ``switch`` are ``prev``'s; samples switch … switch + m − 1 are this node's
    joints (m, k) on ``path`` at arc lengths ``sigma``; after them the last goal repeats
    ``hold`` times (a pause). Any index past the end answers the last goal, so a loop that
    still has an older, longer bound never reads outside."""

    def __init__(self, prev: OnlineSamples | None, switch: int, joints: NDArray[np.float64],
                 sigma: NDArray[np.float64], path: JointPath, bus: ServoBus, rate_hz: float,
                 joint_names: Sequence[str], *, ticks: NDArray[np.int64] | None = None,
                 encoded: list | None = None, hold: int = 0,
                 lead: Callable[[NDArray[np.float64]], NDArray[np.int64] | None] | None = None
                 ) -> None:
        self.prev = prev
        self.switch = int(switch)
        self.joints = np.asarray(joints, dtype=np.float64)
        self.sigma = np.asarray(sigma, dtype=np.float64)
        self.path = path
        self.bus = bus
        self.rate_hz = float(rate_hz)
        self.period = 1.0 / self.rate_hz
        self.joint_names = tuple(joint_names)
        if ticks is None:
            ticks = servo_units.radians_to_ticks(self.joints, bus.servos)
            bus.check_ticks(ticks)
        self.ticks = np.asarray(ticks, dtype=np.int64)
        #: the goals the servos need to follow the joints (tracking compensation, as the
        #: plan's: :meth:`robodcn.stream.source.PlannedSamples.commanded_for`), or None
        self.lead = lead if lead is not None else (None if prev is None else prev.lead)
        self.compensated = self.lead is not None
        if encoded is None:
            encoded = bus.encode_goals(self._commanded())
        self._encoded = encoded
        self.hold = int(hold)
        self._own = len(self.ticks)

    def _commanded(self) -> NDArray[np.int64]:
        """What is sent for this node's joints: the plan's ticks, or with a lead the
        compensated goals, from finite differences that start at the two samples before
        the switch (no step in the lead where the tail begins)."""
        if self.lead is None:
            return self.ticks
        before = [self.prev.joint(i) for i in range(max(0, self.switch - 2), self.switch)] \
            if self.prev is not None else []
        joints = np.vstack([*before, self.joints]) if before else self.joints
        commanded = self.lead(joints)
        return self.ticks if commanded is None else commanded[len(before):]

    @classmethod
    def of_trajectory(cls, trajectory: Trajectory, bus: ServoBus,
                      encoded: list | None = None,
                      lead: Callable[[NDArray[np.float64]], NDArray[np.int64] | None]
                      | None = None) -> OnlineSamples:
        """The root of a chain: the planned samples (``encoded``: as the streamer encoded
        them; ``lead``: how a tail's goals are compensated, None to send the joints)."""
        path, sigma = JointPath.of_samples(trajectory.joints)
        return cls(None, 0, trajectory.joints, sigma, path, bus, trajectory.rate_hz,
                   trajectory.joint_names, ticks=trajectory.ticks, encoded=encoded, lead=lead)

    def held(self, hold: int) -> OnlineSamples:
        """This source with ``hold`` repeats of its last goal (shares every array)."""
        return OnlineSamples(self.prev, self.switch, self.joints, self.sigma, self.path,
                             self.bus, self.rate_hz, self.joint_names, ticks=self.ticks,
                             encoded=self._encoded, hold=hold, lead=self.lead)

    def __len__(self) -> int:
        return self.switch + self._own + self.hold

    def _node(self, i: int) -> tuple[OnlineSamples, int]:
        node = self
        while i < node.switch and node.prev is not None:
            node = node.prev
        return node, min(max(i - node.switch, 0), node._own - 1)

    def goal(self, i: int) -> NDArray[np.int64]:
        node, j = self._node(i)
        return node.ticks[j]

    def encoded(self, i: int) -> Sequence[Sequence[int]]:
        node, j = self._node(i)
        return node._encoded[j]

    def joint(self, i: int) -> NDArray[np.float64]:
        """Commanded joints (k,) rad of sample i (before rounding to ticks)."""
        node, j = self._node(i)
        return node.joints[j]

    def path_at(self, i: int) -> tuple[JointPath, float]:
        """The path sample i lies on and its σ there."""
        node, j = self._node(i)
        return node.path, float(node.sigma[j])

    @property
    def end(self) -> int:
        """Index after this node's own samples (where a hold begins)."""
        return self.switch + self._own


#: new samples on one path: joints (m, k), their σ (m,), the path
Segment = tuple[NDArray[np.float64], NDArray[np.float64], JointPath]


@dataclasses.dataclass(frozen=True)
class State:
    """The commanded state at sample ``index``: joints q, q̇, q̈ (finite differences of the
    commanded joints), the path it is on, its σ and σ̇ = ‖q̇‖ (arc-length speed)."""

    index: int
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]
    path: JointPath
    sigma: float
    sd: float
    #: σ̈: the commanded acceleration along the direction of motion
    sdd: float = 0.0
    #: the commanded joints (3, k) of samples index − 2 … index (jerk checks across a switch)
    history: NDArray[np.float64] | None = None

    @classmethod
    def of_history(cls, index: int, history: NDArray[np.float64], path: JointPath,
                   sigma: float, rate_hz: float) -> State:
        """The state at the last of three commanded samples (3, k): q̇ and q̈ their backward
        differences at the stream rate, σ̇ = ‖q̇‖, σ̈ = q̈·q̇/σ̇ (along the motion)."""
        q2, q1, q0 = history
        qd = (q0 - q1) * rate_hz
        qdd = (q0 - 2.0 * q1 + q2) * rate_hz * rate_hz
        sd = float(np.linalg.norm(qd))
        sdd = float(qdd @ qd) / sd if sd > 1e-12 else 0.0
        return cls(index, q0, qd, qdd, path, sigma, sd, sdd, np.asarray(history))


class Execution:
    """A running execution (:func:`start`); every method is thread-safe.

    Attributes
    ----------
    status : "starting" | "running" | "paused" | "stopping" | "finished"
    speed : the present speed scale k (1: the plan's limits)
    paused : True while paused (or braking into a pause)
    report : the :class:`ExecutionReport` once finished (None before)
    error : the exception :func:`execute` raised (a refusal before any write), or None
    switches : (request time, first changed sample, its due time, planning seconds, the
        planning time the switch was placed for) of every operation applied (perf_counter
        clock), for latency measurements
    """

    def __init__(self, trajectory: Trajectory, bus: ServoBus, stop: StopSignal,
                 arm: Any = None) -> None:
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
        self.switches: list[tuple[float, int, float, float, float]] = []
        self.on_change: Callable[[str], None] | None = None
        self._smooth_stopped = False
        self._lock = threading.RLock()
        #: the swaps of a retarget's end keeper and the retarget's own (never interleaved)
        self._swap_lock = threading.Lock()
        self._attached = threading.Event()
        self._done = threading.Event()
        self._streamer: Any = None
        self._thread: threading.Thread | None = None
        self._keeper: threading.Thread | None = None
        #: expected planning time of each operation (s): how far ahead its switch is placed
        #: (optimistic: the fastest of the last few; a miss is planned again from further
        #: ahead, and the request's planning time counts both)
        self._plan_s: dict[str, list[float]] = {"retarget": [0.01]}
        self._limits: Limits | None = None if self.arm is None else Limits.of_arm(self.arm)
        if self._limits is not None and self._limits.j is not None:
            self._plan_s = {k: [v] for k, v in JERK_PLAN_S.items()}
        with _SEEN_LOCK:
            for (what, jerk), times in _SEEN_PLAN_S.items():
                if jerk == self._jerk:
                    self._plan_s[what] = list(times)
        self._options = ExecutionOptions()
        #: id(path) → (path, σ midpoints, σ̇ at speed 1) of the first law on each path
        self._laws: dict[int, tuple[JointPath, NDArray, NDArray]] = {}

    def warm_up(self) -> None:
        """Run the re-timing once on the plan's path (first calls pay numpy's set-up), and
        once a process a retarget from its middle to its end (the planner's first calls)."""
        if self._limits is None:
            return
        rate = self.trajectory.rate_hz
        path, sigma = JointPath.of_samples(self.trajectory.joints)
        if path.length <= 0:
            return
        mid = float(sigma[len(sigma) // 2])
        retime(path, mid, 0.0, self._limits, rate)
        brake(path, mid, 1e-3, self._limits.a, rate)
        q = self.trajectory.joints
        i = len(q) // 2
        if _RETARGET_WARM.is_set() or self._jerk or self.arm is None or i < 2:
            return
        _RETARGET_WARM.set()
        state = State.of_history(i, q[i - 2:i + 1], path, float(sigma[i]), rate)
        end = tuple(kinematics.fk(self.arm.links, q[-1:])[0])
        self._streamer = types.SimpleNamespace(period=1.0 / rate,
                                               source=types.SimpleNamespace(rate_hz=rate))
        try:
            # (its time is not a guess for a switch: planning beside a running stream,
            # which shares the interpreter, takes about twice as long)
            self._retarget_tail(state, [None, end], {})
        except RobodcnError:
            pass
        finally:
            self._streamer = None

    def _record_plan_s(self, what: str, took: float) -> None:
        self._plan_s[what] = [*self._plan_s.get(what, [])[-4:], took]
        with _SEEN_LOCK:
            _SEEN_PLAN_S[(what, self._jerk)] = list(self._plan_s[what])

    # -- lifecycle ------------------------------------------------------------------------

    def _attach(self, streamer: Any) -> None:
        """Called by the streamer before the first sample: take over its source."""
        planned = streamer.source
        lead = planned.commanded_for if getattr(planned, "compensated", False) else None
        root = OnlineSamples.of_trajectory(planned.trajectory, self.bus,
                                           encoded=planned._encoded, lead=lead)
        streamer.swap(root)
        self._register_law(root.path, root.sigma, root.rate_hz, 1.0)
        self._streamer = streamer
        if self.arm is None and planned.trajectory.request is not None:
            self.arm = planned.trajectory.request.arm
            self._limits = Limits.of_arm(self.arm)
        self.status = "running"
        self._attached.set()

    def run(self) -> ExecutionReport | None:
        """Stream on the calling thread until the end (:func:`prepare`); the report, or
        raise what :func:`execute` raised."""
        self._run(self.trajectory, self._options)
        return self.wait(0)

    def _run(self, trajectory: Trajectory, opts: ExecutionOptions) -> None:
        from robodcn.stream.streamer import execute
        # Planning runs on other threads while this one streams: a short GIL switch
        # interval keeps the loop's wake-ups on time (the default 5 ms is five periods).
        interval = sys.getswitchinterval()
        sys.setswitchinterval(min(interval, SWITCH_INTERVAL_S))
        try:
            report = execute(trajectory, self.bus, opts)
            if self._smooth_stopped and report.stop_reason == "completed":
                report = dataclasses.replace(
                    report, stop_reason="stopped",
                    message="stopped smoothly along the path (decelerated within the limits)")
            self.report = report
        except BaseException as exc:  # reported through .error and wait()
            self.error = exc
        finally:
            sys.setswitchinterval(interval)
            self.status = "finished"
            self.paused = False
            self._attached.set()
            self._done.set()

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
    def sample(self) -> int:
        """Index of the last sample sent (−1 before the first)."""
        s = self._streamer
        return -1 if s is None or not s.sent else int(s.sent_index[s.sent - 1])

    def sent(self) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """Every sample sent so far: indices, send times (perf_counter) and the commanded
        joints (rad, before rounding to ticks)."""
        s = self._streamer
        if s is None:
            return np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 0))
        n = s.sent
        index = np.array(s.sent_index[:n], dtype=np.int64)
        src = s.source
        joints = np.array([src.joint(int(i)) for i in index]) if n else np.zeros((0, 0))
        return index, np.array(s.sent_at[:n]), joints

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

    # -- the commanded state and the swap -------------------------------------------------

    def _state(self, index: int) -> State:
        src: OnlineSamples = self._streamer.source
        rate = src.rate_hz
        q0 = src.joint(index)
        q1 = src.joint(index - 1) if index > 0 else q0
        q2 = src.joint(index - 2) if index > 1 else q1
        path, sigma = src.path_at(index)
        return State.of_history(index, np.vstack([q2, q1, q0]), path, sigma, rate)

    def _apply(self, what: str, tail: Callable[[State], list[Segment]], *,
               hold: int = 0) -> int:
        """Plan ``tail`` from the state at a switch sample ahead of the loop and swap it in.

        ``tail`` returns the new samples as segments (joints, σ, path), each on one path.
        Returns the first changed sample. The switch is placed the expected planning time
        ahead of the later of the last sample sent and the sample due now; when the loop got
        there first (planning or the loop's catching up took longer), it is planned again
        :data:`SWITCH_MARGIN` × what that attempt measured further ahead, up to
        :data:`SWITCH_TRIES` times (the loop never reads a sample that changes under it).

        Raises
        ------
        InputError
            ``field="execution"``, "the stream ran ahead of planning": no attempt landed
            before the loop (or the move ended first); nothing changed."""
        requested = time.perf_counter()
        if not self._attached.wait(10.0) or self.done or self._streamer is None:
            raise InputError(f"cannot {what}: the execution is not running",
                             field="execution", value=self.status)
        streamer = self._streamer
        keeper = _EndKeeper(self, streamer) if what == "retarget" else None
        with self._lock, keeper or contextlib.nullcontext():
            # (jerk-limited laws take long and vary: the slowest of the last few)
            ahead = (max if self._jerk else min)(self._plan_s.get(what, [0.003]))
            for _ in range(SWITCH_TRIES):
                rate = streamer.source.rate_hz
                bound = streamer.n
                # The loop may lag its clock on a loaded host and then catch up (or skip):
                # count from the later of the last sample sent and the one due now.
                last = max(self.sample, self._due_now(streamer) - 1)
                if what == "retarget" and bound - last < math.ceil(ahead * rate) + 4:
                    # the move ends before planning could: keep its end (at rest) a while
                    # longer, so the new move leaves from there instead of being refused
                    src0: OnlineSamples = streamer.source
                    streamer.swap(src0.held(src0.hold + math.ceil(2 * ahead * rate) + 8))
                    bound = streamer.n
                # state at switch, new samples from switch + 1: as far ahead as planning takes
                switch = last + 1 + math.ceil(ahead * rate)
                # the loop must still be running when it gets to the switch
                capped = switch >= bound - 2
                switch = min(switch, bound - 2)
                t_plan = time.perf_counter()
                state = self._state(max(switch, 0))
                segments = [seg for seg in tail(state) if len(seg[0])]
                if not segments:  # nothing to add: the switch state is where it ends
                    segments = [(state.q[None], np.array([state.sigma]), state.path)]
                src: OnlineSamples = streamer.source
                node = src
                first = switch + 1
                for n, (joints, sigma, path) in enumerate(segments):
                    node = OnlineSamples(node, first if n == 0 else node.end, joints, sigma,
                                         path, self.bus, src.rate_hz, src.joint_names,
                                         hold=hold if n == len(segments) - 1 else 0)
                took = time.perf_counter() - t_plan
                running = streamer.t_end == 0.0 and not self.done
                if running and self.sample + 2 < first and self.sample + 2 < streamer.n:
                    with self._swap_lock:
                        if keeper is not None:
                            keeper.stopped = True
                        streamer.swap(node)
                    for _joints, sigma, path in segments:  # a new path's own law
                        self._register_law(path, sigma, src.rate_hz, self.speed)
                    took_total = time.perf_counter() - requested
                    due = streamer.t_start + first * streamer.period
                    self.switches.append((requested, first, due, took_total, ahead))
                    self._record_plan_s(what, took)
                    log.info("%s: switch at sample %d (planned in %.2f ms)", what, first,
                             took * 1000)
                    if self.on_change is not None:
                        self.on_change(what)
                    return first
                if capped or not running:
                    break  # the move ends before any switch planning could reach
                # Missed: the stream ran on by more than planning was given. Next time give
                # it what this attempt measured (the planning and the loop's advance during
                # it, which includes a lagging loop catching up), with a margin.
                ran = (self.sample - last + 2) / rate
                ahead = SWITCH_MARGIN * max(ahead, took, ran)
                log.info("%s: the stream ran ahead of planning (%.1f ms), again %.1f ms ahead",
                         what, took * 1000, ahead * 1000)
        raise InputError(f"cannot {what}: the stream ran ahead of planning",
                         field="execution", value=self.status)

    @staticmethod
    def _due_now(streamer: Any) -> int:
        """Index of the sample due now on the loop's clock (−1 before the loop started)."""
        if not streamer.t_start:
            return -1
        return int((streamer.clock() - streamer.t_start) / streamer.period)

    def _need_arm(self, what: str) -> Limits:
        if self._limits is None:
            raise InputError(f"cannot {what}: the trajectory carries no arm (plan it with "
                             "robodcn.plan or pass arm=)", field="arm", value=None)
        return self._limits

    @property
    def _jerk(self) -> bool:
        return self._limits is not None and self._limits.j is not None

    def _brake(self, state: State, until_sd: float = 0.0) -> NDArray | None:
        """σ samples of the fastest brake along the present path from ``state`` (to
        ``until_sd``) under the full limits; None when the path ends first."""
        limits = self._limits
        assert limits is not None
        rate = self._streamer.source.rate_hz
        if limits.j is None:
            sigma = brake(state.path, state.sigma, state.sd, limits.a, rate, until_sd=until_sd)
            # a brake that runs into the path's end is cut there (a step to rest): the move's
            # own end, braking within the limits, comes first
            ends = sigma.size and sigma[-1] >= state.path.length - 1e-12 and state.sd > 0.0
            return None if ends else sigma
        return brake_jerk_checked(state.path, state.sigma, state.sd, state.sdd, limits, rate,
                                  state.history, until_sd=until_sd)

    def _braked(self, state: State, sigma: NDArray, *, at_rest: bool) -> State:
        """The state where the σ samples ``sigma`` of a brake on ``state.path`` end."""
        if not sigma.size:
            return state
        q = state.path.at(sigma[-3:])
        history = np.vstack([state.history, q])[-3:] if state.history is not None else None
        rate = self._streamer.source.rate_hz
        sd = 0.0 if at_rest else float(np.linalg.norm(history[-1] - history[-2]) * rate)
        return dataclasses.replace(state, index=state.index + len(sigma), q=history[-1],
                                   qd=(history[-1] - history[-2]) * rate,
                                   qdd=np.zeros_like(state.q), sigma=float(sigma[-1]), sd=sd,
                                   sdd=0.0, history=history)

    @staticmethod
    def _samples(path: JointPath, sigma: NDArray) -> list[Segment]:
        return [(path.at(sigma), sigma, path)]

    def _timed(self, state: State, limits: Limits, path: JointPath | None = None,
               sigma0: float | None = None, allowed: float | None = None,
               cap: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None
               ) -> NDArray:
        """σ samples: brake with the full limits while over what ``limits`` allow, then the
        time-optimal law under ``limits`` (and the speed ``cap``) to the end of the path."""
        if self._jerk:
            return self._timed_jerk(state, limits, path, sigma0, cap)
        path = state.path if path is None else path
        s0 = state.sigma if sigma0 is None else sigma0
        rate = self._streamer.period and 1.0 / self._streamer.period
        full = self._limits
        assert full is not None
        sd = state.sd
        pre = np.zeros(0)

        def allow(at: float) -> float:
            return self._allowed(path, at, limits, cap)

        if allowed is None:
            allowed = allow(s0) if sd > 0 else math.inf
        if sd > allowed * 0.98:
            pre = brake(path, s0, sd, full.a, rate, until_sd=allowed * 0.95)
            if pre.size:
                sd = (pre[-1] - (pre[-2] if pre.size > 1 else s0)) * rate
                s0 = float(pre[-1])
        for attempt in range(RETIME_TRIES):
            try:
                rest = retime(path, s0, sd, limits, rate, sd_cap=cap)
                break
            except InputError:
                if sd <= 0.0:
                    raise
                # Too fast for ``limits`` here: the brake ran on to where less speed is
                # allowed (near the path's end). Brake again to what is allowed where it
                # now is; the last tries brake to rest (always possible under the full
                # limits), from where the scaled law starts.
                to_rest = attempt >= RETIME_TRIES - 2
                until = 0.0 if to_rest else min(0.8 * sd, 0.95 * allow(s0))
                prev = pre[-1] if pre.size else s0
                more = brake(path, s0, sd, full.a, rate, until_sd=until)
                if to_rest:
                    # one sample at rest where the brake ends (its last step and the law's
                    # first step from rest are two accelerations, not one)
                    more = np.concatenate([more, more[-1:]]) if more.size else np.array([s0])
                    sd = 0.0
                elif more.size:
                    sd = (more[-1] - (more[-2] if more.size > 1 else prev)) * rate
                else:
                    continue
                pre = np.concatenate([pre, more])
                s0 = float(more[-1])
        else:
            raise InputError("cannot re-time the path from the present speed",
                             field="speed", value=self.speed)
        if pre.size and pre[-1] >= path.length - 1e-12 and rest.size == 0:
            # the brake (a share of the full limits) ran to the path's end still moving:
            # the move is already braking to its end as fast as the limits allow
            last = pre[-1] - (pre[-2] if pre.size > 1 else state.sigma)
            if last * rate > 1e-9:
                raise InputError("cannot re-time the path from the present speed: it ends "
                                 "before a brake could reach the scaled limits",
                                 field="speed", value=self.speed)
        return np.concatenate([pre, rest])

    @staticmethod
    def _allowed(path: JointPath, sigma: float, limits: Limits,
                 cap: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None) -> float:
        """The fastest σ̇ a re-timing may start with at ``sigma``: the controllable speed
        under ``limits``, and under the speed ``cap`` when there is one."""
        top = controllable_speed(path, sigma, limits)
        return top if cap is None else min(top, float(cap(np.array([sigma]))[0]))

    def _register_law(self, path: JointPath, sigma: NDArray, rate_hz: float,
                      scale: float) -> None:
        """Keep the first law a path was timed with, at speed scale 1 (σ̇ / ``scale`` at the
        midpoints of its samples): what a speed scale k must not exceed k × of."""
        if id(path) in self._laws or sigma.size < 2:
            return
        step = np.diff(sigma)
        keep = step > 0.0
        if not keep.any():
            return
        mid = 0.5 * (sigma[1:] + sigma[:-1])[keep]
        self._laws[id(path)] = (path, mid, step[keep] * rate_hz / max(scale, 1e-9))

    def _speed_cap(self, state: State, k: float
                   ) -> Callable[[NDArray[np.float64]], NDArray[np.float64]] | None:
        """σ ↦ the largest σ̇ a re-timing at speed scale k may reach: k × the path's own
        first law, so a slower, fixed-duration plan stays k × as slow (as with
        joint_trajectory_controller's speed scaling) instead of becoming time-optimal. The
        k-scaled law itself keeps v·k, a·k², j·k³, so a law under the cap exists from any
        state below it; :meth:`_timed` brakes to it first."""
        entry = self._laws.get(id(state.path))
        if entry is None or entry[0] is not state.path:
            return None
        _, mid, speed = entry

        def cap(s: NDArray[np.float64]) -> NDArray[np.float64]:
            return k * np.interp(s, mid, speed) * (1.0 + 1e-6) + 1e-9

        return cap

    def _retimed(self, state: State, limits: Limits) -> NDArray:
        """:meth:`_timed` on the present path for a speed change or a resume.

        Raises
        ------
        InputError
            ``field="speed"``: nothing of the path is left to re-time (the switch is at its
            end); the samples planned stand."""
        sigma = self._timed(state, limits, cap=self._speed_cap(state, self.speed))
        if not sigma.size:
            raise InputError("nothing of the path is left to re-time", field="speed",
                             value=self.speed)
        return sigma

    def _timed_jerk(self, state: State, limits: Limits, path: JointPath | None = None,
                    sigma0: float | None = None,
                    cap: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None
                    ) -> NDArray:
        """:meth:`_timed` under jerk limits: the law from the moving state (σ̇, σ̈); else a
        jerk-limited brake under the full limits to below what ``limits`` allow and the law
        from there; else a brake to rest and the law from rest (always possible).

        Raises
        ------
        InputError
            ``field="speed"``: the path ends before any brake could (the move's own end)."""
        path = state.path if path is None else path
        st = dataclasses.replace(state, path=path,
                                 sigma=state.sigma if sigma0 is None else sigma0)
        rate = self._streamer.source.rate_hz

        def law(at: State) -> NDArray:
            return retime(path, at.sigma, at.sd, limits, rate, sdd0=at.sdd,
                          history=at.history, sd_cap=cap)

        try:
            return law(st)
        except InputError:
            pass
        if st.sd > 0.0:
            allowed = self._allowed(path, st.sigma, limits, cap)
            if 0.0 < allowed < st.sd:
                pre = self._brake(st, until_sd=0.9 * allowed)
                if pre is not None:
                    try:
                        return np.concatenate([pre, law(self._braked(st, pre,
                                                                     at_rest=False))])
                    except InputError:
                        pass
        pre = self._brake(st) if st.sd > 0.0 or st.sdd != 0.0 else np.zeros(0)
        if pre is None:
            raise InputError("cannot re-time the path from the present speed: it ends "
                             "before a jerk-limited brake could stop", field="speed",
                             value=self.speed)
        return np.concatenate([pre, law(self._braked(st, pre, at_rest=True))])

    def _rest_of_source(self, state: State) -> list[Segment]:
        """The samples after ``state`` as they are (one segment per path): the present
        move's own way to rest."""
        src: OnlineSamples = self._streamer.source
        segments: list[Segment] = []
        for i in range(state.index + 1, src.end):
            path, sigma = src.path_at(i)
            if segments and segments[-1][2] is path:
                segments[-1][0].append(src.joint(i))
                segments[-1][1].append(sigma)
            else:
                segments.append(([src.joint(i)], [sigma], path))
        return [(np.array(q), np.array(s), p) for q, s, p in segments]

    # -- operations -----------------------------------------------------------------------

    def stop(self, mode: str = "smooth", reason: str = "stop requested") -> None:
        """Stop: ``"smooth"`` brakes along the path then holds; ``"hold"`` holds at once."""
        if mode not in STOP_MODES:
            raise InputError(f"mode must be one of {', '.join(STOP_MODES)}, got {mode!r}",
                             field="mode", value=mode)
        if mode == "hold" or self.done or self._streamer is None or self._limits is None:
            self.stop_signal.request(reason)
            return
        self._stop_keeper()
        self._smooth_stopped = True
        self.status = "stopping"
        try:
            self._apply("stop smoothly", lambda st: self._samples(st.path,
                                                                  self._brake_or_end(st)))
        except _PlanEnds:
            log.info("smooth stop: the move's own end is the fastest stop")
        except (InputError, RobodcnError):
            self.stop_signal.request(reason)

    def _brake_or_end(self, state: State) -> NDArray:
        sigma = self._brake(state)
        if sigma is None:
            raise _PlanEnds
        return sigma

    def pause(self) -> None:
        """Brake along the path to rest and stay there (the stream goes on)."""
        self._need_arm("pause")
        with self._lock:
            if self.paused:
                return
            rate = self._streamer.source.rate_hz if self._streamer else 1.0
            hold = max(1, int(PAUSE_AHEAD_S * rate))
            try:
                self._apply("pause", lambda st: self._samples(st.path, self._brake_or_end(st)),
                            hold=hold)
            except _PlanEnds:
                log.info("pause: the move ends before a brake could stop it")
                return
            self.paused = True
            self.status = "paused"
        self._keeper = threading.Thread(target=self._keep_paused, daemon=True,
                                        name="robodcn-pause")
        self._keeper.start()

    def _keep_paused(self) -> None:
        """While paused, keep a second of rest ahead of the loop."""
        while self.paused and not self.done:
            with self._lock:
                if not self.paused:
                    return
                src: OnlineSamples = self._streamer.source
                if len(src) - self.sample < PAUSE_AHEAD_S * src.rate_hz / 2:
                    self._streamer.swap(src.held(src.hold + int(PAUSE_AHEAD_S * src.rate_hz)))
            self._done.wait(PAUSE_AHEAD_S / 4)

    def _stop_keeper(self) -> None:
        self.paused = False

    def resume(self) -> None:
        """Continue the same path from where the pause left it, timed from there."""
        limits = self._need_arm("resume")
        with self._lock:
            if not self.paused:
                return
            self._stop_keeper()
            try:
                self._apply("resume", lambda st: self._samples(
                    st.path, self._retimed(st, limits.scaled(self.speed))))
            except InputError as exc:
                if exc.field != "speed":
                    raise
                log.info("resume: %s; the held end of the path stands", exc)
            self.status = "running"

    def set_speed(self, scale: float) -> None:
        """Re-time the rest of the path with the limits scaled by ``scale`` ∈ (0, 1].

        Near the end, where the move already brakes to its end at the full limits and no
        brake reaches the scaled ones first, the move ends as planned (``speed`` is still
        set: a resume uses it)."""
        k = check_limits_named("scale", scale)
        limits = self._need_arm("change speed")
        with self._lock:
            self.speed = k
            if self.paused or self.status == "stopping" or self.done:
                return
            try:
                self._apply("change speed", lambda st: self._samples(
                    st.path, self._retimed(st, limits.scaled(k))))
            except InputError as exc:
                if exc.field not in ("speed", "limits"):
                    raise
                # near the end the move already brakes to rest at the full limits; a
                # slower law from here would overrun the path (or none keeps every limit
                # from this state): the move ends as planned
                log.info("speed %.3g: %s; the move ends as planned", k, exc)

    def retarget(self, target: PlanRequest | Sequence[ArrayLike | None],
                 **plan_options: Any) -> int:
        """Replace the rest of the motion by a path to ``target``, from the moving state.

        ``target``: a PlanRequest (planned from the switch joints as
        :func:`robodcn.present.plan_from_present` would: an approach to its first waypoint
        if the arm is not there) or waypoints whose first entry None is the switch pose.
        ``plan_options``: keywords of :func:`robodcn.plan` (method, turn, blend, elbow, …).
        Returns the first changed sample. Raises the planner's errors (nothing changes).
        """
        self._need_arm("retarget")
        with self._lock:
            self._stop_keeper()
            first = self._apply("retarget", lambda st: self._retarget_tail(st, target,
                                                                           plan_options))
            self.paused = False
            self.status = "running"
            return first

    def _geometry(self, q: NDArray, target: Any, options: dict[str, Any]) -> NDArray:
        """Joint samples of the planner's path from joints ``q`` to ``target`` (geometry
        only: a slow quintic, re-timed afterwards)."""
        from robodcn.present import plan_from_present
        arm = self.arm
        options = dict(options)
        here = tuple(kinematics.fk(arm.links, q[None, :])[0])
        if isinstance(target, PlanRequest):
            target = dataclasses.replace(target, duration=GEOMETRY_DURATION_S,
                                         profile="quintic", rate_hz=GEOMETRY_RATE_HZ)
        else:
            target = list(target)
            if target and target[0] is None:
                target[0] = here
            else:
                target.insert(0, here)
            options.update(duration=GEOMETRY_DURATION_S, profile="quintic",
                           rate_hz=GEOMETRY_RATE_HZ)
        try:
            return self._even(plan_from_present(arm, None, target, joints=q, **options).joints)
        except (VelocityLimitError, AccelerationLimitError):
            # a long way: the slow geometry plan needs longer (only its path is used)
            if isinstance(target, PlanRequest):
                target = dataclasses.replace(target, duration=4 * GEOMETRY_DURATION_S)
            else:
                options.update(duration=4 * GEOMETRY_DURATION_S)
            return self._even(plan_from_present(arm, None, target, joints=q, **options).joints)

    def _even(self, q: NDArray) -> NDArray:
        """Under jerk limits, the geometry's samples thinned to about even arc-length steps
        (:func:`~robodcn.stream.online_path.evenly_spaced`): the slow quintic crowds them at
        both ends, where third differences on them are noise of 10⁵ × the path's own q⁽³⁾."""
        return evenly_spaced(q, GEOMETRY_SAMPLES) if self._jerk else q

    def remaining(self, first: int, request: PlanRequest | None = None) -> Trajectory:
        """The commanded samples from ``first`` to the end as a Trajectory (t from 0): what a
        retarget put in place, for records and reports."""
        src: OnlineSamples = self._streamer.source
        end = max(first + 1, src.end)
        index = range(first, end)
        joints = np.array([src.joint(i) for i in index])
        ticks = np.array([src.goal(i) for i in index])
        poses = kinematics.fk(self.arm.links, joints)
        poses[:, 2] = np.unwrap(poses[:, 2])
        method = request.method if request is not None else "sclerp"
        if isinstance(method, tuple):
            method = list(method)
        return Trajectory(np.arange(len(joints)) / src.rate_hz, poses, joints, ticks,
                          src.joint_names, tuple(self.bus.ids), src.rate_hz, method, request)

    def _retarget_tail(self, state: State, target: Any,
                       plan_options: dict[str, Any]) -> list[Segment]:
        """The planner's plan from the moving state (``plan(..., start_state=...)``, profile
        "optimal") at full speed; at a speed scale below 1, or when the planner cannot
        start from the state, :meth:`_retarget_own`."""
        if self._jerk:
            # From a moving state neither the planner's moving start (it joins the state
            # within its own sampled model: 7–24 × the jerk limit on the wire across the
            # switch) nor the bent start of _retarget_own (the bend's own q⁽³⁾σ̇³ at speed)
            # keeps a jerk limit; measured, every jerk-limited attempt ended braking to rest
            # anyway, after a wasted planning: go through rest at once.
            return self._retarget_through_rest(state, target, plan_options)
        own = self._retarget_own
        if self.speed >= 1.0 and StartState is not None:
            try:
                return self._retarget_planned(state, target, plan_options)
            except RobodcnError as exc:
                try:
                    return own(state, target, plan_options)
                except RobodcnError:
                    raise exc from None
        return own(state, target, plan_options)

    def _retarget_planned(self, state: State, target: Any,
                          plan_options: dict[str, Any]) -> list[Segment]:
        from robodcn.planner import plan, plan_request
        rate = 1.0 / self._streamer.period
        start = StartState(tuple(state.q), tuple(state.qd), tuple(state.qdd))
        if isinstance(target, PlanRequest):
            request = dataclasses.replace(target, start_state=start, start_joints=None,
                                          profile="optimal", duration="auto", rate_hz=rate)
            trajectory = plan_request(request)
        else:
            here = tuple(kinematics.fk(self.arm.links, state.q[None, :])[0])
            waypoints = list(target)
            if waypoints and waypoints[0] is None:
                waypoints[0] = here
            else:
                waypoints.insert(0, here)
            options = {**plan_options, "profile": "optimal", "duration": "auto",
                       "rate_hz": rate, "start_state": start}
            trajectory = plan(self.arm, waypoints, **options)
        path, sigma = JointPath.of_samples(trajectory.joints)
        return [(trajectory.joints[1:], sigma[1:], path)]

    def _retarget_through_rest(self, state: State, target: Any,
                               plan_options: dict[str, Any]) -> list[Segment]:
        """Under jerk limits: brake to rest along the present path (or follow it to its end
        when that comes first), then the new path from rest, timed under the present speed
        scale's limits."""
        full = self._limits
        assert full is not None
        sigma = self._brake(state)
        if sigma is None:
            segments = self._rest_of_source(state)
            q = segments[-1][0][-1] if segments else state.q
            history = np.vstack([state.history, *(seg[0] for seg in segments)])[-3:]
            rest = dataclasses.replace(state, q=q, history=history)
        else:
            segments = self._samples(state.path, sigma) if sigma.size else []
            rest = self._braked(state, sigma, at_rest=True)
        path, _ = JointPath.of_samples(self._geometry(rest.q, target, plan_options))
        path = dataclasses.replace(path, smooth=True)
        start = dataclasses.replace(rest, qd=np.zeros_like(rest.q), sd=0.0, sdd=0.0,
                                    path=path, sigma=0.0)
        tail = self._timed_jerk(start, full.scaled(self.speed))
        return [*segments, (path.at(tail), tail, path)]

    def _retarget_own(self, state: State, target: Any,
                      plan_options: dict[str, Any]) -> list[Segment]:
        """Brake along the present path as far as needed (a turn the limits cannot take at
        the present speed), then the new path, bent to the direction of motion."""
        full = self._limits
        assert full is not None
        limits = full.scaled(self.speed)
        rate = 1.0 / self._streamer.period
        segments: list[Segment] = []
        st = state
        path = None
        for attempt in range(5):
            q_new = self._geometry(st.q, target, plan_options)
            if st.sd <= 1e-9:
                path, _ = JointPath.of_samples(q_new)
                break
            direction = st.qd / st.sd
            total = float(np.sum(np.linalg.norm(np.diff(q_new, axis=0), axis=1)))
            length = max(st.sd ** 2 / (2.0 * float(np.min(limits.a))), 1e-3)
            coarse = q_new[::max(1, len(q_new) // SEARCH_STAGES)]
            best, best_speed = length, -1.0
            for _ in range(4):
                bent = blend_start(coarse, direction, min(length, max(total, 1e-3)))
                speed = controllable_speed(JointPath.of_samples(bent)[0], 0.0, limits,
                                           max_stages=SEARCH_STAGES)
                if speed > best_speed:
                    best, best_speed = length, speed
                if speed >= st.sd * 1.01 or length >= total:
                    break
                length *= 2.0
            path, _ = JointPath.of_samples(blend_start(q_new, direction,
                                                       min(best, max(total, 1e-3))))
            path = dataclasses.replace(path, start_tangent=direction)
            # the decision on the full path, under the limits the re-timing aims for
            best_speed = controllable_speed(path, 0.0, limits.scaled(1.0).shrunk(RETIME_SHARE))
            if st.sd <= best_speed * 0.99:
                break
            # too fast for the turn: brake along the present path first, then try again
            until = 0.0 if attempt >= 1 else 0.85 * best_speed
            more = brake(st.path, st.sigma, st.sd, full.a, rate, until_sd=until)
            if until == 0.0:
                # one sample at rest where the brake ends: the last step to rest and the
                # new path's first step from rest do not add up in one acceleration
                more = np.concatenate([more, more[-1:]]) if more.size else \
                    np.array([st.sigma])
            if not more.size:
                break
            segments.append((st.path.at(more), more, st.path))
            ends = st.path.at(np.concatenate([[st.sigma], more])[-2:])
            qd = (ends[1] - ends[0]) * rate
            st = dataclasses.replace(st, q=ends[1], qd=qd, sigma=float(more[-1]),
                                     sd=float(np.linalg.norm(qd)))
        assert path is not None
        tail = self._timed(dataclasses.replace(st, path=path, sigma=0.0), limits,
                           allowed=best_speed if st.sd > 1e-9 else math.inf)
        segments.append((path.at(tail), tail, path))
        return segments


def prepare(trajectory: Trajectory, bus: ServoBus, options: ExecutionOptions | None = None,
            *, arm: Any = None, **kwargs: Any) -> Execution:
    """An :class:`Execution` of ``trajectory`` not yet started: :meth:`Execution.run` streams
    it on the calling thread (a service's bus worker), :func:`start` on a thread of its own.
    Options as :func:`robodcn.stream.execute` (the stop signal is the execution's: one is
    made when none is given)."""
    opts = ExecutionOptions.build(options, kwargs)
    stop = opts.stop if isinstance(opts.stop, StopSignal) else StopSignal()
    execution = Execution(trajectory, bus, stop, arm)
    execution.warm_up()
    execution._options = dataclasses.replace(opts, stop=stop, attach=execution._attach)
    return execution


def start(trajectory: Trajectory, bus: ServoBus, options: ExecutionOptions | None = None,
          *, arm: Any = None, **kwargs: Any) -> Execution:
    """Start streaming ``trajectory`` on its own thread; the :class:`Execution` at once.

    Same options as :func:`robodcn.stream.execute`. Refusals before the first write are
    raised by :meth:`Execution.wait` (and kept in ``Execution.error``)."""
    execution = prepare(trajectory, bus, options, arm=arm, **kwargs)
    thread = threading.Thread(target=execution.run, daemon=True, name="robodcn-stream")
    execution._thread = thread
    thread.start()
    return execution
