"""Releasing an arm (robodcn.workflow.release): torque off refused on an arm under gravity
without confirmation, lowering to the rest pose first, on the wire against firmware_sim."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ARM3R, CONFIGS, open_bus

from firmware_sim.bus import SimBus
from robodcn import dynamics, kinematics, servo_units
from robodcn.config import arm_from_dict, load_arm
from robodcn.errors import GravityReleaseError, InputError
from robodcn.simulated import simulated_arm
from robodcn.stream import StopSignal
from robodcn.workflow import float_teach, release

OMX = load_arm(CONFIGS / "omx.toml")


def vertical_arm(rest=True):
    """arm3r turned into a vertical plane (gravity −y), masses on its links, a rest pose."""
    doc = ARM3R.to_dict()
    doc["arm"]["plane"] = "vertical"
    if rest:
        doc["arm"]["rest"] = {"x": 0.15, "y": -0.2, "theta": -1.2}
    doc["dynamics"] = {"gravity": [0.0, -9.81], "link_masses": [0.15, 0.12, 0.05],
                       "link_com": [0.1, 0.075, 0.025]}
    return arm_from_dict(doc, source="vertical arm3r")


VERTICAL = vertical_arm()


# -- the check ----------------------------------------------------------------------------------

def test_the_check_gives_the_holding_torques_of_the_present_pose():
    q = kinematics.ik_yawed(OMX.chain, np.array([OMX.home]))[0]
    check = release.check_release(OMX, q)
    expected = dynamics.gravity_torque(float_teach.arm_chain(OMX), q)
    assert check.falls and check.joints == ("shoulder", "elbow", "wrist")
    assert check.holding_torque_nm == pytest.approx(expected.tolist())
    assert check.joint_names == OMX.joint_names and check.rest == OMX.rest
    assert abs(check.holding_torque_nm[1]) > 0.05          # the shoulder holds the arm up
    flat = release.check_release(ARM3R, [0.1, 0.2, 0.3])
    assert not flat.falls and flat.joints == () and flat.holding_torque_nm is None
    with pytest.raises(InputError) as err:
        release.check_release(OMX, [0.0, 0.1])
    assert err.value.field == "joints"


def test_an_arm_with_gravity_but_no_masses_still_falls():
    from dataclasses import replace
    bare = replace(OMX, mass_properties=replace(OMX.mass_properties, link_masses=None))
    check = release.check_release(bare, [0.0] * 4)
    assert check.falls and check.holding_torque_nm is None
    assert check.joints == ("shoulder", "elbow", "wrist")


# -- on the wire --------------------------------------------------------------------------------

def test_an_arm_without_gravity_is_released_at_once():
    with simulated_arm(ARM3R, timing="fast", dynamics=False) as s:
        result = release.release(s.bus, ARM3R)
        assert result.released and not result.lowered and result.lowering is None
        assert result.released_ids == (1, 2, 3)
        assert not any(sim.torque_enabled for sim in s.sim.servos)


def test_without_confirmation_nothing_moves_and_torque_stays_on():
    with simulated_arm(VERTICAL, timing="fast") as s:
        before = {i: len(s.sim.goal_history(i)) for i in VERTICAL.servo_ids}
        with pytest.raises(GravityReleaseError) as err:
            release.release(s.bus, VERTICAL)
        exc = err.value
        assert exc.field == "confirm" and exc.exit_code == 2 and exc.http_status == 409
        assert exc.joints == ("shoulder", "elbow", "wrist") and exc.rest == VERTICAL.rest
        assert "shoulder" in exc.message and "N·m" in exc.message and "rest pose" in exc.message
        assert exc.value["holding_torque_nm"] == list(exc.holding_torque_nm)
        assert all(sim.torque_enabled for sim in s.sim.servos)
        assert {i: len(s.sim.goal_history(i)) for i in VERTICAL.servo_ids} == before


def test_confirmed_it_is_lowered_to_the_rest_pose_then_released():
    rest_joints = kinematics.ik(VERTICAL.links, np.array([VERTICAL.rest]), VERTICAL.elbow)[0]
    with simulated_arm(VERTICAL, timing="fast") as s:
        result = release.release(s.bus, VERTICAL, confirm=True)
        assert result.lowered and result.released and result.lowering.outcome in release.ARRIVED
        assert not any(sim.torque_enabled for sim in s.sim.servos)
        arrived = result.lowering.final_positions      # read before torque went off
        assert arrived == pytest.approx(
            servo_units.radians_to_ticks(rest_joints, VERTICAL.servos).tolist(), abs=20)
        assert result.to_dict()["check"]["falls"] is True


def test_confirmed_without_lowering_or_rest_it_is_released_where_it_is():
    for arm, kw in ((VERTICAL, {"lower": False}), (vertical_arm(rest=False), {})):
        with simulated_arm(arm, timing="fast") as s:
            before = {i: len(s.sim.goal_history(i)) for i in arm.servo_ids}
            result = release.release(s.bus, arm, confirm=True, **kw)
            assert result.released and not result.lowered
            assert {i: len(s.sim.goal_history(i)) for i in arm.servo_ids} == before
    with pytest.raises(GravityReleaseError) as err, \
            simulated_arm(vertical_arm(rest=False), timing="fast") as s:
        release.release(s.bus, s.arm)
    assert err.value.rest is None and "no rest pose" in err.value.message


def test_a_lowering_that_stops_short_keeps_torque_on():
    stop = StopSignal()
    stop.request("test")
    with simulated_arm(VERTICAL, timing="fast") as s:
        result = release.release(s.bus, VERTICAL, confirm=True,
                                 execute_options={"stop": stop})
        assert not result.released and result.lowering.outcome == "stopped"
        assert all(sim.torque_enabled for sim in s.sim.servos)


def test_the_omx_refuses_without_confirmation_on_the_wire():
    with SimBus(arm=CONFIGS / "omx.toml", dynamics=True, timing="fast") as sim:
        with open_bus(sim, OMX.servos) as bus:
            bus.verify()
            bus.configure()
            with pytest.raises(GravityReleaseError) as err:
                release.release(bus, OMX)
            assert set(err.value.joints) <= {"shoulder", "elbow", "wrist"}
            assert "shoulder" in err.value.joints
            assert all(bus.torque_enabled().values())
        assert not sim.errors


@pytest.mark.parametrize("kwargs, field", [({"confirm": "yes"}, "confirm"),
                                           ({"lower": 1}, "lower")])
def test_bad_flags_name_the_field(kwargs, field):
    with pytest.raises(InputError) as err:
        release.release(None, VERTICAL, **kwargs)
    assert err.value.field == field


def test_the_rest_pose_is_taken_in_the_present_yaw_plane():
    """issue 27 §7: torque off --yes swung the base to yaw 0 to reach [arm.rest]."""
    q = np.array([np.radians(40.0), -0.3, 0.4, 0.2])
    rest = release.rest_here(OMX, q)
    assert np.hypot(*rest[:2]) == pytest.approx(np.hypot(*OMX.rest[:2]), abs=1e-12)
    assert rest[2:] == pytest.approx(OMX.rest[2:], abs=1e-12)
    assert np.degrees(np.arctan2(rest[1], rest[0])) == pytest.approx(40.0, abs=1e-9)
    assert release.rest_here(VERTICAL, np.zeros(3)) == tuple(VERTICAL.rest)


def test_a_turned_omx_is_lowered_without_swinging_its_base():
    from robodcn.planner import plan
    from robodcn.stream import execute
    from robodcn.workflow.poses import tool_pose

    with simulated_arm(OMX, timing="fast") as s:
        home = np.asarray(OMX.home)
        turned = (home[0] * np.cos(0.7), home[0] * np.sin(0.7), *home[2:])
        q0 = s.bus.read_positions()
        start = servo_units.ticks_to_radians(q0, OMX.servos)
        execute(plan(OMX, [tool_pose(OMX, start), turned], start_joints=start), s.bus)
        yaw_id = OMX.servos[0].id
        before = len(s.sim.goal_history(yaw_id))
        result = release.release(s.bus, OMX, confirm=True)
        assert result.lowered, result.to_dict()
        yaw_goals = s.sim.goal_history(yaw_id)[before:]
        assert yaw_goals and max(yaw_goals) - min(yaw_goals) <= 2, "the base swung round"
