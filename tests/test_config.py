"""Arm configuration: shipped files load, units convert, and every error names file, key, value."""

from __future__ import annotations

import copy
import math
import re
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robodcn import kinematics
from robodcn.config import SERVO_SPECS, Arm, ServoSpec, arm_from_dict, load_arm
from robodcn.errors import ConfigError

CONFIGS = Path(__file__).resolve().parent.parent / "configs"
ARM3R = CONFIGS / "arm3r.toml"
ARM2R = CONFIGS / "arm2r.toml"
MISSING = object()


def raw(path: Path = ARM3R) -> dict[str, Any]:
    return tomllib.loads(path.read_text())


def set_key(data: dict[str, Any], key: str, value: Any) -> dict[str, Any]:
    """Copy of ``data`` with the dotted key (``joints[1].servo.id``) set, or deleted for MISSING."""
    data = copy.deepcopy(data)
    parts = [p for p in re.split(r"\.|\[(\d+)\]", key) if p]
    node: Any = data
    for part in parts[:-1]:
        node = node[int(part)] if part.isdigit() else node[part]
    last = int(parts[-1]) if parts[-1].isdigit() else parts[-1]
    if value is MISSING:
        del node[last]
    else:
        node[last] = value
    return data


def case_ids(cases: list[tuple[Any, ...]]) -> list[str]:
    """pytest ids of (key, value, …) cases: ``key=value`` (``<missing>`` for MISSING)."""
    return [f"{c[0]}=" + ("<missing>" if c[1] is MISSING else repr(c[1])) for c in cases]


def named_error(data: dict[str, Any], key: str, value: Any, source: str,
                named: str) -> ConfigError:
    """The ConfigError of ``data`` with ``key`` set to ``value`` (:func:`set_key`), read as
    from ``source``: it names the file and the key ``named`` (``file``, ``key``, ``field``
    and its text)."""
    with pytest.raises(ConfigError) as info:
        arm_from_dict(set_key(data, key, value), source=source)
    err = info.value
    assert err.file == source and err.key == named and err.field == named
    text = str(err)
    assert source in text and repr(named) in text
    return err


def test_shipped_arm3r() -> None:
    arm = load_arm(ARM3R)
    assert isinstance(arm, Arm)
    assert arm.dof == 3 and len(arm.links) == 3
    assert arm.servo_ids == (1, 2, 3)
    assert all(j.servo.model == "xm430-w350" for j in arm.joints)
    assert arm.joint_names == tuple(j.name for j in arm.joints)
    assert arm.source == str(ARM3R)
    assert arm.bus.protocol == 2.0 and 1 <= arm.bus.rate_hz <= 1000
    # degrees in the file, radians inside
    data = raw()
    assert arm.joints[0].min_angle == pytest.approx(math.radians(data["joints"][0]["min_deg"]))
    assert arm.joints[0].max_velocity == pytest.approx(
        math.radians(data["joints"][0]["max_velocity_deg_s"]))
    assert kinematics.reachable(arm.links, [arm.home]).all()


def test_shipped_arm2r() -> None:
    arm = load_arm(ARM2R)
    assert arm.dof == 2 and len(arm.links) == 2
    assert arm.servo_ids == (1, 2)
    data = raw(ARM2R)
    assert arm.joints[0].max_velocity == data["joints"][0]["max_velocity"]  # SI keys stay SI
    # defaults fill the servo keys the file leaves out
    assert arm.joints[0].servo == ServoSpec(1, "xl430-w250", 4096, 2048, 1, 0, 4095)


@pytest.mark.parametrize("path", [ARM3R, ARM2R])
def test_to_dict_round_trip(path: Path) -> None:
    arm = load_arm(path)
    assert arm_from_dict(arm.to_dict(), source=arm.source) == arm


def test_degree_and_radian_keys_agree() -> None:
    data = raw()
    joint = data["joints"][1]
    radian = set_key(data, "joints[1].min_deg", MISSING)
    radian = set_key(radian, "joints[1].min", math.radians(joint["min_deg"]))
    assert arm_from_dict(radian).joints[1].min_angle == arm_from_dict(data).joints[1].min_angle


