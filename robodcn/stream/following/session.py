"""A follow session: the arm heads for the newest of a stream of targets, streamed on a thread.

:func:`follow` opens the session on a bus and returns a :class:`Follower` at once. The
session is one execution (:func:`robodcn.stream.execute`: preflight, the Bus Watchdog, the
schedule, feedback, tracking limit, collision stop, the hold and the report, as for a move)
whose sample source is :class:`~robodcn.stream.following.source.FollowSamples`: each period
the loop asks the online generator (:class:`robodcn.online.Generator`) for the next sample
toward the newest input. Nothing is planned when a target arrives: :meth:`Follower.target`
checks it, turns a pose into joints, estimates its velocity
(:mod:`robodcn.stream.following.targets`) and hands the generator a new input, which the next
period's sample already heads for. On an arm with torque limits the input is checked
first (:meth:`robodcn.online.Generator.check`: a lower speed scale where the law would
exceed one, with the session's payload).

Ending: :meth:`Follower.end` — to rest at the last target, then the stream ends (outcome
"done"); :meth:`Follower.stop` ``"smooth"`` — brake to rest the shortest way, the report
says "stopped"; ``"hold"`` — hold at once. With ``timeout_s`` a session that gets no target
for that long while the arm moves stops smoothly (the deadman), its report naming the
timeout.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import sys
import threading
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import servo_units
from robodcn.bus import ServoBus
from robodcn.config import Arm
from robodcn.errors import InputError, KeepOutError, NoMoveError
from robodcn.online import Generator, Infeasible, Input
from robodcn.path_timing import JointLimits
from robodcn.planner import Trajectory, keepout, plan
from robodcn.planner.arm_arrays import limits_of
from robodcn.planner.path import user_pose
from robodcn.stream.collision import predicted_currents, thresholds
from robodcn.stream.following.source import FollowSamples
from robodcn.stream.following.targets import Targets
from robodcn.stream.options import ExecutionOptions
from robodcn.stream.report import ExecutionReport
from robodcn.stream.signal import StopSignal
from robodcn.stream.streamer import execute

log = logging.getLogger("robodcn.stream")

#: stop modes of :meth:`Follower.stop`
STOP_MODES = ("smooth", "hold")
#: GIL switch interval while a session streams (s): target() runs on other threads
SWITCH_INTERVAL_S = 0.0002
#: how long target() waits for the stream to start (s)
ATTACH_TIMEOUT_S = 10.0
#: bus periods a streamed target's law is stretched past the stream's gap, and the arm goes on
#: past it: the next target may come that much late without a brake
SLACK_PERIODS = 2
#: the jerk limit (× the acceleration limit, 1/s) of a session on a joint without one: full
#: acceleration in 20 ms
SESSION_JERK_PER_ACCEL = 50.0
#: how far (rad) each joint's probe motion goes for the collision thresholds
PROBE_RAD = 0.6
#: a target velocity below this (rad/s, every joint) is rest
REST_SPEED = 1e-9
#: samples of the law toward a new target checked against the keep-out zones (at most)
KEEPOUT_SAMPLES = 400


def smoothed(limits: JointLimits) -> JointLimits:
    """``limits`` with a jerk limit of :data:`SESSION_JERK_PER_ACCEL` × a on every joint
    that has none. A stream's law reaches each target state in one gap exactly
    (:mod:`~robodcn.stream.following.targets`); an acceleration-limited (second-order)
    law does so by switching between ±a_max within the gap — the position follows, but
    the acceleration written to the servos jumps by 2·a_max at every target."""
    extra = SESSION_JERK_PER_ACCEL * limits.a
    jerk = extra if limits.j is None else np.where(np.isfinite(limits.j), limits.j, extra)
    return dataclasses.replace(limits, j=jerk)


class Follower:
    """A running follow session (:func:`follow`); every method is thread-safe.

    Attributes
    ----------
    status : "starting" | "following" | "ending" | "stopping" | "finished"
    taken, refused : targets accepted and refused so far
    seq : the sequence number of the newest accepted target (0 before the first)
    report : the :class:`~robodcn.stream.ExecutionReport` once finished (None before)
    error : what :func:`~robodcn.stream.execute` raised before any write, or None
    """

    def __init__(self, bus: ServoBus, arm: Arm, trajectory: Trajectory, *,
                 space: str, timeout_s: float | None, payload_kg: float | None,
                 options: ExecutionOptions, present_ticks: ArrayLike | None = None) -> None:
        self.check(arm, space, timeout_s)
        self.bus = bus
        self.arm = arm
        self.trajectory = trajectory
        self.targets = Targets(arm, space)
        self.space = space
        self.timeout_s = None if timeout_s is None else float(timeout_s)
        self.rate_hz = trajectory.rate_hz
        q0 = trajectory.joints[-1].copy()
        self.generator = Generator(
            smoothed(limits_of(arm, payload_kg)), self.rate_hz, q0,
            position_limits=[(j.min_angle, j.max_angle) for j in arm.joints])
        self.status = "starting"
        #: paused (a stop that stays until :meth:`resume`)
        self.paused = False
        #: the speed scale asked for (:meth:`set_speed`; the torque check may lower it more)
        self.speed = 1.0
        self.taken = 0
        self.refused = 0
        self.seq = 0
        self.infeasible = 0
        self.report: ExecutionReport | None = None
        self.error: BaseException | None = None
        self.stream: Any = None
        self.source: FollowSamples | None = None
        self.clock = options.clock
        self.stop_signal = options.stop if isinstance(options.stop, StopSignal) \
            else StopSignal()
        self._options = ExecutionOptions.build(
            options, {"stop": self.stop_signal, "attach": self._attach})
        self._present_ticks = present_ticks
        self._input = Input(target=q0)
        #: the speed scale the torque limits allow toward the newest target
        self._scale = 1.0
        #: a streamed target reached early goes on at its velocity until then (the stream's
        #: clock): the next target is due
        self._coast_until = -np.inf
        self._ending: str | None = None         # None | "end" | "stop"
        self._stop_message: str | None = None
        self._last_at: float | None = None
        self._lock = threading.Lock()
        self._attached = threading.Event()
        self._done = threading.Event()
        self._thread: threading.Thread | None = None

    @staticmethod
    def check(arm: Arm, space: str, timeout_s: float | None) -> None:
        """A session's arguments (InputError naming ``space`` or ``timeout_s``)."""
        Targets(arm, space)
        if timeout_s is not None and not (isinstance(timeout_s, int | float)
                                          and not isinstance(timeout_s, bool)
                                          and 0 < timeout_s < float("inf")):
            raise InputError(f"timeout_s must be a number of seconds > 0, got {timeout_s!r}",
                             field="timeout_s", value=timeout_s)

    # -- lifecycle --------------------------------------------------------------------------

    def start(self) -> Follower:
        """Stream on a thread of its own; self at once."""
        self._thread = threading.Thread(target=self.run, daemon=True, name="robodcn-follow")
        self._thread.start()
        return self

    def run(self) -> ExecutionReport | None:
        """Stream on the calling thread until the session ends; the report (or raise what
        :func:`~robodcn.stream.execute` raised)."""
        interval = sys.getswitchinterval()
        sys.setswitchinterval(min(interval, SWITCH_INTERVAL_S))
        try:
            report = execute(self.trajectory, self.bus, self._options,
                             present_ticks=self._present_ticks)
            if self._stop_message is not None and report.stop_reason == "completed":
                report = dataclasses.replace(report, stop_reason="stopped",
                                             message=self._stop_message)
            log.info("%s", report.headline)
            self.report = report
        except BaseException as exc:  # reported through .error and wait()
            self.error = exc
        finally:
            sys.setswitchinterval(interval)
            self.status = "finished"
            self._attached.set()
            self._done.set()
        return self.wait(0)

    def _attach(self, stream: Any) -> None:
        """Called by the streamer before its first sample: the generator becomes its
        source."""
        planned = stream.source
        compensated = getattr(planned, "compensated", False)
        source = FollowSamples(self._step, self.bus, self.arm, self.rate_hz,
                               planned.joint_names,
                               lead=planned.commanded_for if compensated else None,
                               start_goal=getattr(planned, "start_goal", None))
        source.stream = stream
        self._collision_thresholds(stream.feedback)
        stream.swap(source)
        self.stream, self.source = stream, source
        self._last_at = self.clock.now()
        self.status = "following"
        self._attached.set()

    def _collision_thresholds(self, feedback: Any) -> None:
        """The collision stop's thresholds for a session (:mod:`robodcn.stream.collision`):
        what it will command is not known ahead, so each joint's is that of the fastest
        motion the limits allow near the start — :data:`PROBE_RAD` out and back on every
        joint at once, the generator's law at the session's rate — instead of the rest
        plan's (which a first target at speed took for a collision). A configured
        ``collision_current_a`` (or the execution's ``collision_current``) stands."""
        if feedback.threshold_at is None:
            return
        q0 = self.generator.state[0]
        lo = np.array([j.min_angle for j in self.arm.joints])
        hi = np.array([j.max_angle for j in self.arm.joints])
        room = np.where(hi - q0 > q0 - lo, 1.0, -1.0)
        far = np.clip(q0 + room * PROBE_RAD, lo, hi)
        probe = Generator(self.generator.limits, self.rate_hz, q0)
        rows = [q0]
        for goal in (far, q0):
            inp = Input(target=goal)
            while True:
                sample = probe.update(inp)
                if isinstance(sample, Infeasible):
                    break
                rows.append(sample.q)
                if sample.reached:
                    break
        bus = self.bus
        predicted = predicted_currents(np.array(rows), 1.0 / self.rate_hz, bus.servos,
                                       self.arm, feedback.payload_kg)
        limits = bus.current_limits or tuple(2.3 for _ in bus.ids)
        feedback.threshold_at = None
        feedback.chain = None
        feedback.threshold = thresholds(predicted, limits, self.arm, bus.position_d_gains)

    def wait(self, timeout: float | None = None) -> ExecutionReport | None:
        """Block until the session has ended (or ``timeout``); the report, or raise what
        :func:`~robodcn.stream.execute` raised before any write."""
        self._done.wait(timeout)
        if self.error is not None:
            raise self.error
        return self.report

    @property
    def done(self) -> bool:
        return self._done.is_set()

    # -- one period (the loop's thread) -------------------------------------------------------

    def _step(self, i: int) -> tuple[NDArray[np.float64], bool]:
        """The commanded joints of sample ``i`` and whether it ends the session."""
        with self._lock:
            if self._deadman():
                self._input = Input.stop(self._scale * self.speed)
            inp = self._input
        sample = self.generator.update(inp)
        if isinstance(sample, Infeasible):
            self.infeasible += 1
            log.warning("follow: input not taken at sample %d: %s", i, sample.message)
            sample = self.generator.update()
            if isinstance(sample, Infeasible):
                return self.generator.state[0], False
        if not sample.reached:
            return sample.q, False
        with self._lock:
            if self._input is not inp:
                return sample.q, False          # a newer input: the next sample takes it
            if self._ending is not None:
                return sample.q, True
            if inp.mode == "target" and inp.velocity is not None \
                    and np.abs(inp.velocity).max() > REST_SPEED \
                    and self.stream.t_start + i / self.rate_hz > self._coast_until:
                # passed the target with its velocity (and the law's acceleration, a
                # streamed target's next is due by _coast_until) and no newer target
                # came: rest there
                self._input = Input(target=inp.target, scale=inp.scale)
        return sample.q, False

    def _deadman(self) -> bool:
        """No target for ``timeout_s`` while the arm moves: a smooth stop (under the lock)."""
        if self.timeout_s is None or self._ending is not None or self._last_at is None \
                or self.paused:
            return False
        if self.clock.now() - self._last_at <= self.timeout_s:
            return False
        qd = self.generator.state[1]
        if np.abs(qd).max() <= REST_SPEED and self._input.mode == "target" \
                and self._input.velocity is None:
            at = self.generator.state[0]
            if np.abs(at - np.asarray(self._input.target)).max() <= 1e-9:
                return False                   # at rest at its target: nothing to stop
        self._ending = "stop"
        self.status = "stopping"
        self._stop_message = (f"no target for {self.timeout_s:g} s (timeout_s): stopped "
                              "smoothly (decelerated within the limits)")
        log.info("follow: %s", self._stop_message)
        return True

    # -- operations ---------------------------------------------------------------------------

    def _open(self, what: str) -> None:
        if not self._attached.wait(ATTACH_TIMEOUT_S) or self.done:
            raise NoMoveError(f"cannot {what}: the follow session is not running",
                              field="follow", value=self.status)
        if self.paused and what != "end the session":
            raise NoMoveError(f"cannot {what}: the follow session is paused (resume it)",
                              field="follow", value=self.status)
        if self._ending is not None:
            raise NoMoveError(f"cannot {what}: the follow session is "
                              f"{'ending' if self._ending == 'end' else 'stopping'}",
                              field="follow", value=self.status)

    def target(self, joints: ArrayLike | None = None, pose: ArrayLike | None = None,
               velocity: ArrayLike | None = None) -> int:
        """Head for a new target from the commanded state (module notes); its sequence
        number. InputError naming ``joints``, ``pose`` or ``velocity`` (the session goes on
        to the previous target); NoMoveError when the session is not running."""
        self._open("take a target")
        try:
            last = self.targets.last
            reference = last.joints if last is not None else self.generator.state[0]
            q = self.targets.joints_of(joints, pose, reference)
            with self._lock:
                target = self.targets.take(q, velocity, self.clock.now())
                segment = target.segment
                if segment is None:
                    # alone: as fast as the limits allow (passed with its given velocity)
                    inp = Input(target=target.joints, velocity=target.velocity)
                else:
                    # in a stream: its state one gap (+ slack) after it arrived, when the
                    # next is due; the arm goes on past it until then (_step)
                    _, v1, a1 = segment.at(segment.end)
                    due = segment.h + SLACK_PERIODS / self.rate_hz
                    inp = Input(target=target.joints, velocity=v1, acceleration=a1,
                                duration=due)
                try:
                    inp = self._checked(dataclasses.replace(inp, scale=self.speed))
                except (InputError, KeepOutError):
                    self.targets.drop(target)
                    raise
                self._input, self._scale = inp, inp.scale / self.speed
                self._coast_until = -np.inf if segment is None else target.at + due
                self._last_at = target.at
                self.taken += 1
                self.seq += 1
                return self.seq
        except (InputError, KeepOutError):
            self.refused += 1
            raise

    def _checked(self, inp: Input) -> Input:
        """``inp`` under the torque limits (Generator.check); InputError naming the
        session's space when no speed keeps them; KeepOutError when the law toward it from
        the commanded state takes a point of the arm into a keep-out zone (its samples
        checked as a plan's: :func:`robodcn.planner.keepout.check_joints`)."""
        checked = self.generator.check(inp)
        if isinstance(checked, Infeasible):
            raise InputError(f"{self.space}: {checked.message}", field=self.space,
                             value=None if inp.target is None else inp.target.tolist())
        if not self.arm.workspace.empty:
            law = self.generator.law(checked)
            if not isinstance(law, Infeasible):
                n = max(2, min(KEEPOUT_SAMPLES, math.ceil(law.duration * self.rate_hz) + 1))
                at = np.linspace(0.0, law.duration, n)
                q = np.array([law.at_time(float(t))[0] for t in at])
                keepout.check_joints(self.arm, q, (n - 1) / max(law.duration, 1e-9),
                                     field=self.space)
        return checked

    def end(self) -> None:
        """Come to rest at the last target, then end the session (outcome "done")."""
        self._open("end the session")
        with self._lock:
            last = self.targets.last
            q = last.joints if last is not None else self.generator.state[0]
            self._input = Input(target=q, scale=self._scale * self.speed)
            self.paused = False
            self._ending = "end"
            self.status = "ending"

    def stop(self, mode: str = "smooth", reason: str = "stop requested") -> None:
        """``"smooth"``: brake to rest within the limits, then end ("stopped"); ``"hold"``:
        hold at once."""
        if mode not in STOP_MODES:
            raise InputError(f"mode must be one of {', '.join(STOP_MODES)}, got {mode!r}",
                             field="mode", value=mode)
        if mode == "hold" or self.done or self.stream is None:
            self.stop_signal.request(reason)
            return
        with self._lock:
            self._input = Input.stop(self._scale * self.speed)
            self.paused = False
            self._ending = "stop"
            self.status = "stopping"
            self._stop_message = f"{reason}: stopped smoothly (decelerated within the limits)"

    def pause(self) -> bool:
        """Brake to rest and stay there (the stream goes on); targets are refused until
        :meth:`resume`. True (a session can always be paused)."""
        self._open("pause")
        with self._lock:
            self._input = Input.stop(self._scale * self.speed)
            self.paused = True
            self.status = "paused"
        return True

    def resume(self) -> None:
        """Head for the last target again (at rest there) after a pause."""
        if not self.paused:
            return
        with self._lock:
            last = self.targets.last
            q = last.joints if last is not None else self.generator.state[0]
            self._input = Input(target=q, scale=self._scale * self.speed)
            self.paused = False
            self.status = "following"

    def set_speed(self, scale: float) -> None:
        """Scale the limits the session moves with by ``scale`` ∈ (0, 1] (v·k, a·k², j·k³;
        the present motion is re-timed from the commanded state at once)."""
        if not (isinstance(scale, int | float) and 0.0 < scale <= 1.0):
            raise InputError(f"scale must be a number in (0, 1], got {scale!r}",
                             field="scale", value=scale)
        with self._lock:
            self.speed = float(scale)
            self._input = dataclasses.replace(self._input, scale=self._scale * self.speed)

    # -- what was streamed ------------------------------------------------------------------

    def sent(self) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """Every sample sent so far: indices, send times (the stream's clock) and the
        commanded joints (rad)."""
        s, src = self.stream, self.source
        if s is None or src is None:
            return np.zeros(0, np.int64), np.zeros(0), np.zeros((0, len(self.arm.joints)))
        n = s.records.count
        index = np.array(s.records.index[:n], dtype=np.int64)
        return index, np.array(s.records.at[:n]), src.joints[np.minimum(index, src.made - 1)]

    def commanded(self) -> Trajectory:
        """The session's commanded samples as a Trajectory (t from 0; every sample made,
        sent or skipped): its record."""
        src = self.source
        if src is None or not src.made:
            return self.trajectory
        joints = src.joints[:src.made].copy()
        ticks = src.ticks[:src.made].copy()
        return Trajectory(np.arange(len(joints)) / self.rate_hz, user_pose(self.arm, joints),
                          joints, ticks, self.arm.joint_names, tuple(self.bus.ids),
                          self.rate_hz, "follow", self.trajectory.request)


