"""``robodcn serve --ros2`` against a test-side ROS 2 peer (:mod:`ros2_peer`: rmw_zenoh's
wire rules, rosbags' CDR) on loopback, the arm simulated: the graph tokens, /joint_states,
/<controller>/joint_trajectory and the FollowJointTrajectory action."""

from __future__ import annotations

import os
import struct
import time
from typing import Any

import numpy as np
import pytest
from http_helpers import ARM, HOME
from ros2_peer import FJT, JOINT_STATE_HASH, RosPeer
from zenoh_helpers import peer, wait_for, zenoh_arm

from robodcn import kinematics

pytest_plugins = ["http_helpers"]

ACTION = "/arm_controller/follow_joint_trajectory/_action"
HOME_Q = [float(v) for v in kinematics.ik(ARM.links, [HOME], ARM.elbow)[0]]
NAMES = list(ARM.joint_names)


@pytest.fixture
def ros() -> Any:
    with zenoh_arm("left", ros2=True) as (server, native, endpoint), peer(endpoint) as s:
        time.sleep(0.3)
        yield server, native, RosPeer(s)


def _points(q0: list[float], q1: list[float], duration: float = 1.0) -> list[dict[str, Any]]:
    return [{"positions": q0, "time_from_start": {"sec": 0, "nanosec": 0}},
            {"positions": q1, "time_from_start": {"sec": int(duration),
                                                  "nanosec": int(duration % 1 * 1e9)}}]


def _goal(points: list[dict[str, Any]], names: list[str] = NAMES, **extra: Any
          ) -> dict[str, Any]:
    return {"goal_id": {"uuid": os.urandom(16)},
            "goal": {"trajectory": {"joint_names": names, "points": points}, **extra}}


def _result(rp: RosPeer, uuid: bytes) -> Any:
    response, _ = rp.call(f"{ACTION}/get_result", f"{FJT}_GetResult",
                          {"goal_id": {"uuid": uuid}})
    return response


def _target() -> list[float]:
    return [HOME_Q[0] + 0.3, HOME_Q[1] - 0.2, HOME_Q[2]]


def test_graph_tokens(ros: Any) -> None:
    _, _, rp = ros
    tokens = rp.graph()
    node = [t for t in tokens if "/NN/" in t]
    assert len(node) == 1 and node[0].endswith("/NN/%/%/robodcn_left")
    entity = {t.split("/")[5]: [] for t in tokens}
    for t in tokens:
        entity[t.split("/")[5]].append(t)
    assert any(t.endswith(f"/MP/%/%/robodcn_left/%joint_states/sensor_msgs::msg::dds_::"
                          f"JointState_/{JOINT_STATE_HASH}/::,10:,:,:,,") for t in tokens)
    assert any("/MS/%/%/robodcn_left/%arm_controller%joint_trajectory/trajectory_msgs::msg::"
               "dds_::JointTrajectory_/RIHS01_179b33eb" in t for t in tokens)
    for part in ("send_goal", "get_result", "cancel_goal"):
        assert any(f"/SS/%/%/robodcn_left/%arm_controller%follow_joint_trajectory%_action%"
                   f"{part}/" in t for t in tokens), part
    status = [t for t in tokens if "_action%status/" in t]
    assert len(status) == 1 and status[0].endswith("/:1:,1:,:,:,,")  # transient local, 1


def test_joint_states(ros: Any) -> None:
    server, _, rp = ros
    got = rp.subscribe("/joint_states", "sensor_msgs/msg/JointState")
    wait_for(lambda: len(got) >= 5, 5, "5 joint states at rest (10 Hz)")
    _, msg, att = got[-1]
    assert msg["name"] == NAMES
    assert msg["position"] == pytest.approx(server.controller.state().joints, abs=1e-9)
    assert len(att) == 33 and att[16] == 16
    seqs = [struct.unpack_from("<q", a)[0] for _, _, a in got]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)
    stamp_ns = struct.unpack_from("<q", att, 8)[0]
    assert abs(stamp_ns / 1e9 - time.time()) < 2