# (key to change, new value or MISSING, key the error must name, value it must carry)
CASES = [
    ("extra", 1, "extra", 1),
    ("arm.colour", "red", "arm.colour", "red"),
    ("joints[1].servo.speed", 3, "joints[1].servo.speed", 3),
    ("arm.name", MISSING, "arm.name", None),
    ("joints[0].servo.id", MISSING, "joints[0].servo.id", None),
    ("joints[2].max_velocity_deg_s", MISSING, "joints[2].max_velocity", None),
    ("bus", MISSING, "bus", None),
    ("arm.links", [0.2, -0.1, 0.05], "arm.links[1]", -0.1),
    ("arm.links", [0.2], "arm.links", [0.2]),
    ("arm.links", [0.2, "long", 0.05], "arm.links[1]", "long"),
    ("arm.elbow", "sideways", "arm.elbow", "sideways"),
    ("arm.home.x", 5.0, "arm.home", [5.0, 0.1, 0.0]),
    ("joints[2].servo.id", 300, "joints[2].servo.id", 300),
    ("joints[2].servo.id", "one", "joints[2].servo.id", "one"),
    ("joints[2].servo.id", 1, "joints[2].servo.id", 1),
    ("joints[1].name", "shoulder", "joints[1].name", "shoulder"),
    ("joints[0].servo.model", "mx-28", "joints[0].servo.model", "mx-28"),
    ("joints[0].servo.direction", 2, "joints[0].servo.direction", 2),
    ("joints[0].servo.max_tick", 5000, "joints[0].servo.max_tick", 5000),
    ("joints[0].servo.min_tick", 4095, "joints[0].servo.max_tick", 4095),
    ("joints[0].servo.zero_offset", -1, "joints[0].servo.zero_offset", -1),
    ("joints[0].servo.ticks_per_turn", 0, "joints[0].servo.ticks_per_turn", 0),
    ("joints[1].max_deg", -170.0, "joints[1].max_deg", -170.0),
    ("joints[1].max_velocity_deg_s", 0.0, "joints[1].max_velocity_deg_s", 0.0),
    ("joints[1].max_acceleration_deg_s2", -5.0, "joints[1].max_acceleration_deg_s2", -5.0),
    ("joints[1].max_velocity_deg_s", math.inf, "joints[1].max_velocity_deg_s", math.inf),
    ("joints[1].min", -1.0, "joints[1].min_deg", -160.0),
    ("joints", [], "joints", []),
    ("bus.baud", 12345, "bus.baud", 12345),
    ("bus.protocol", 1.0, "bus.protocol", 1.0),
    ("bus.rate_hz", 5000.0, "bus.rate_hz", 5000.0),
    ("bus.port", "", "bus.port", ""),
    ("bus.baud", True, "bus.baud", True),
]


@pytest.mark.parametrize(("key", "value", "named", "carried"), CASES, ids=case_ids(CASES))
def test_config_errors_name_file_key_value(key: str, value: Any, named: str, carried: Any) -> None:
    err = named_error(raw(), key, value, "/some/dir/bad-arm.toml", named)
    assert err.value == carried
    text = str(err)
    if carried is not None:
        assert repr(carried) in text


def test_file_errors_name_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "arm.toml"
    bad.write_text(ARM3R.read_text().replace("id = 2", "id = 999"))
    with pytest.raises(ConfigError) as info:
        load_arm(bad)
    assert info.value.file == str(bad) and info.value.key == "joints[1].servo.id"
    assert str(bad) in str(info.value) and "999" in str(info.value)

    broken = tmp_path / "broken.toml"
    broken.write_text("[arm\nname = 1\n")
    with pytest.raises(ConfigError) as info:
        load_arm(broken)
    assert str(broken) in str(info.value) and "TOML" in str(info.value)

    with pytest.raises(ConfigError) as info:
        load_arm(tmp_path / "nope.toml")
    assert "nope.toml" in str(info.value)


