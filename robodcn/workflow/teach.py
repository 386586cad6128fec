"""Teach by hand: with torque off, each confirmation records the present pose as a waypoint.

The pose is the FK of the present joints through the arm's calibration
(:func:`robodcn.workflow.poses.tool_poses`): x, y, θ on a planar arm, x, y, z, pitch on an
arm with a base yaw. A :class:`Teaching` session records and undoes poses on an open bus
(a surface drives the dialogue: ``robodcn teach``); :func:`waypoints_toml` writes the
waypoints file that :func:`robodcn.workflow.files.load_waypoints` reads back
(``robodcn run poses.toml``).

On a vertical arm the arm would fall with torque off: the session switches it off only
through the gravity guard (:func:`robodcn.workflow.release.release`: confirmed, lowered to
its rest pose first) and, however it ends, leaves the arm holding where it is
(:func:`robodcn.workflow.release.hold`). Or :class:`FloatSession` holds it in float mode
instead (:class:`robodcn.workflow.float_teach.FloatTeach`: current control with torque on
and the present pose's gravity currents, refreshed on a thread of its own) while a hand
moves it; the session's bus work (recording, the gripper) runs on that thread between two
refreshes (:meth:`FloatSession.call`), since the float loop holds the bus. Leaving it, the
arm holds in position mode where it was left. :meth:`Teaching.gripper` opens or closes the
gripper (:mod:`robodcn.workflow.gripper`) and marks the waypoint there ``gripper =
"open" | "close"``: ``robodcn run`` comes to rest and acts on it there.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Future
from types import TracebackType
from typing import Any, Self, TypeVar

import numpy as np
from numpy.typing import NDArray

from robodcn.bus import ServoBus
from robodcn.config import PLANAR_POSE, Arm
from robodcn.errors import InputError
from robodcn.planner import keepout
from robodcn.workflow.admin import present_state
from robodcn.workflow.float_teach import FloatReport, FloatSample, FloatTeach, has_gravity
from robodcn.workflow.gripper import COMMANDS as GRIPPER_ACTIONS
from robodcn.workflow.gripper import GripperResult, actuate
from robodcn.workflow.poses import file_key, pose_table
from robodcn.workflow.release import ReleaseResult, hold, release, released

log = logging.getLogger(__name__)

T = TypeVar("T")
#: A gripper action on a pose within this of the last waypoint's goes on that waypoint
#: (m; rad for the angles): the arm was not moved in between.
SAME_POSE_M = 1e-3
SAME_POSE_RAD = 0.02
#: Longest wait for the float thread to run a piece of bus work (s).
CALL_TIMEOUT_S = 10.0


def _direct(fn: Callable[[], T]) -> T:
    return fn()


class Teaching:
    """Poses taught by hand on an open ``bus``; a context manager.

    With ``torque_off`` (default) torque goes off when the session starts, so a hand moves
    the arm freely — through the gravity guard (:func:`robodcn.workflow.release.release`):
    on an arm under gravity only with ``confirm`` (GravityReleaseError otherwise), after
    lowering it to its rest pose (planned with ``plan_options``: the command gives the
    hands-on tool speed), ``warn`` told what happens. Without, the arm is held
    otherwise (float mode: pass the :class:`FloatSession`'s ``call`` as ``run``, which every
    bus access goes through). Leaving (finished, aborted or failed), an arm under gravity
    whose torque the session switched off holds where it is
    (:func:`robodcn.workflow.release.hold`: torque on, position mode, goal = present);
    :attr:`held` says so.
    """

    def __init__(self, bus: ServoBus, arm: Arm, *, torque_off: bool = True,
                 confirm: bool = False, warn: Callable[[str], None] | None = None,
                 run: Callable[[Callable[[], Any]], Any] = _direct,
                 plan_options: dict[str, Any] | None = None) -> None:
        self.bus = bus
        self.arm = arm
        self._run = run
        self._poses: list[NDArray[np.float64]] = []
        self._actions: list[dict[str, Any]] = []
        #: What the guard did when the session switched torque off (None: it did not).
        self.released: ReleaseResult | None = None
        #: Whether leaving put the arm on hold (torque on, position mode).
        self.held = False
        if torque_off:
            self.released = released(run(lambda: release(
                bus, arm, confirm=confirm, what="teach", warn=warn,
                plan_options=plan_options)), "teach")

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close(raising=exc is None)

    def close(self, *, raising: bool = True) -> None:
        """Hold an arm under gravity where it is if the session switched its torque off;
        idempotent. With ``raising`` False a failure is logged (leaving on another error)."""
        if self.released is None or not self.released.released or self.held \
                or not has_gravity(self.arm):
            return
        try:
            self._run(lambda: hold(self.bus))
        except Exception as error:
            if raising:
                raise
            log.warning("teach: the arm could not be held: %s", error)
            return
        self.held = True

    def present_pose(self) -> NDArray[np.float64]:
        """The present pose (the arm's pose keys), read on the bus."""
        return self._run(lambda: present_state(self.bus, self.arm).pose)

    def record(self, pose: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """Record the present pose (or ``pose``; the arm's pose keys: x, y, θ or x, y, z,
        pitch) as the next waypoint and return it. The present pose is refused
        (KeepOutError, nothing recorded) when a point of the arm lies inside a keep-out
        zone: no plan could go there."""
        if pose is None:
            state = self._run(lambda: present_state(self.bus, self.arm))
            keepout.check_pose(self.arm, state.joints)
            pose = state.pose
        self._poses.append(np.asarray(pose, dtype=np.float64))
        self._actions.append({})
        log.info("waypoint %d: %s", len(self._poses) - 1, pose)
        return pose

    def gripper(self, command: str, **options: Any) -> tuple[int, GripperResult]:
        """Open or close the gripper here and mark the waypoint ``gripper = command``: the
        last one when the arm has not moved since it was recorded, else the present pose
        recorded as a new one. Returns (the waypoint's index, what the gripper did).
        ``options`` go to :func:`robodcn.workflow.gripper.actuate`."""
        if command not in GRIPPER_ACTIONS:
            raise InputError(f"gripper must be one of {', '.join(GRIPPER_ACTIONS)}, got "
                             f"{command!r}", field="gripper", value=command)
        if self.arm.gripper is None:
            raise InputError(f"arm {self.arm.name!r} has no [gripper] table", field="gripper",
                             value=self.arm.name)
        gripper = self.arm.gripper
        state = self._run(lambda: present_state(self.bus, self.arm))
        keepout.check_pose(self.arm, state.joints)
        pose = state.pose
        result = self._run(lambda: actuate(self.bus, gripper, command, **options))
        if not self._poses or not self._same_pose(self._poses[-1], pose):
            self.record(pose)
        self._actions[-1]["gripper"] = command
        return len(self._poses) - 1, result

    def _same_pose(self, a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
        d = np.abs(np.asarray(a) - np.asarray(b))
        return bool(np.all(d[:-1] <= SAME_POSE_M) and d[-1] <= SAME_POSE_RAD)

    def undo(self) -> bool:
        """Drop the last waypoint (and its actions); False when there was none."""
        if not self._poses:
            return False
        self._poses.pop()
        self._actions.pop()
        return True

    @property
    def actions(self) -> tuple[dict[str, Any], ...]:
        """Per waypoint what it does there (``{"gripper": "close"}``, or empty), for
        :func:`waypoints_toml`'s ``extras``."""
        return tuple(dict(a) for a in self._actions)

    @property
    def poses(self) -> NDArray[np.float64]:
        """The waypoints recorded so far, (m, len(arm.pose_keys)): metres and radians."""
        return np.array(self._poses, dtype=np.float64).reshape(-1, len(self.arm.pose_keys))

    def __len__(self) -> int:
        return len(self._poses)


class FloatSession:
    """Float mode (:class:`~robodcn.workflow.float_teach.FloatTeach`) refreshed on a thread
    of its own while a dialogue runs; :meth:`call` runs bus work on that thread between two
    refreshes (the loop holds the bus). Leaving stops the loop and restores position mode
    at the present pose. ``float_options`` go to FloatTeach (joints, rate_hz,
    payload_kg)."""

    def __init__(self, bus: ServoBus, arm: Arm, **float_options: Any) -> None:
        self.float = FloatTeach(bus, arm, **float_options)
        self._jobs: queue.SimpleQueue[tuple[Callable[[], Any], Future[Any]]] = \
            queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self.report: FloatReport | None = None

    def __enter__(self) -> Self:
        self.float.__enter__()
        self._thread = threading.Thread(target=self._loop, name="robodcn-float", daemon=True)
        self._thread.start()
        return self

    def _loop(self) -> None:
        try:
            self.report = self.float.run(on_sample=self._serve)
        except BaseException as error:       # handed to the caller
            self._error = error
            log.warning("float: the refresh loop stopped: %s", error)
        finally:
            self._serve(None)

    def _serve(self, _sample: FloatSample | None) -> None:
        while True:
            try:
                fn, future = self._jobs.get_nowait()
            except queue.Empty:
                return
            if not future.set_running_or_notify_cancel():
                continue
            try:
                future.set_result(fn())
            except BaseException as error:   # raised by call()
                future.set_exception(error)

    def call(self, fn: Callable[[], T]) -> T:
        """Run ``fn`` (bus work) on the float thread between two refreshes; its result."""
        if self._thread is None or not self._thread.is_alive():
            if self._error is not None:
                raise self._error
            return fn()
        future: Future[T] = Future()
        self._jobs.put((fn, future))
        return future.result(timeout=CALL_TIMEOUT_S)

    @property
    def latest(self) -> FloatSample | None:
        """The float loop's last sample."""
        return self.float.latest

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.float.stop()
        if self._thread is not None:
            self._thread.join(timeout=CALL_TIMEOUT_S)
        self.float.__exit__(exc_type, exc, tb)
        self.report = self.float.report()        # with what leaving read back (held)
        if self._error is not None and exc is None:
            raise self._error


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def waypoints_toml(poses: Sequence[Sequence[float]], *, arm_name: str,
                   method: str | Sequence[str] | None = None,
                   beta: float | Sequence[float] | None = None,
                   turn: str | Sequence[str] | None = None,
                   keys: Sequence[str] = PLANAR_POSE,
                   extras: Sequence[Mapping[str, Any]] | None = None) -> str:
    """The waypoints file for ``poses`` (metres, radians; the angles written in degrees:
    ``theta_deg``, ``pitch_deg``), one row of ``keys`` each (x, y, θ, or a yawed arm's x, y,
    z, pitch).

    ``method``, ``turn`` and ``beta`` are one value for the whole plan (``[plan]``) or one
    per segment (written on the waypoint each segment leads to). ``extras`` holds per
    waypoint further keys to write on it (``gripper = "close"``, ``payload_kg``).
    """
    keys = tuple(keys)
    units = ", ".join(file_key(k) for k in keys)
    lines = [f"# robodcn waypoints taught on arm {arm_name!r}: {units} (metres, degrees).",
             "# [plan] holds plan options for every segment; a waypoint may carry method, turn",
             "# and beta for the segment that leads to it. Run with: robodcn run FILE",
             f"arm = {_toml_string(arm_name)}", "", "[plan]"]
    per_segment: dict[str, list[str]] = {}
    for key, value in (("method", method), ("turn", turn)):
        if isinstance(value, str):
            lines.append(f"{key} = {_toml_string(value)}")
        elif value is not None:
            per_segment[key] = [_toml_string(v) for v in value]
    if isinstance(beta, int | float):
        lines.append(f"beta = {float(beta)!r}")
    elif beta is not None:
        per_segment["beta"] = [repr(float(b)) for b in beta]
    rows = np.asarray(poses, dtype=np.float64).reshape(-1, len(keys))
    for i, pose in enumerate(rows):
        lines += ["", "[[waypoints]]"]
        lines += [f"{key} = {value!r}" for key, value in pose_table(keys, pose).items()]
        for key, values in per_segment.items():
            if i >= 1 and i - 1 < len(values):
                lines.append(f"{key} = {values[i - 1]}")
        for key, value in (extras[i] if extras is not None and i < len(extras) else {}).items():
            lines.append(f"{key} = {_toml_value(value)}")
    return "\n".join(lines) + "\n"


def _toml_value(value: Any) -> str:
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(float(value)) if isinstance(value, float) else repr(value)
