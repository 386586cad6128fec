"""simulated_arm: a firmware_sim bus with the arm's servos, opened through robodcn.bus."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest
from conftest import ARM2R, ARM3R

from robodcn import kinematics, servo_units
from robodcn.errors import InputError
from robodcn.simulated import simulated_arm

ARM3, ARM2 = ARM3R, ARM2R


def _fds() -> set[str]:
    return set(os.listdir("/proc/self/fd"))


@pytest.mark.parametrize("arm", [ARM3, ARM2], ids=["arm3r", "arm2r"])
def test_starts_at_home_with_the_arms_servos(arm) -> None:
    with simulated_arm(arm, timing="fast") as sa:
        assert sa.arm is arm
        assert sa.bus.is_open and sa.bus.ids == arm.servo_ids and sa.bus.configured
        assert [sa.sim.servo(i).model for i in arm.servo_ids] == [s.model for s in arm.servos]
        home = kinematics.ik(arm.links, [arm.home], arm.elbow)
        want = servo_units.radians_to_ticks(home, arm.servos)[0]
        got = sa.bus.read_positions()
        np.testing.assert_array_equal(got, want)
        # FK of the read-back joints is the home pose (to one tick per joint).
        joints = servo_units.ticks_to_radians(got[None], arm.servos)
        pose = kinematics.fk(arm.links, joints)[0]
        np.testing.assert_allclose(pose[:2], arm.home[:2], atol=1e-3)
        assert all(sa.bus.torque_enabled().values())


def test_start_joints_and_fast_read_choice() -> None:
    q = [0.3, -0.8, 0.2]
    with simulated_arm(ARM3, timing="fast", start_joints=q, firmware=44) as sa:
        want = servo_units.radians_to_ticks(np.array([q]), ARM3.servos)[0]
        np.testing.assert_array_equal(sa.bus.read_positions(), want)
        assert sa.bus.fast_read is False  # firmware 44 has no Fast Sync Read
    with simulated_arm(ARM3, timing="fast") as sa:
        assert sa.bus.fast_read is True


def test_closes_everything() -> None:
    threads = set(threading.enumerate())
    fds = _fds()
    with simulated_arm(ARM3, timing="fast") as sa:
        path = sa.sim.port_path
        assert os.path.exists(path)
    assert not sa.bus.is_open
    assert set(threading.enumerate()) == threads
    assert _fds() == fds


def test_closes_on_error_inside_the_block() -> None:
    threads = set(threading.enumerate())
    fds = _fds()
    with pytest.raises(RuntimeError), simulated_arm(ARM3, timing="fast"):
        raise RuntimeError("boom")
    assert set(threading.enumerate()) == threads
    assert _fds() == fds


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"timing": "slow"}, "timing"),
    ({"start_joints": [0.1, 0.2]}, "start_joints"),
    ({"start_joints": [0.1, float("nan"), 0.0]}, "start_joints"),
    ({"start_joints": [0.0, 0.0, 3.1]}, "start_joints"),   # outside the wrist's limits
    ({"firmware": "new"}, "firmware"),
])
def test_bad_arguments_name_the_field(kwargs, field) -> None:
    threads = set(threading.enumerate())
    with pytest.raises(InputError) as exc, simulated_arm(ARM3, **kwargs):
        pass
    assert exc.value.field == field
    assert set(threading.enumerate()) == threads


def test_physics_is_the_default_and_dynamics_false_keeps_the_kinematic_model() -> None:
    q = servo_units.ticks_to_radians(
        servo_units.radians_to_ticks(kinematics.ik(ARM3.links, [ARM3.home], ARM3.elbow),
                                     ARM3.servos), ARM3.servos)[0]
    goal = servo_units.radians_to_ticks((q + 0.5)[None], ARM3.servos)[0]
    lags = {}
    for dynamics in (True, False):
        with simulated_arm(ARM3, timing="fast", dynamics=dynamics) as sa:
            assert sa.sim.dynamics is dynamics
            assert all(sa.sim.servo(i).dynamics is dynamics for i in ARM3.servo_ids)
            sa.bus.write_goals(goal)
            lags[dynamics] = np.abs(sa.bus.read_positions() - goal).max()
    assert lags[False] == 0          # the kinematic servo takes a step goal at once
    assert lags[True] > 100          # a motor needs time for 0.5 rad (≈ 326 ticks)


def test_the_arm_dynamics_table_reaches_the_simulator() -> None:
    from robodcn.config import arm_from_dict

    data = ARM3.to_dict()
    data["dynamics"] = {"link_masses": [0.3, 0.2, 0.1], "payload_kg": 0.05}
    arm = arm_from_dict(data)
    with simulated_arm(arm, timing="fast") as sa:
        assert sa.sim.arm.masses == (0.3, 0.2, 0.1) and sa.sim.arm.payload == 0.05


@pytest.mark.parametrize("dynamics,field", [
    ({"link_mass": [0.1, 0.1, 0.1]}, "dynamics.link_mass"),
    ({"link_masses": [0.1, 0.1]}, "dynamics.link_masses"),
    ({"link_masses": [0.1, 0.0, 0.1]}, "dynamics.link_masses"),
    ({"payload_kg": -1.0}, "dynamics.payload_kg"),
    ({"gravity": [0.0]}, "dynamics.gravity"),
])
def test_a_bad_dynamics_table_is_a_config_error_naming_the_key(dynamics, field) -> None:
    from robodcn.config import arm_from_dict
    from robodcn.errors import ConfigError

    data = ARM3.to_dict()
    data["dynamics"] = dynamics
    with pytest.raises(ConfigError) as err:
        arm_from_dict(data)
    assert err.value.key == field


def test_collision_current_key_per_joint_round_trips_and_is_checked() -> None:
    from robodcn.config import arm_from_dict
    from robodcn.errors import ConfigError

    data = ARM3.to_dict()
    data["joints"][1]["collision_current_a"] = 1.2
    arm = arm_from_dict(data)
    assert [j.collision_current for j in arm.joints] == [None, 1.2, None]
    assert arm_from_dict(arm.to_dict()) == arm
    data["joints"][1]["collision_current_a"] = 0
    with pytest.raises(ConfigError) as err:
        arm_from_dict(data)
    assert err.value.key == "joints[1].collision_current_a"


def test_omx_starts_at_its_home_with_the_gripper_beside_it() -> None:
    from pathlib import Path

    from robodcn.config import load_arm
    arm = load_arm(Path(__file__).resolve().parent.parent / "configs" / "omx.toml")
    q = kinematics.ik_yawed(arm.chain, np.array([arm.home]), arm.elbow)[0]
    want = servo_units.radians_to_ticks(q[None, :], arm.servos)[0]
    with simulated_arm(arm, timing="fast") as s:
        ticks = [s.sim.servo(i).present_position for i in arm.servo_ids]
        # seated at home and held from the start: only the P loop's sag under gravity
        # (the elbow ≈ 2 ticks), not the fall an unheld arm takes before configure
        assert np.abs(np.array(ticks) - want).max() <= 3
        assert s.sim.servo(arm.gripper.servo.id).present_position == 2048
        assert s.sim.arm is not None and s.sim.arm.base_yaw