def test_either_unit_not_both() -> None:
    data = set_key(raw(), "joints[0].min", -1.0)
    with pytest.raises(ConfigError) as info:
        arm_from_dict(data, source="x.toml")
    assert "not both" in str(info.value)


# -- issue 9: values past what the servo or physics allows ------------------------------------

HUGE = int("9" * 400)


@pytest.mark.parametrize(("key", "value", "named"), [
    ("joints[0].servo.id", HUGE, "joints[0].servo.id"),
    ("joints[0].max_velocity_deg_s", HUGE, "joints[0].max_velocity_deg_s"),
    ("arm.links", [1e300, 0.15, 0.05], "arm.links[0]"),
    ("arm.links", [0.2, 0.0, 0.05], "arm.links[1]"),
    ("joints[0].servo.ticks_per_turn", 2**63 - 1, "joints[0].servo.ticks_per_turn"),
    ("joints[0].servo.ticks_per_turn", 8192, "joints[0].servo.ticks_per_turn"),
    ("joints[0].max_velocity_deg_s", 1e308, "joints[0].max_velocity_deg_s"),
    ("joints[0].max_velocity_deg_s", 400.0, "joints[0].max_velocity_deg_s"),
    ("joints[0].max_acceleration_deg_s2", 1e9, "joints[0].max_acceleration_deg_s2"),
    ("joints[0].min_deg", -1e300, "joints[0].min_deg"),
    ("joints[0].max_jerk_deg_s3", -1.0, "joints[0].max_jerk_deg_s3"),
    ("joints[0].max_jerk_deg_s3", 1e300, "joints[0].max_jerk_deg_s3"),
])
def test_values_past_the_servo_or_physics_are_config_errors(key: str, value: Any,
                                                           named: str) -> None:
    with pytest.raises(ConfigError) as info:
        arm_from_dict(set_key(raw(), key, value), source="arm.toml")
    err = info.value
    assert err.key == named and err.file == "arm.toml"
    text = str(err)
    assert len(text) < 200 and "arm.toml" in text and named in text
    assert "['" not in text and "{'" not in text


def test_messages_are_short_and_plain() -> None:
    data = set_key(raw(), "arm.elbow", "sideways")
    with pytest.raises(ConfigError) as info:
        arm_from_dict(data, source="a.toml")
    assert "one of up, down" in str(info.value)
    data = set_key(raw(), "joints", raw()["joints"][:2])
    with pytest.raises(ConfigError) as info:
        arm_from_dict(data, source="a.toml")
    assert len(str(info.value)) < 160 and "{" not in str(info.value)


def test_jerk_limit_is_optional_and_si() -> None:
    # the shipped config leaves its jerk keys commented (the online layer does not honour them)
    assert all(j.max_jerk is None for j in load_arm(ARM3R).joints)
    assert all(j.max_jerk is None for j in load_arm(ARM2R).joints)
    plain = raw()
    assert all("max_jerk_deg_s3" not in joint for joint in plain["joints"])
    data = set_key(plain, "joints[1].max_jerk_deg_s3", 20000.0)
    arm = arm_from_dict(data, source="a.toml")
    assert arm.joints[1].max_jerk == pytest.approx(math.radians(20000.0))
    assert arm.joints[0].max_jerk is None
    assert arm_from_dict(arm.to_dict(), source="a.toml") == arm
    data = set_key(plain, "joints[1].max_jerk", 300.0)
    assert arm_from_dict(data, source="a.toml").joints[1].max_jerk == 300.0


# -- issue 18/19: the OpenMANIPULATOR-X, a yawed arm with a gripper ----------------------------

OMX = CONFIGS / "omx.toml"
PACKAGED = Path(__file__).resolve().parent.parent / "robodcn" / "config" / "data"


