"""Moves of the ROS 2 node through the service's operations: a ROS JointTrajectory as the
``POST /v1/moves`` body, a smooth stop before a replacement, builtin_interfaces times."""

from __future__ import annotations

import time
from typing import Any

from robodcn.http.context import Service
from robodcn.zenoh import dispatch

#: Seconds a new trajectory waits for the one it replaces to stop.
REPLACE_WAIT_S = 5.0


def stamp(t: float | None = None) -> dict[str, int]:
    """builtin_interfaces/Time of UNIX time ``t`` (now by default)."""
    ns = time.time_ns() if t is None else int(t * 1e9)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def seconds(duration: dict[str, int]) -> float:
    """A builtin_interfaces Duration/Time in seconds."""
    return duration.get("sec", 0) + duration.get("nanosec", 0) * 1e-9


def trajectory_body(server: Service, trajectory: dict[str, Any]) -> dict[str, Any]:
    """The ``POST /v1/moves`` body of a ROS JointTrajectory: joint names and points as
    JSON; a first point after t = 0 gets the present joints at t = 0 before it (as
    joint_trajectory_controller starts from where the arm is); a ``header.stamp`` in the
    future is the move's ``start_at`` (joint_trajectory_controller's delayed start; zero or
    past: at once)."""
    names = list(trajectory.get("joint_names", []))
    points = [{key: list(p[key]) for key in ("positions", "velocities", "accelerations")}
              | {"time_from_start": dict(p["time_from_start"])}
              for p in trajectory.get("points", [])]
    if points and seconds(points[0]["time_from_start"]) > 0 and \
            sorted(names) == sorted(server.arm.joint_names):
        state = dispatch.call(server, "state", None)
        if state["status"] == 200:
            here = dict(zip(server.arm.joint_names, state["body"]["joints"], strict=True))
            start = {"positions": [here[n] for n in names],
                     "time_from_start": {"sec": 0, "nanosec": 0}}
            if points[0]["velocities"]:
                start["velocities"] = [0.0] * len(names)
                if points[0]["accelerations"]:
                    start["accelerations"] = [0.0] * len(names)
            points.insert(0, start)
    for p in points:
        for key in ("velocities", "accelerations"):
            if not p.get(key):
                p.pop(key, None)
    body: dict[str, Any] = {"trajectory": {"joint_names": names, "points": points}}
    start = seconds(trajectory.get("header", {}).get("stamp", {}))
    if start > time.time():
        body["start_at"] = start
    return body


def stop_and_wait(server: Service, timeout: float = REPLACE_WAIT_S) -> bool:
    """Stop the running move smoothly and wait until the arm is free; whether it is."""
    controller = server.controller
    if controller is None:
        return False
    if controller.busy:
        dispatch.call(server, "stop", b'{"mode": "smooth"}')
    deadline = time.monotonic() + timeout
    while controller.busy and time.monotonic() < deadline:
        time.sleep(0.01)
    return not controller.busy
