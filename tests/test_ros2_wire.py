"""ROS 2 wire pieces against golden values and an independent codec (rosbags).

Golden type hashes: rmw_zenoh's design document (String, AddTwoInts), the Jazzy values of
JointState, JointTrajectory and GoalStatusArray (rosbags' Jazzy store, agreeing with the
design document), ServiceEventInfo and a whole action (``GoalTarget``, test data) from
rosidl-generated C sources (``*__description.c``) of a Jazzy build. CDR: every payload our
codec writes is read by rosbags into the same values and written back by rosbags to the
same bytes; rosbags' payloads decode to the same values with ours.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path

import pytest
import ros2_oracle
from hypothesis import given
from hypothesis import strategies as st

from robodcn.ros2 import CdrError, cdr, idl, typehash, wire

DATA = Path(__file__).parent / "data" / "ros2"

GOLDEN = {
    "std_msgs/msg/String":
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18",
    "example_interfaces/srv/AddTwoInts":
        "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a",
    "sensor_msgs/msg/JointState":
        "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e",
    "trajectory_msgs/msg/JointTrajectory":
        "RIHS01_179b33eba59d676f6d967ac71fe35e7ca2f64b2f3928f4a018cec115e213796e",
    "action_msgs/msg/GoalStatusArray":
        "RIHS01_6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e",
    "service_msgs/msg/ServiceEventInfo":
        "RIHS01_41bcbbe07a75c9b52bc96bfd5c24d7f0fc0a08c0cb7921b3373c5732345a6f45",
    "builtin_interfaces/msg/Time":
        "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
    "unique_identifier_msgs/msg/UUID":
        "RIHS01_1b8e8aca958cbea28fe6ef60bf6c19b683c97a9ef60bb34752067d0f2f7ab437",
    "std_msgs/msg/Header":
        "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01",
}

#: rosidl's hashes of the parts of goal_target/action/GoalTarget (a Jazzy build's
#: goal_target__description.c), the action in tests/data/ros2.
GOAL_TARGET = {
    "Result": "RIHS01_880ec2b237ad3745195b1939591562a00c1168f21e76b1b3a9a7c44220dd8267",
    "SendGoal": "RIHS01_0a1aca7e3cbf3cb1d424dc12fd5b5761d226138257fc8d4ca454cbea0c4c1a29",
    "GetResult": "RIHS01_917b822716d5c353ab389b9f2d57ea4d02f444ab7af01e14c984c1c0de9d5554",
    "FeedbackMessage":
        "RIHS01_c9900b5de3becb5c29a788393cdd2e19117a18b7415dff30664c3ef58eb79d62",
}


@pytest.mark.parametrize("type_name", sorted(GOLDEN))
def test_type_hash_golden(type_name):
    assert typehash.type_hash(type_name) == GOLDEN[type_name]


@pytest.mark.parametrize("type_name", [
    "sensor_msgs/msg/JointState", "trajectory_msgs/msg/JointTrajectoryPoint",
    "trajectory_msgs/msg/MultiDOFJointTrajectory", "action_msgs/msg/GoalStatus",
    "action_msgs/msg/GoalInfo", "geometry_msgs/msg/Transform", "std_msgs/msg/Header",
    "builtin_interfaces/msg/Duration"])
def test_message_hash_agrees_with_rosbags(type_name):
    assert typehash.type_hash(type_name) == ros2_oracle.store().hash_rihs01(type_name)


def test_action_part_hashes_match_rosidl():
    """A whole action's derived types (services with their event message, the feedback
    message) hash as rosidl hashes them."""
    types = dict(idl.registry())
    for name, pkg in (("PointStamped", "geometry_msgs"), ("Point", "geometry_msgs"),
                      ("Float32", "std_msgs")):
        types.update(idl.expand(f"{pkg}/msg/{name}", (DATA / f"{name}.msg").read_text()))
    types.update(idl.expand("goal_target/action/GoalTarget",
                            (DATA / "GoalTarget.action").read_text()))
    got = {part: typehash.type_hash(f"goal_target/action/GoalTarget_{part}", types)
           for part in GOAL_TARGET}
    assert got == GOAL_TARGET


def test_unknown_type_is_named():
    with pytest.raises(idl.InputError, match="nav_msgs/msg/Odometry"):
        typehash.type_hash("nav_msgs/msg/Odometry")


def test_keys_match_design_document():
    assert wire.topic_key(0, "/chatter", "std_msgs/msg/String") == (
        "0/chatter/std_msgs::msg::dds_::String_/" + GOLDEN["std_msgs/msg/String"])
    assert wire.topic_key(2, "/add_two_ints", "example_interfaces/srv/AddTwoInts") == (
        "2/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/"
        + GOLDEN["example_interfaces/srv/AddTwoInts"])
    key = wire.topic_key(0, "/arm_controller/follow_joint_trajectory/_action/send_goal",
                         "control_msgs/action/FollowJointTrajectory_SendGoal")
    assert key.startswith("0/arm_controller/follow_joint_trajectory/_action/send_goal/"
                          "control_msgs::action::dds_::FollowJointTrajectory_SendGoal_/RIHS01_")
    with pytest.raises(idl.InputError, match="fully qualified"):
        wire.topic_key(0, "chatter", "std_msgs/msg/String")


def test_liveliness_tokens_match_design_document():
    node = wire.Node(domain=2, zid="8b20917502ee955ac4476e0266340d5c", node_id=0,
                     name="talker")
    assert node.node_token() == "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/0/NN/%/%/talker"
    token = node.entity_token(10, "MP", "/chatter", "std_msgs/msg/String", wire.QoS(depth=7))
    assert token == ("@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/"
                     "%chatter/std_msgs::msg::dds_::String_/"
                     + GOLDEN["std_msgs/msg/String"] + "/::,7:,:,:,,")
    status = wire.QoS(durability=wire.TRANSIENT_LOCAL, depth=1)
    assert status.text() == ":1:,1:,:,:,,"
    spaced = wire.Node(0, "ab", 3, "robodcn_left", namespace="/lab/bench")
    assert spaced.node_token() == "@ros2_lv/0/ab/3/3/NN/%/%lab%bench/robodcn_left"


def test_attachment_layout():
    gid = bytes(range(16))
    data = wire.attachment(7, 1_700_000_000_123_456_789, gid)
    assert len(data) == 33
    assert data[:8] == (7).to_bytes(8, "little")
    assert data[8:16] == (1_700_000_000_123_456_789).to_bytes(8, "little")
    assert data[16] == 16 and data[17:] == gid
    assert wire.read_attachment(data) == (7, 1_700_000_000_123_456_789, gid)
    with pytest.raises(idl.InputError, match="attachment"):
        wire.read_attachment(data[:-1])
    with pytest.raises(idl.InputError, match="GID"):
        wire.attachment(1, 2, b"short")


def test_joint_state_bytes_by_hand():
    """The layout written out: header, Time (8), frame_id, names, then float64 arrays
    aligned to 8 from the byte after the encapsulation header."""
    msg = {"header": {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": ""},
           "name": ["j1"], "position": [0.5], "velocity": [], "effort": []}
    got = cdr.encode("sensor_msgs/msg/JointState", msg)
    want = (b"\x00\x01\x00\x00" + struct.pack("<iI", 1, 2) + struct.pack("<I", 1) + b"\x00"
            + b"\x00" * 3 + struct.pack("<I", 1) + struct.pack("<I", 3) + b"j1\x00"
            + b"\x00" + struct.pack("<I", 1) + struct.pack("<d", 0.5)  # 8-aligned at 32
            + struct.pack("<I", 0) + struct.pack("<I", 0))
    assert got == want
    odd = cdr.encode("sensor_msgs/msg/JointState", {**msg, "name": ["j123"]})
    assert odd[4 + 32:4 + 48] == struct.pack("<I", 1) + bytes(4) + struct.pack("<d", 0.5)


finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
names = st.text(st.characters(codec="utf-8", exclude_characters="\x00"), max_size=12)
stamps = st.fixed_dictionaries({"sec": st.integers(-2**31, 2**31 - 1),
                                "nanosec": st.integers(0, 999_999_999)})
headers = st.fixed_dictionaries({"stamp": stamps, "frame_id": names})
points = st.fixed_dictionaries({
    "positions": st.lists(finite, max_size=6), "velocities": st.lists(finite, max_size=6),
    "accelerations": st.lists(finite, max_size=6), "effort": st.lists(finite, max_size=6),
    "time_from_start": stamps})
uuids = st.fixed_dictionaries({"uuid": st.binary(min_size=16, max_size=16)})
tolerances = st.fixed_dictionaries({"name": names, "position": finite, "velocity": finite,
                                    "acceleration": finite})


def _agrees(type_name, msg):
    ours = cdr.encode(type_name, msg)
    theirs = ros2_oracle.decode(type_name, ours)
    assert ros2_oracle.encode(theirs, type_name) == ours
    assert cdr.decode(type_name, ours) == ros2_oracle.to_plain(theirs)
    return ours


@given(st.fixed_dictionaries({
    "header": headers, "name": st.lists(names, max_size=5),
    "position": st.lists(finite, max_size=5), "velocity": st.lists(finite, max_size=5),
    "effort": st.lists(finite, max_size=5)}))
def test_joint_state_agrees_with_rosbags(msg):
    decoded = cdr.decode("sensor_msgs/msg/JointState", _agrees("sensor_msgs/msg/JointState",
                                                               msg))
    assert decoded == msg


@given(st.fixed_dictionaries({"header": headers, "joint_names": st.lists(names, max_size=4),
                              "points": st.lists(points, max_size=4)}))
def test_joint_trajectory_agrees_with_rosbags(msg):
    assert cdr.decode("trajectory_msgs/msg/JointTrajectory",
                      _agrees("trajectory_msgs/msg/JointTrajectory", msg)) == msg


@given(st.fixed_dictionaries({
    "goal_id": uuids,
    "goal": st.fixed_dictionaries({
        "trajectory": st.fixed_dictionaries({"header": headers,
                                             "joint_names": st.lists(names, max_size=3),
                                             "points": st.lists(points, max_size=3)}),
        "path_tolerance": st.lists(tolerances, max_size=2),
        "goal_tolerance": st.lists(tolerances, max_size=2),
        "goal_time_tolerance": stamps})}))
def test_send_goal_request_agrees_with_rosbags(msg):
    _agrees("control_msgs/action/FollowJointTrajectory_SendGoal_Request", msg)


@given(st.fixed_dictionaries({
    "goal_id": uuids,
    "feedback": st.fixed_dictionaries({"header": headers,
                                       "joint_names": st.lists(names, max_size=3),
                                       "desired": points, "actual": points,
                                       "error": points})}))
def test_feedback_agrees_with_rosbags(msg):
    _agrees("control_msgs/action/FollowJointTrajectory_FeedbackMessage", msg)


@given(st.lists(st.fixed_dictionaries({
    "goal_info": st.fixed_dictionaries({"goal_id": uuids, "stamp": stamps}),
    "status": st.integers(0, 6)}), max_size=4))
def test_status_array_agrees_with_rosbags(statuses):
    _agrees("action_msgs/msg/GoalStatusArray", {"status_list": statuses})


def test_service_parts_agree_with_rosbags():
    info = {"goal_id": {"uuid": bytes(range(16))}, "stamp": {"sec": 3, "nanosec": 4}}
    _agrees("action_msgs/srv/CancelGoal_Request", {"goal_info": info})
    _agrees("action_msgs/srv/CancelGoal_Response", {"return_code": 0,
                                                    "goals_canceling": [info, info]})
    _agrees("control_msgs/action/FollowJointTrajectory_GetResult_Response",
            {"status": 4, "result": {"error_code": -5, "error_string": "goal ✗ 0.2 rad"}})
    _agrees("control_msgs/action/FollowJointTrajectory_SendGoal_Response",
            {"accepted": True, "stamp": {"sec": 9, "nanosec": 1}})


def test_missing_fields_are_zero():
    payload = cdr.encode("sensor_msgs/msg/JointState", {"name": ["a"]})
    got = ros2_oracle.to_plain(ros2_oracle.decode("sensor_msgs/msg/JointState", payload))
    assert got["name"] == ["a"] and got["position"] == [] and got["header"]["frame_id"] == ""


@pytest.mark.parametrize("cut", [0, 3, 4, 9, 20, -1])
def test_bad_payloads_raise_cdr_error(cut):
    good = cdr.encode("trajectory_msgs/msg/JointTrajectory",
                      {"joint_names": ["a", "b"], "points": [{"positions": [1.0, 2.0]}]})
    with pytest.raises(CdrError):
        cdr.decode("trajectory_msgs/msg/JointTrajectory", good[:cut])


def test_bad_lengths_and_header_are_named():
    with pytest.raises(CdrError, match="little-endian"):
        cdr.decode("std_msgs/msg/String", b"\x00\x00\x00\x00\x01\x00\x00\x00\x00")
    huge = b"\x00\x01\x00\x00" + struct.pack("<I", 2**31) + b"ab"
    with pytest.raises(CdrError, match="runs past the end") as err:
        cdr.decode("std_msgs/msg/String", huge)
    assert err.value.field == "data"
    no_nul = b"\x00\x01\x00\x00" + struct.pack("<I", 2) + b"ab"
    with pytest.raises(CdrError, match="NUL"):
        cdr.decode("std_msgs/msg/String", no_nul)


def test_nan_survives_the_codec():
    """NaN is a value CDR carries (the service refuses it later, naming the field)."""
    payload = cdr.encode("sensor_msgs/msg/JointState", {"position": [math.nan]})
    assert math.isnan(cdr.decode("sensor_msgs/msg/JointState", payload)["position"][0])