def rest_trajectory(arm: Arm, present_ticks: ArrayLike, rate_hz: float | None = None,
                    payload_kg: float | None = None) -> Trajectory:
    """A session's first samples: at rest where the arm is (``present_ticks`` (k,), clipped
    to the joint limits), at ``rate_hz`` (None: the arm's ``[bus] rate_hz``) — what the
    preflight checks the start against and the record opens with (the generator answers
    every sample after them)."""
    ticks = np.asarray(present_ticks, dtype=np.int64)
    q0 = servo_units.ticks_to_radians(ticks[None], arm.servos)[0]
    lo = np.array([j.min_angle for j in arm.joints])
    hi = np.array([j.max_angle for j in arm.joints])
    start = np.clip(q0, lo, hi)
    rate = float(rate_hz) if rate_hz is not None else float(arm.bus.rate_hz)
    return plan(arm, [tuple(float(v) for v in user_pose(arm, start[None])[0])],
                rate_hz=rate, start_joints=start, payload_kg=payload_kg)


def follow(bus: ServoBus, arm: Arm, *, space: str = "joints", timeout_s: float | None = None,
           payload_kg: float | None = None, rate_hz: float | None = None,
           options: ExecutionOptions | None = None, present_ticks: ArrayLike | None = None,
           compensation: bool = False, **kwargs: Any) -> Follower:
    """Open a follow session on ``bus`` (module notes) and stream it on its own thread.

    Parameters
    ----------
    bus : an open :class:`~robodcn.bus.ServoBus` with ``arm``'s servos.
    arm : the arm (its joint limits, jerk and torque limits where set, its IK for poses).
    space : "joints" (targets are joint angles, rad) or "pose" (the arm's pose axes).
    timeout_s : the deadman: no target for this long while moving → a smooth stop.
    payload_kg : the payload the torque limits carry (None: the arm's).
    rate_hz : the bus rate (None: the arm's ``[bus] rate_hz``).
    options, kwargs : :class:`~robodcn.stream.ExecutionOptions` (``clock``,
        ``tracking_limit``, ``watchdog_ms`` …) as :func:`robodcn.stream.execute` takes them.
    present_ticks : Present Position (k,) the caller has just read (None: read here).
    compensation : tracking compensation: each goal led like a plan's
        (:mod:`~robodcn.stream.following.source`; about a millisecond a sample, for rates
        up to a few hundred Hz); False (the default) sends the generator's samples.

    Returns
    -------
    Follower: :meth:`~Follower.target`, :meth:`~Follower.end`, :meth:`~Follower.stop`,
    :meth:`~Follower.wait` (the :class:`~robodcn.stream.ExecutionReport`).
    """
    opts = ExecutionOptions.build(options, {**kwargs, "compensation": compensation})
    ticks = (np.asarray(present_ticks, dtype=np.int64) if present_ticks is not None
             else bus.read_positions())
    rest = rest_trajectory(arm, ticks, rate_hz, payload_kg)
    follower = Follower(bus, arm, rest, space=space, timeout_s=timeout_s,
                        payload_kg=payload_kg, options=opts, present_ticks=ticks)
    return follower.start()


__all__ = ["STOP_MODES", "Follower", "follow", "rest_trajectory"]
