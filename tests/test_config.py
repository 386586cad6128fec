"""Arm configuration: shipped files load, units convert, and every error names file, key, value."""

from __future__ import annotations

import copy
import math
import re
import tomllib
from pathlib import Path
from typing import Any

import pytest

from robodcn import kinematics
from robodcn.config import Arm, ServoSpec, arm_from_dict, load_arm
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


@pytest.mark.parametrize(("key", "value", "named", "carried"), CASES,
                         ids=[f"{c[0]}=" + ("<missing>" if c[1] is MISSING else repr(c[1]))
                              for c in CASES])
def test_config_errors_name_file_key_value(key: str, value: Any, named: str, carried: Any) -> None:
    source = "/some/dir/bad-arm.toml"
    with pytest.raises(ConfigError) as info:
        arm_from_dict(set_key(raw(), key, value), source=source)
    err = info.value
    assert err.file == source and err.key == named and err.field == named
    assert err.value == carried
    text = str(err)
    assert source in text and repr(named) in text
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
