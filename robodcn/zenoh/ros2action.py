"""``control_msgs/action/FollowJointTrajectory`` with joint_trajectory_controller's
semantics, as three services and two topics on rmw_zenoh's wire (``<action>/_action/…``).

- ``send_goal``: a goal naming other joints than the arm's is rejected (``accepted`` false;
  its result, if asked, ``INVALID_JOINTS``); otherwise accepted at once, then played through
  the ``start_move`` operation: a plan it refuses (NaN, beyond the limits) aborts the goal
  with ``INVALID_GOAL`` and the refusal's message in ``error_string``, nothing moves. A new
  goal preempts the running one (which ends ``CANCELED``, the arm stopping smoothly first).
- ``feedback`` at :data:`FEEDBACK_HZ`: desired (the plan at the elapsed time), actual (the
  present joints), error = desired − actual (rad).
- ``path_tolerance``: a position error beyond a joint's tolerance (> 0; 0 is the default,
  none; −1 erases) stops the move (hold) and aborts ``PATH_TOLERANCE_VIOLATED``.
- At the end: every joint within its ``goal_tolerance`` of the last point, allowing
  ``goal_time_tolerance`` for it, gives ``SUCCEEDED``/``SUCCESSFUL``; otherwise
  ``GOAL_TOLERANCE_VIOLATED``. A move that ends stopped or faulted aborts the goal with
  ``PATH_TOLERANCE_VIOLATED`` and the move's reason.
- ``cancel_goal``: a smooth stop, then ``CANCELED`` (a zero goal id cancels every active
  goal); ``get_result``: answered when the goal ends (the query stays open until then).
- ``status`` (``action_msgs/msg/GoalStatusArray``, transient-local): on every change.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robodcn.http.context import Service
from robodcn.ros2 import wire
from robodcn.zenoh import dispatch
from robodcn.zenoh.ros2moves import stamp, stop_and_wait, trajectory_body

log = logging.getLogger("robodcn.ros2")

ACTION = "control_msgs/action/FollowJointTrajectory"
CANCEL = "action_msgs/srv/CancelGoal"
STATUS = "action_msgs/msg/GoalStatusArray"

# action_msgs/msg/GoalStatus
UNKNOWN, ACCEPTED, EXECUTING, CANCELING, SUCCEEDED, CANCELED, ABORTED = range(7)
ACTIVE = (ACCEPTED, EXECUTING, CANCELING)
# control_msgs/action/FollowJointTrajectory result codes
SUCCESSFUL, INVALID_GOAL, INVALID_JOINTS = 0, -1, -2
PATH_TOLERANCE_VIOLATED, GOAL_TOLERANCE_VIOLATED = -4, -5
# action_msgs/srv/CancelGoal return codes
ERROR_NONE, ERROR_REJECTED, ERROR_UNKNOWN_GOAL_ID, ERROR_GOAL_TERMINATED = range(4)

#: Feedback rate while a goal executes (Hz).
FEEDBACK_HZ = 20.0
#: Finished goals kept for get_result and the status array.
KEEP_GOALS = 16
#: Longest a get_result query is held open (s).
RESULT_WAIT_S = 3600.0
ZERO_UUID = bytes(16)


@dataclass
class Goal:
    """One goal: its id, acceptance stamp, status, result and what it plays."""

    uuid: bytes
    stamp: dict[str, int]
    goal: dict[str, Any]
    status: int = ACCEPTED
    result: dict[str, Any] = field(default_factory=lambda: {"error_code": SUCCESSFUL,
                                                            "error_string": ""})
    move_id: str | None = None
    done: threading.Event = field(default_factory=threading.Event)
    cancel: threading.Event = field(default_factory=threading.Event)
    preempted: str | None = None

    @property
    def info(self) -> dict[str, Any]:
        return {"goal_id": {"uuid": self.uuid}, "stamp": self.stamp}


def _tolerances(entries: list[dict[str, Any]]) -> dict[str, float]:
    """Position tolerances by joint name: > 0 applies; 0 (default) and −1 (erased) do not."""
    return {e["name"]: e["position"] for e in entries if e.get("position", 0) > 0}


def _point(positions: Any, t: float) -> dict[str, Any]:
    return {"positions": [float(v) for v in positions], "velocities": [],
            "accelerations": [], "effort": [],
            "time_from_start": {"sec": int(t), "nanosec": int((t - int(t)) * 1e9)}}


class FollowJointTrajectoryServer:
    """The action server ``name`` (``/<controller>/follow_joint_trajectory``) on ``node``."""

    def __init__(self, server: Service, node: Any, name: str) -> None:
        self._stamp = stamp
        self.server = server
        self.node = node
        self.arm = server.arm
        self.goals: OrderedDict[bytes, Goal] = OrderedDict()
        self._lock = threading.Lock()
        # one thread: goals are accepted (and the older ones preempted) in arrival order
        self._requests = ThreadPoolExecutor(1, thread_name_prefix="robodcn-ros2-action")
        self._starting = threading.Lock()
        self._results = threading.BoundedSemaphore(64)
        base = f"{name}/_action"
        node.service(f"{base}/send_goal", f"{ACTION}_SendGoal", self._send_goal,
                     self._requests.submit)
        node.service(f"{base}/cancel_goal", CANCEL, self._cancel_goal, self._requests.submit)
        node.service(f"{base}/get_result", f"{ACTION}_GetResult", self._get_result,
                     self._on_thread)
        self._feedback = node.publisher(f"{base}/feedback", f"{ACTION}_FeedbackMessage")
        self._status = node.publisher(f"{base}/status", STATUS,
                                      wire.QoS(durability=wire.TRANSIENT_LOCAL, depth=1))
        self._closed = threading.Event()

    def close(self) -> None:
        self._closed.set()
        with self._lock:
            for goal in self.goals.values():
                goal.done.set()
        self._requests.shutdown(wait=False, cancel_futures=True)

    def _on_thread(self, job: Any) -> None:
        if not self._results.acquire(blocking=False):
            log.warning("get_result: too many open result queries")
            return

        def run() -> None:
            try:
                job()
            finally:
                self._results.release()
        threading.Thread(target=run, daemon=True, name="robodcn-ros2-result").start()

    # -- status -------------------------------------------------------------------------

    def _set(self, goal: Goal, status: int, code: int | None = None, text: str = "") -> None:
        with self._lock:
            if goal.status not in ACTIVE:
                return
            goal.status = status
            if code is not None:
                goal.result = {"error_code": code, "error_string": text}
            if status not in ACTIVE:
                goal.done.set()
            while len(self.goals) > KEEP_GOALS:
                oldest = next(iter(self.goals.values()))
                if oldest.status in ACTIVE:
                    break
                self.goals.popitem(last=False)
            status_list = [{"goal_info": g.info, "status": g.status}
                           for g in self.goals.values()]
        self._status.publish({"status_list": status_list})

    def _active(self) -> list[Goal]:
        with self._lock:
            return [g for g in self.goals.values() if g.status in ACTIVE]

    def preempt(self, why: str) -> None:
        """End every active goal as CANCELED (``why`` in its result) and stop its move."""
        for goal in self._active():
            goal.preempted = why
            goal.cancel.set()

    # -- send_goal ----------------------------------------------------------------------

    def _send_goal(self, request: dict[str, Any]) -> dict[str, Any]:
        uuid = bytes(request["goal_id"]["uuid"])
        goal = Goal(uuid, self._stamp(), request["goal"])
        names = list(goal.goal["trajectory"]["joint_names"])
        accepted = sorted(names) == sorted(self.arm.joint_names) and len(set(names)) == len(names)
        with self._lock:
            self.goals[uuid] = goal
        if not accepted:
            goal.result = {"error_code": INVALID_JOINTS, "error_string": (
                f"joints {names} are not arm {self.arm.name!r}'s: "
                f"{list(self.arm.joint_names)}")}
            goal.status = ABORTED
            goal.done.set()
            log.info("goal rejected: %s", goal.result["error_string"])
            return {"accepted": False, "stamp": goal.stamp}
        for other in self._active():  # a new goal preempts the running ones
            if other is not goal:
                other.preempted = "preempted by a new goal"
                other.cancel.set()
        self._set(goal, ACCEPTED)
        threading.Thread(target=self._execute, args=(goal,), daemon=True,
                         name="robodcn-ros2-goal").start()
        return {"accepted": True, "stamp": goal.stamp}

    def _execute(self, goal: Goal) -> None:
        with self._starting:  # one goal starts at a time; a preempted one starts not at all
            if goal.cancel.is_set():
                self._set(goal, CANCELED, SUCCESSFUL, goal.preempted or "canceled")
                return
            if not stop_and_wait(self.server):
                self._set(goal, ABORTED, INVALID_GOAL, "the running move did not stop in time")
                return
            started = self._start(goal)
        if started:
            self._monitor(goal)

    def _start(self, goal: Goal) -> bool:
        """Start ``goal``'s move (EXECUTING), or abort it INVALID_GOAL with the reason."""
        body = trajectory_body(self.server, goal.goal["trajectory"])
        try:
            payload = json.dumps(body, allow_nan=False).encode()
        except ValueError:
            self._set(goal, ABORTED, INVALID_GOAL, "the trajectory holds NaN or infinity")
            return False
        answer = dispatch.call(self.server, "start_move", payload)
        if answer["status"] != 202:
            error = answer["body"].get("error", {}) if isinstance(answer["body"], dict) else {}
            text = f"{error.get('message', answer['body'])}"
            if error.get("field"):
                text += f" (field {error['field']})"
            self._set(goal, ABORTED, INVALID_GOAL, text)
            return False
        goal.move_id = answer["body"]["id"]
        self._set(goal, EXECUTING)
        return True

    # -- execution ----------------------------------------------------------------------

    def _monitor(self, goal: Goal) -> None:
        controller = self.server.controller
        assert controller is not None and goal.move_id is not None
        record = controller.move(goal.move_id)
        trajectory = record.trajectory
        path_tol = _tolerances(goal.goal.get("path_tolerance", []))
        names = list(self.arm.joint_names)
        period = 1.0 / FEEDBACK_HZ
        stopping = False
        while not self._closed.is_set():
            info = dispatch.call(self.server, "get_move", None, {"id": goal.move_id})["body"]
            status = info.get("status")
            if status not in ("queued", "running", "paused"):
                break
            if goal.cancel.is_set() and not stopping:
                stopping = True
                self._set(goal, CANCELING)
                dispatch.call(self.server, "stop", b'{"mode": "smooth"}')
            state = dispatch.call(self.server, "state", None)
            if state["status"] == 200 and status == "running":
                elapsed = float(info.get("elapsed") or 0.0)
                i = min(int(np.searchsorted(trajectory.t, elapsed)), len(trajectory.t) - 1)
                desired = np.asarray(trajectory.joints[i], dtype=float)
                actual = np.asarray(state["body"]["joints"], dtype=float)
                error = desired - actual
                self._feedback.publish({"goal_id": {"uuid": goal.uuid}, "feedback": {
                    "header": {"stamp": self._stamp(), "frame_id": ""},
                    "joint_names": names, "desired": _point(desired, elapsed),
                    "actual": _point(actual, elapsed), "error": _point(error, elapsed)}})
                worst = [(n, abs(e), path_tol[n]) for n, e in zip(names, error, strict=True)
                         if n in path_tol and abs(e) > path_tol[n]]
                if worst and not stopping:
                    n, e, tol = worst[0]
                    dispatch.call(self.server, "stop", b'{"mode": "hold"}')
                    self._wait_free()
                    self._set(goal, ABORTED, PATH_TOLERANCE_VIOLATED,
                              f"joint {n} off its path by {e:.4f} rad, tolerance {tol:g} rad")
                    return
            time.sleep(period)
        if goal.cancel.is_set():
            self._set(goal, CANCELED, SUCCESSFUL, goal.preempted or "canceled")
            return
        if status not in ("done", "degraded"):
            reason = (info.get("error") or {}).get("message") or status
            self._set(goal, ABORTED, PATH_TOLERANCE_VIOLATED,
                      f"move {goal.move_id} ended {status}: {reason}")
            return
        self._finish(goal)

    def _wait_free(self, timeout: float = 5.0) -> None:
        controller = self.server.controller
        deadline = time.monotonic() + timeout
        while controller is not None and controller.busy and time.monotonic() < deadline:
            time.sleep(0.01)

    def _finish(self, goal: Goal) -> None:
        """SUCCEEDED when every joint is within its goal tolerance of the last point by
        ``goal_time_tolerance`` after the end, else GOAL_TOLERANCE_VIOLATED."""
        trajectory = goal.goal["trajectory"]
        last = dict(zip(trajectory["joint_names"], trajectory["points"][-1]["positions"],
                        strict=True))
        tol = _tolerances(goal.goal.get("goal_tolerance", []))
        wait = max(0.0, goal.goal.get("goal_time_tolerance", {}).get("sec", 0)
                   + goal.goal.get("goal_time_tolerance", {}).get("nanosec", 0) * 1e-9)
        deadline = time.monotonic() + wait
        while True:
            state = dispatch.call(self.server, "state", None)
            if state["status"] != 200:
                self._set(goal, ABORTED, GOAL_TOLERANCE_VIOLATED, "the arm's state cannot be "
                          f"read: {state['body']}")
                return
            here = dict(zip(self.arm.joint_names, state["body"]["joints"], strict=True))
            off = [(n, abs(here[n] - last[n]), t) for n, t in tol.items()
                   if abs(here[n] - last[n]) > t]
            if not off:
                self._set(goal, SUCCEEDED, SUCCESSFUL, "")
                return
            if time.monotonic() >= deadline:
                n, e, t = off[0]
                self._set(goal, ABORTED, GOAL_TOLERANCE_VIOLATED,
                          f"joint {n} ended {e:.4f} rad from its goal, tolerance {t:g} rad")
                return
            time.sleep(0.02)

    # -- cancel_goal, get_result ----------------------------------------------------------

    def _cancel_goal(self, request: dict[str, Any]) -> dict[str, Any]:
        info = request["goal_info"]
        uuid = bytes(info["goal_id"]["uuid"])
        with self._lock:
            if uuid == ZERO_UUID:
                chosen = [g for g in self.goals.values() if g.status in ACTIVE]
                code = ERROR_NONE
            elif uuid not in self.goals:
                chosen, code = [], ERROR_UNKNOWN_GOAL_ID
            elif self.goals[uuid].status not in ACTIVE:
                chosen, code = [], ERROR_GOAL_TERMINATED
            else:
                chosen, code = [self.goals[uuid]], ERROR_NONE
        for goal in chosen:
            goal.cancel.set()
        return {"return_code": code, "goals_canceling": [g.info for g in chosen]}

    def _get_result(self, request: dict[str, Any]) -> dict[str, Any]:
        uuid = bytes(request["goal_id"]["uuid"])
        with self._lock:
            goal = self.goals.get(uuid)
        if goal is None:
            return {"status": UNKNOWN, "result": {"error_code": SUCCESSFUL,
                                                  "error_string": "unknown goal"}}
        goal.done.wait(RESULT_WAIT_S)
        return {"status": goal.status, "result": goal.result}
