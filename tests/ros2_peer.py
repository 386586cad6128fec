"""A test-side ROS 2 peer on rmw_zenoh's wire, written from the wire rules (ros2-zenoh.md)
with the independent codec (rosbags, :mod:`ros2_oracle`): its keys are spelled out here with
the golden hashes of test_ros2_wire (action parts: robodcn's hashes, which that file checks
against rosidl's), its payloads are rosbags' CDR, its attachments packed here."""

from __future__ import annotations

import os
import struct
import threading
import time
from typing import Any

import ros2_oracle
import zenoh

from robodcn.ros2.typehash import type_hash

JOINT_STATE_HASH = "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e"
JOINT_TRAJECTORY_HASH = "RIHS01_179b33eba59d676f6d967ac71fe35e7ca2f64b2f3928f4a018cec115e213796e"
STATUS_HASH = "RIHS01_6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e"
FJT = "control_msgs/action/FollowJointTrajectory"


def key(domain: int, name: str, dds: str, hash_: str) -> str:
    return f"{domain}/{name.strip('/')}/{dds}/{hash_}"


def dds(type_name: str) -> str:
    pkg, kind, name = type_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def hash_of(type_name: str) -> str:
    return {"sensor_msgs/msg/JointState": JOINT_STATE_HASH,
            "trajectory_msgs/msg/JointTrajectory": JOINT_TRAJECTORY_HASH,
            "action_msgs/msg/GoalStatusArray": STATUS_HASH}.get(type_name) or type_hash(type_name)


class RosPeer:
    """A ROS 2 client on ``session`` in ``domain``."""

    def __init__(self, session: Any, domain: int = 0) -> None:
        self.session = session
        self.domain = domain
        self.gid = os.urandom(16)
        self.seq = 0
        self._lock = threading.Lock()

    def _attachment(self) -> bytes:
        with self._lock:
            self.seq += 1
            return struct.pack("<qqB", self.seq, time.time_ns(), 16) + self.gid

    def key(self, name: str, type_name: str) -> str:
        return key(self.domain, name, dds(type_name), hash_of(type_name))

    def graph(self) -> list[str]:
        return [str(r.ok.key_expr) for r in
                self.session.liveliness().get(f"@ros2_lv/{self.domain}/**", timeout=3)
                if r.ok is not None]

    def subscribe(self, topic: str, type_name: str) -> list[tuple[float, Any, bytes]]:
        """(arrival time, rosbags message as plain dicts, attachment) per sample."""
        got: list[tuple[float, Any, bytes]] = []

        def on(sample: Any) -> None:
            msg = ros2_oracle.to_plain(ros2_oracle.decode(type_name, sample.payload.to_bytes()))
            att = sample.attachment.to_bytes() if sample.attachment is not None else b""
            got.append((time.monotonic(), msg, att))

        self.session.declare_subscriber(self.key(topic, type_name), on)
        return got

    def subscribe_late(self, topic: str, type_name: str) -> list[Any]:
        """A transient-local subscription (history of late-joined publishers)."""
        got: list[Any] = []
        zenoh.ext.declare_advanced_subscriber(
            self.session, self.key(topic, type_name),
            lambda s: got.append(ros2_oracle.to_plain(
                ros2_oracle.decode(type_name, s.payload.to_bytes()))),
            history=zenoh.ext.HistoryConfig(detect_late_publishers=True))
        return got

    def publish(self, topic: str, type_name: str, message: dict[str, Any],
                *, raw: bytes | None = None) -> None:
        payload = raw if raw is not None else ros2_oracle.encode_plain(type_name, message)
        self.session.put(self.key(topic, type_name), payload, attachment=self._attachment())

    def call(self, service: str, type_name: str, request: dict[str, Any],
             timeout: float = 30.0) -> tuple[Any, bytes]:
        """(response as plain dicts, reply attachment) of one service call."""
        payload = ros2_oracle.encode_plain(f"{type_name}_Request", request)
        attachment = self._attachment()
        for reply in self.session.get(self.key(service, type_name), payload=payload,
                                      attachment=attachment,
                                      target=zenoh.QueryTarget.ALL_COMPLETE, timeout=timeout):
            assert reply.ok is not None, reply.err
            response = ros2_oracle.to_plain(ros2_oracle.decode(
                f"{type_name}_Response", reply.ok.payload.to_bytes()))
            return response, reply.ok.attachment.to_bytes()
        raise AssertionError(f"no reply from {service}")
