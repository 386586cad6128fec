"""``robodcn serve --ros2``: the service as the ROS 2 node ``robodcn_<arm>`` (Jazzy
interfaces, rmw_zenoh's wire), without rclpy or a ROS installation.

- ``/joint_states`` (``sensor_msgs/msg/JointState``): the arm's joint names, positions
  (rad), velocities (rad/s) and efforts (N·m; both empty where the feedback does not give
  them), with each state the Zenoh face publishes (100 Hz moving, 10 Hz at rest);
- ``/<controller>/joint_trajectory`` (``trajectory_msgs/msg/JointTrajectory``): played like
  the HTTP JointTrajectory body (``POST /v1/moves {"trajectory": …}``); a new one replaces
  the running one (that one stops smoothly first);
- the action ``/<controller>/follow_joint_trajectory``
  (``control_msgs/action/FollowJointTrajectory``), :class:`FollowJointTrajectoryServer`.

Moves go through the same operations as HTTP (:func:`robodcn.zenoh.dispatch.call`), so a
goal with NaN, unknown joints or beyond the limits is refused before anything moves.
"""

from __future__ import annotations

import logging
import re
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from robodcn.http.context import Service
from robodcn.zenoh import dispatch
from robodcn.zenoh.options import ZenohOptions
from robodcn.zenoh.ros2action import FollowJointTrajectoryServer
from robodcn.zenoh.ros2graph import Node
from robodcn.zenoh.ros2moves import stamp, stop_and_wait, trajectory_body

log = logging.getLogger("robodcn.ros2")

JOINT_STATE = "sensor_msgs/msg/JointState"
JOINT_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"


def node_name(arm_name: str) -> str:
    """``robodcn_<arm>`` with every character a ROS name does not take as ``_``."""
    return "robodcn_" + re.sub(r"[^A-Za-z0-9_]", "_", arm_name)


class RosNode:
    """The ROS 2 node of one service (``server``) on ``session``, beside its native face
    (whose state publication it rides on for ``/joint_states``)."""

    def __init__(self, server: Service, session: Any, options: ZenohOptions,
                 native: Any) -> None:
        self.server = server
        self.session = session
        self.options = options
        self.native = native
        self.controller_name = options.ros_controller
        self.name = node_name(options.name or server.arm.name)
        # one thread: JointTrajectory messages are played in arrival order
        self.work = ThreadPoolExecutor(1, thread_name_prefix="robodcn-ros2")
        #: JointTrajectory messages refused (bad joints, NaN, beyond the limits).
        self.refused = 0
        self.node: Node | None = None
        self.action: FollowJointTrajectoryServer | None = None

    def start(self) -> RosNode:
        node = Node(self.session, self.options.domain, self.name)
        self.node = node
        self._joint_states = node.publisher("/joint_states", JOINT_STATE)
        node.subscription(f"/{self.controller_name}/joint_trajectory", JOINT_TRAJECTORY,
                          lambda msg: self.work.submit(self._play, msg))
        self.action = FollowJointTrajectoryServer(
            self.server, node, f"/{self.controller_name}/follow_joint_trajectory")
        self.native.listeners.append(self._publish_joint_state)
        return self

    def close(self) -> None:
        if self._publish_joint_state in self.native.listeners:
            self.native.listeners.remove(self._publish_joint_state)
        if self.action is not None:
            self.action.close()
        if self.node is not None:
            self.node.close()
        self.work.shutdown(wait=False, cancel_futures=True)

    def __enter__(self) -> RosNode:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _publish_joint_state(self, state: dict[str, Any]) -> None:
        self._joint_states.publish({
            "header": {"stamp": stamp(), "frame_id": ""},
            "name": list(state["joint_names"]), "position": list(state["joints"]),
            # empty when the feedback does not give them (JointState's convention)
            "velocity": list(state.get("velocities") or ()),
            "effort": list(state.get("efforts") or ())})

    def _play(self, message: dict[str, Any]) -> None:
        """A JointTrajectory from the topic: replaces the running move (and goal)."""
        body = trajectory_body(self.server, message)
        if self.action is not None:
            self.action.preempt("a JointTrajectory on the topic replaced it")
        if not stop_and_wait(self.server):
            self.refused += 1
            log.warning("joint_trajectory: the running move did not stop in time")
            return
        answer = dispatch.call(self.server, "start_move", _json(body))
        if answer["status"] != 202:
            self.refused += 1
            log.warning("joint_trajectory refused (%s): %s", answer["status"],
                        answer["body"].get("error", {}).get("message"))


def _json(body: dict[str, Any]) -> bytes:
    import json

    return json.dumps(body, allow_nan=True).encode()