def test_shipped_omx() -> None:
    arm = load_arm(OMX)
    assert arm.yawed and arm.plane == "vertical" and arm.dof == 4
    assert arm.joint_names == ("yaw", "shoulder", "elbow", "wrist")
    assert arm.servo_ids == (11, 12, 13, 14) and arm.bus.baud == 1_000_000
    assert arm.bus.rate_hz == 100.0 and arm.pose_keys == ("x", "y", "z", "pitch")
    assert arm.chain_links.tolist() == [[0.024, 0.128], [0.124, 0.0], [0.126, 0.0]]
    assert arm.links == pytest.approx((math.hypot(0.024, 0.128), 0.124, 0.126))
    assert arm.shoulder_height == 0.0765 and len(arm.home) == 4 and len(arm.rest) == 4
    # the published limits (omx.md), within two ticks of ±π for the yaw
    assert [(j.min_angle, j.max_angle) for j in arm.joints[1:]] == [
        (-1.5, 1.5), (-1.5, 1.4), (-1.7, 1.97)]
    assert arm.joints[0].max_angle == pytest.approx(math.pi, abs=2 * 2 * math.pi / 4096)
    for j in arm.joints:
        model = SERVO_SPECS[j.servo.model]
        assert j.servo == ServoSpec(j.servo.id, "xm430-w350", 4096, 2048, 1, 0, 4095)
        assert j.max_velocity < 46 * 2 * math.pi / 60  # below 46 rpm at 12 V
        assert j.max_torque is not None
        assert j.max_torque <= model.available_torque(j.max_velocity)  # under the line
    grip = arm.gripper
    assert grip is not None and grip.servo.id == 15 and grip.servo.model == "xm430-w350"
    assert (grip.closed_width, grip.open_width) == pytest.approx((0.020, 0.075))
    assert 0 < grip.grip_current < SERVO_SPECS["xm430-w350"].stall_current
    assert grip.angle_of_width(grip.open_width) == pytest.approx(grip.open_angle)
    assert grip.width_of_angle(grip.angle_of_width(0.05)) == pytest.approx(0.05)
    # the chain's COMs from the base-frame table of omx.md: joint position at zero + com
    props = arm.mass_properties
    joints_at_zero = [(0.0, 0.0765), (0.024, 0.2045), (0.148, 0.2045)]
    base_com = [(0.0103, 0.1782), (0.1149, 0.2047), (0.1922, 0.2134)]
    for (jr, jz), (cr, cz), (br, bz) in zip(joints_at_zero, props.link_com, base_com,
                                            strict=True):
        assert (jr + cr, jz + cz) == pytest.approx((br, bz), abs=1e-9)
    assert props.gravity == (0.0, -9.81) and props.gravity_m_s2 == 9.81
    assert props.link_masses == (0.1385, 0.1327, 0.1433) and arm.payload_kg == 0.0
    assert props.rotor_inertia == (0.0125,) * 4 and props.yaw_body_mass == 0.0984
    assert arm.max_torques == tuple(j.max_torque for j in arm.joints)


def test_planar_arms_have_no_yaw_and_no_torque_limits() -> None:
    arm = load_arm(ARM3R)
    assert not arm.yawed and arm.chain is None and arm.gripper is None and arm.rest is None
    assert arm.max_torques == (None, None, None) and arm.pose_keys == ("x", "y", "theta")
    np.testing.assert_array_equal(arm.chain_links, [[0.20, 0.0], [0.15, 0.0], [0.05, 0.0]])
    assert arm.mass_properties.gravity_m_s2 == 0.0 and arm.chain_joints == arm.joints


def test_omx_round_trip_and_packaged_copy() -> None:
    arm = load_arm(OMX)
    assert arm_from_dict(arm.to_dict(), source=arm.source) == arm
    assert (PACKAGED / "omx.toml").read_text() == OMX.read_text()
    data = arm.to_dict()
    assert data["arm"]["links"] == [[0.024, 0.128], [0.124, 0.0], [0.126, 0.0]]
    assert data["gripper"]["id"] == 15 and data["joints"][1]["max_torque_nm"] == 2.8