@pytest.mark.serial  # rates and times on the real clock
def test_joint_trajectory_topic_moves_the_arm(ros: Any) -> None:
    server, _, rp = ros
    q0 = list(server.controller.state().joints)
    target = _target()
    got = rp.subscribe("/joint_states", "sensor_msgs/msg/JointState")
    rp.publish("/arm_controller/joint_trajectory", "trajectory_msgs/msg/JointTrajectory",
               {"joint_names": NAMES, "points": _points(q0, target, 1.0)})
    wait_for(lambda: server.controller.moves() and not server.controller.busy
             and server.controller.moves()[-1].status in ("done", "degraded"), 15,
             "the trajectory to be played")
    assert server.controller.state().joints == pytest.approx(target, abs=0.02)
    moving = [t for t, m, _ in got if m["position"] != pytest.approx(q0, abs=1e-6)]
    gaps = np.diff(moving)
    assert len(gaps) > 10 and np.median(gaps) <= 1 / 50 + 0.005


def test_bad_trajectories_move_nothing(ros: Any) -> None:
    server, native, rp = ros
    q0 = list(server.controller.state().joints)
    rp.publish("/arm_controller/joint_trajectory", "trajectory_msgs/msg/JointTrajectory",
               {}, raw=b"\x00\x01\x00\x00\xff\xff\xff\x7f")
    rp.publish("/arm_controller/joint_trajectory", "trajectory_msgs/msg/JointTrajectory",
               {"joint_names": ["x", "y", "z"], "points": _points(q0, q0)})
    rp.publish("/arm_controller/joint_trajectory", "trajectory_msgs/msg/JointTrajectory",
               {"joint_names": NAMES, "points": _points(q0, [float("nan")] * 3)})
    rp.publish("/arm_controller/joint_trajectory", "trajectory_msgs/msg/JointTrajectory",
               {"joint_names": NAMES, "points": _points(q0, [q0[0] + 3.0, *q0[1:]], 0.05)})
    wait_for(lambda: native.ros.refused >= 3, 5, "three refusals")
    assert native.ros.node.bad_payloads == 1  # the payload that does not decode
    assert server.controller.moves() == []
    assert server.controller.state().joints == pytest.approx(q0, abs=1e-9)


@pytest.mark.serial  # rates and times on the real clock
def test_action_succeeds_with_feedback(ros: Any) -> None:
    server, _, rp = ros
    q0 = list(server.controller.state().joints)
    feedback = rp.subscribe(f"{ACTION}/feedback", f"{FJT}_FeedbackMessage")
    goal = _goal(_points(q0, _target(), 1.0),
                 goal_tolerance=[{"name": n, "position": 0.02} for n in NAMES],
                 goal_time_tolerance={"sec": 1, "nanosec": 0})
    response, att = rp.call(f"{ACTION}/send_goal", f"{FJT}_SendGoal", goal)
    assert response["accepted"] is True
    assert att[:8] == struct.pack("<q", rp.seq) and att[17:] == rp.gid  # its request's
    result = _result(rp, goal["goal_id"]["uuid"])
    assert result["status"] == 4, result
    assert result["result"]["error_code"] == 0
    mine = [(t, m) for t, m, _ in feedback if m["goal_id"]["uuid"] == goal["goal_id"]["uuid"]]
    assert len(mine) >= 8  # ≥ 10 Hz over a 1 s move
    assert np.median(np.diff([t for t, _ in mine])) <= 0.1
    last = mine[-1][1]["feedback"]
    assert last["joint_names"] == NAMES
    err = np.subtract(last["desired"]["positions"], last["actual"]["positions"])
    assert last["error"]["positions"] == pytest.approx(err, abs=1e-9)
    late = rp.subscribe_late(f"{ACTION}/status", "action_msgs/msg/GoalStatusArray")
    wait_for(lambda: late, 5, "the transient-local status")
    statuses = {bytes(s["goal_info"]["goal_id"]["uuid"]): s["status"]
                for s in late[-1]["status_list"]}
    assert statuses[goal["goal_id"]["uuid"]] == 4