def test_home_and_rest_are_reachable_within_the_limits() -> None:
    arm = load_arm(OMX)
    q = kinematics.ik_yawed(arm.chain, [arm.home, arm.rest], arm.elbow)
    lo = [j.min_angle for j in arm.joints]
    hi = [j.max_angle for j in arm.joints]
    assert ((q >= lo) & (q <= hi)).all()
    rest_z = arm.rest[2]
    assert rest_z < arm.home[2]


# (key to change, new value or MISSING, key the error must name, words the message holds)
OMX_CASES = [
    ("arm.base_yaw", "yes", "arm.base_yaw", "true or false"),
    ("arm.plane", "horizontal", "arm.plane", "vertical"),
    ("arm.plane", "diagonal", "arm.plane", "one of"),
    ("arm.shoulder_height", MISSING, "arm.shoulder_height", "missing"),
    ("arm.shoulder_height", -0.1, "arm.shoulder_height", "0..10 m"),
    ("arm.links", [[0.024, 0.128], [0.124]], "arm.links[1]", "[r, z]"),
    ("arm.links", [[0.024, "up"], [0.124, 0.0], [0.126, 0.0]], "arm.links[0][1]", "number"),
    ("arm.links", [[0.0, 0.0], [0.124, 0.0], [0.126, 0.0]], "arm.links[0]", "m long"),
    ("arm.home.z", MISSING, "arm.home.z", "missing"),
    ("arm.home.theta", 0.0, "arm.home.theta", "unknown"),
    ("arm.home.x", 0.5, "arm.home", "out of reach"),
    ("arm.home.x", 0.0, "arm.home", "yaw axis"),
    ("arm.home.pitch_deg", 120.0, "arm.home", "over the top"),
    ("arm.home.x", -0.1218, "arm.home", "joint 'yaw'"),
    ("arm.rest.pitch_deg", -100.0, "arm.rest", "over the top"),
    ("joints", MISSING, "joints", "missing"),
    ("joints[1].max_torque_nm", 5.0, "joints[1].max_torque_nm", "4.1 N·m"),
    ("joints[1].max_torque_nm", 0.0, "joints[1].max_torque_nm", "stall torque"),
    ("joints[3].max_torque_nm", "2", "joints[3].max_torque_nm", "number"),
    ("dynamics.gravity", [0.0, -9.81], "dynamics.gravity", "unknown"),
    ("dynamics.gravity_m_s2", -9.81, "dynamics.gravity_m_s2", "non-negative"),
    ("dynamics.link_com", [0.1, 0.05, 0.05], "dynamics.link_com[0]", "[r, z]"),
    ("dynamics.link_com", [[0.01, 0.1]], "dynamics.link_com", "3 [r, z] vectors"),
    ("dynamics.link_masses", [0.1, 0.0, 0.1], "dynamics.link_masses", "positive"),
    ("dynamics.rotor_inertia_kg_m2", [0.0125, 0.0125], "dynamics.rotor_inertia_kg_m2",
     "4 numbers"),
    ("dynamics.yaw_body_mass", 0.0, "dynamics.yaw_body_mass", "positive"),
    ("dynamics.payload_kg", -0.5, "dynamics.payload_kg", "non-negative"),
    ("gripper.colour", "red", "gripper.colour", "unknown"),
    ("gripper.id", 12, "gripper.id", "joints[1]"),
    ("gripper.id", MISSING, "gripper.id", "missing"),
    ("gripper.grip_current_a", 5.0, "gripper.grip_current_a", "2.3 A"),
    ("gripper.open_width_mm", 10.0, "gripper.open_width_mm", "wider"),
    ("gripper.closed_width_mm", 0.0, "gripper.closed_width_mm", "1..1000 mm"),
    ("gripper.closed_deg", 200.0, "gripper.closed_deg", "tick"),
    ("gripper.closed_deg", 60.0, "gripper.closed_deg", "differ"),
    ("gripper.open", 1.0, "gripper.open_deg", "not both"),
]


@pytest.mark.parametrize(("key", "value", "named", "words"), OMX_CASES,
                         ids=case_ids(OMX_CASES))
def test_omx_errors_name_the_key(key: str, value: Any, named: str, words: str) -> None:
    text = str(named_error(raw(OMX), key, value, "/arms/omx-bad.toml", named))
    assert words in text
    assert len(text) < 300  # an unknown key lists the allowed ones


def test_omx_home_error_speaks_degrees() -> None:
    with pytest.raises(ConfigError) as info:
        arm_from_dict(set_key(raw(OMX), "arm.home.pitch_deg", 120.0), source="omx.toml")
    assert info.value.value["pitch_deg"] == pytest.approx(120.0)
    assert "'pitch_deg': 120" in str(info.value)


def test_planar_arms_refuse_yawed_keys() -> None:
    for key, value, named in (("arm.links", [[0.2, 0.0], 0.15, 0.05], "arm.links[0]"),
                              ("arm.shoulder_height", 0.1, "arm.shoulder_height"),
                              ("dynamics", {"gravity_m_s2": 9.81}, "dynamics.gravity_m_s2")):
        with pytest.raises(ConfigError) as info:
            arm_from_dict(set_key(raw(), key, value), source="a.toml")
        assert info.value.key == named
    # a planar arm may name its plane and a rest pose; both round-trip
    data = set_key(set_key(raw(), "arm.plane", "vertical"), "arm.rest",
                   {"x": 0.2, "y": 0.0, "theta_deg": -90.0})
    arm = arm_from_dict(data, source="a.toml")
    assert arm.plane == "vertical" and arm.rest == pytest.approx((0.2, 0.0, -math.pi / 2))
    assert arm_from_dict(arm.to_dict(), source="a.toml") == arm


def test_yawed_arm_accepts_length_links_and_a_per_joint_rotor_inertia() -> None:
    data = set_key(raw(OMX), "arm.links", [[0.024, 0.128], 0.124, 0.126])
    data = set_key(data, "dynamics.rotor_inertia_kg_m2", [0.01, 0.02, 0.03, 0.04])
    arm = arm_from_dict(data, source="a.toml")
    assert arm.chain_links.tolist() == load_arm(OMX).chain_links.tolist()
    assert arm.mass_properties.rotor_inertia == (0.01, 0.02, 0.03, 0.04)
    assert arm_from_dict(arm.to_dict(), source="a.toml") == arm


def test_servo_torque_speed_line() -> None:
    xm = SERVO_SPECS["xm430-w350"]
    assert xm.available_torque(0.0) == 4.1
    assert xm.available_torque(xm.rated_speed / 2) == pytest.approx(2.05)
    assert xm.available_torque(-2 * xm.rated_speed) == 0.0
    assert xm.rated_speed == pytest.approx(4.817, abs=1e-3)


# -- issue 27 §4: example names in the library, as --arm takes them -----------------------------

def test_load_arm_takes_an_example_name_from_any_directory(tmp_path, monkeypatch):
    import robodcn
    from robodcn.config import EXAMPLES
    from robodcn.workflow.examples import resolve_arm_path

    monkeypatch.chdir(tmp_path)                       # no configs/ here
    for name in EXAMPLES:
        arm = robodcn.load_arm(name)
        assert arm.name == name
        assert Path(arm.source) == resolve_arm_path(name) == PACKAGED / f"{name}.toml"
        assert arm.to_dict() == load_arm(CONFIGS / f"{name}.toml").to_dict()


def test_a_file_named_like_an_example_is_the_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "omx").write_text((CONFIGS / "arm2r.toml").read_text())
    assert load_arm("omx").name == "arm2r"


def test_a_name_that_is_neither_file_nor_example_says_so(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as caught:
        load_arm("omx2")
    assert caught.value.message == ("omx2: cannot read arm config: No such file or directory "
                                    "(nor an example arm: arm3r, arm2r, omx)")