def test_action_refusals(ros: Any) -> None:
    server, _, rp = ros
    q0 = list(server.controller.state().joints)
    wrong = _goal(_points(q0, q0), names=["shoulder", "elbow", "wrist_x"])
    response, _ = rp.call(f"{ACTION}/send_goal", f"{FJT}_SendGoal", wrong)
    assert response["accepted"] is False
    result = _result(rp, wrong["goal_id"]["uuid"])
    assert result["result"]["error_code"] == -2 and "joints" in result["result"]["error_string"]
    beyond = _goal(_points(q0, [q0[0] + 3.0, *q0[1:]], 0.05))
    response, _ = rp.call(f"{ACTION}/send_goal", f"{FJT}_SendGoal", beyond)
    assert response["accepted"] is True
    result = _result(rp, beyond["goal_id"]["uuid"])
    assert result["status"] == 6 and result["result"]["error_code"] == -1
    assert result["result"]["error_string"]
    unknown = _result(rp, os.urandom(16))
    assert unknown["status"] == 0
    assert server.controller.moves() == []


@pytest.mark.serial  # rates and times on the real clock
def test_cancel_and_preempt(ros: Any) -> None:
    server, _, rp = ros
    q0 = list(server.controller.state().joints)
    first = _goal(_points(q0, _target(), 3.0))
    assert rp.call(f"{ACTION}/send_goal", f"{FJT}_SendGoal", first)[0]["accepted"]
    wait_for(lambda: server.controller.busy, 5, "the first goal to run")
    time.sleep(0.3)
    second = _goal(_points(q0, q0, 2.0))
    assert rp.call(f"{ACTION}/send_goal", f"{FJT}_SendGoal", second)[0]["accepted"]
    assert _result(rp, first["goal_id"]["uuid"])["status"] == 5  # preempted: canceled
    wait_for(lambda: server.controller.busy, 5, "the second goal to run")
    time.sleep(0.3)
    response, _ = rp.call(f"{ACTION}/cancel_goal", "action_msgs/srv/CancelGoal",
                          {"goal_info": {"goal_id": {"uuid": second["goal_id"]["uuid"]}}})
    assert response["return_code"] == 0 and len(response["goals_canceling"]) == 1
    result = _result(rp, second["goal_id"]["uuid"])
    assert result["status"] == 5
    assert not server.controller.busy
    assert server.controller.moves()[-1].status == "stopped"
    again, _ = rp.call(f"{ACTION}/cancel_goal", "action_msgs/srv/CancelGoal",
                       {"goal_info": {"goal_id": {"uuid": second["goal_id"]["uuid"]}}})
    assert again["return_code"] == 3  # terminated


@pytest.mark.serial  # times on the real clock
def test_header_stamp_in_the_future_delays_the_start(ros: Any) -> None:
    server, _, rp = ros
    q0 = list(server.controller.state().joints)
    start = time.time() + 0.8
    goal = _goal(_points(q0, _target(), 0.5))
    goal["goal"]["trajectory"]["header"] = {
        "stamp": {"sec": int(start), "nanosec": int(start % 1 * 1e9)}, "frame_id": ""}
    assert rp.call(f"{ACTION}/send_goal", f"{FJT}_SendGoal", goal)[0]["accepted"]
    assert _result(rp, goal["goal_id"]["uuid"])["status"] == 4
    records = server.controller.moves()[-1].execution.stream.records
    first_write = time.time() - (time.perf_counter() - records.at[0])
    assert start - 0.002 <= first_write <= start + 0.1  # + what a loaded host adds


def test_goals_back_to_back_the_newest_wins(ros: Any) -> None:
    server, _, rp = ros
    q0 = list(server.controller.state().joints)
    first = _goal(_points(q0, _target(), 1.0))
    second = _goal(_points(q0, q0, 0.5))
    assert rp.call(f"{ACTION}/send_goal", f"{FJT}_SendGoal", first)[0]["accepted"]
    assert rp.call(f"{ACTION}/send_goal", f"{FJT}_SendGoal", second)[0]["accepted"]
    assert _result(rp, first["goal_id"]["uuid"])["status"] == 5
    assert _result(rp, second["goal_id"]["uuid"])["status"] == 4
    assert server.controller.state().joints == pytest.approx(q0, abs=0.02)
