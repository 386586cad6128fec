"""Operating Mode switching, Goal Current and Present Current through the real dynamixel-sdk
against firmware_sim (robodcn.bus.modes, .currents, .single)."""

from __future__ import annotations

import time

import numpy as np
import pytest
from conftest import open_bus

from firmware_sim.bus import SimBus
from robodcn.bus import (
    ADDR_GOAL_CURRENT,
    ADDR_OPERATING_MODE,
    ADDR_TORQUE_ENABLE,
    GOAL_CURRENT_UNIT_A,
    OPERATING_MODE_CURRENT,
    OPERATING_MODE_CURRENT_POSITION,
    OPERATING_MODE_POSITION,
)
from robodcn.config import ServoSpec
from robodcn.errors import InputError, TickLimitError

UNIT = GOAL_CURRENT_UNIT_A["xm430-w350"]


def specs(ids=(1, 2, 3), model="xm430-w350") -> list[ServoSpec]:
    return [ServoSpec(i, model) for i in ids]


def writes(sim: SimBus) -> list[tuple[int, int, bytes]]:
    """(id, address, data) of every WRITE the servos received, in order."""
    return [(e.id, int.from_bytes(e.params[:2], "little"), bytes(e.params[2:]))
            for e in sim.packets("rx", "WRITE")]


def item(sim: SimBus, servo_id: int, address: int, size: int) -> int:
    error, data = sim.servo(servo_id).read(address, size)
    assert error == 0
    return int.from_bytes(data, "little", signed=True)


@pytest.fixture
def bus(sim3):
    with open_bus(sim3, specs()) as b:
        b.verify()
        b.configure()
        yield b


def test_switch_to_current_mode_turns_torque_off_then_on_with_zero_goal(sim3, bus):
    sim3.clear_log()
    switches = bus.set_operating_mode(OPERATING_MODE_CURRENT, [1, 2])
    assert [(s.servo_id, s.previous, s.mode, s.torque_on) for s in switches] == [
        (1, 3, 0, True), (2, 3, 0, True)]
    for i in (1, 2):
        assert sim3.servo(i).operating_mode == 0 and sim3.servo(i).torque_enabled
        # the switch reset Goal Current to the limit; robodcn wrote 0 before torque-on
        assert item(sim3, i, ADDR_GOAL_CURRENT, 2) == 0
        ops = [(a, d) for sid, a, d in writes(sim3) if sid == i]
        assert ops == [(ADDR_TORQUE_ENABLE, b"\x00"), (ADDR_OPERATING_MODE, b"\x00"),
                       (ADDR_GOAL_CURRENT, b"\x00\x00"), (ADDR_TORQUE_ENABLE, b"\x01")]
    assert sim3.servo(3).operating_mode == OPERATING_MODE_POSITION
    assert bus.operating_modes() == {1: 0, 2: 0, 3: 3}
    assert not bus.configured              # the switch reset the stream's profile
    sim3.clear_log()
    again = bus.set_operating_mode(OPERATING_MODE_CURRENT, [1])
    assert not again[0].changed and (1, ADDR_TORQUE_ENABLE, b"\x00") not in writes(sim3)


def test_back_to_position_mode_holds_where_the_servo_is(sim3, bus):
    bus.set_operating_mode(OPERATING_MODE_CURRENT)
    bus.torque(False, [2])
    sim3.servo(2).backdrive(1500)          # moved by hand while in current mode
    bus.write(2, 116, (3000).to_bytes(4, "little"))   # a stale goal far away
    switches = bus.set_operating_mode(OPERATING_MODE_POSITION, torque=True)
    assert [s.held_tick for s in switches][1] == 1500
    assert sim3.servo(2).goal_position == 1500 and sim3.servo(2).torque_enabled
    assert bus.read_positions()[1] == 1500


def test_current_based_position_gets_its_goal_current_before_torque(sim3, bus):
    switches = bus.set_operating_mode(OPERATING_MODE_CURRENT_POSITION, [3],
                                      goal_current_a=0.5)
    assert switches[0].goal_current_units == round(0.5 / UNIT) == 186
    assert item(sim3, 3, ADDR_GOAL_CURRENT, 2) == 186
    assert sim3.servo(3).operating_mode == 5 and sim3.servo(3).torque_enabled


def test_goal_current_above_the_current_limit_is_refused_before_any_write(sim3, bus):
    bus.torque(False, [1])
    assert sim3.servo(1).write(38, (100).to_bytes(2, "little")) == 0   # 0.269 A
    bus.torque(True, [1])
    sim3.clear_log()
    with pytest.raises(InputError) as err:
        bus.set_operating_mode(OPERATING_MODE_CURRENT, [2, 1], goal_current_a=0.3)
    assert err.value.field == "servo[1].goal_current" and err.value.value == 0.3
    assert "0.269 A" in err.value.message
    with pytest.raises(InputError):
        bus.write_goal_currents([0.3, 0.1, 0.1])
    assert writes(sim3) == [] and not sim3.packets("rx", "SYNC_WRITE")
    assert sim3.servo(2).operating_mode == 3
    assert bus.current_limit(1) == pytest.approx(100 * UNIT)


@pytest.mark.parametrize("kwargs, field", [
    ({"mode": 2}, "mode"), ({"mode": True}, "mode"),
    ({"mode": 3, "goal_current_a": 0.2}, "goal_current_a"),
    ({"mode": 0, "goal_current_a": [0.1, 0.2]}, "goal_current_a"),
    ({"mode": 0, "goal_current_a": float("nan")}, "servo[1].goal_current"),
    ({"mode": 0, "servos": [1, 1]}, "servos"),
    ({"mode": 0, "servos": [9]}, "servo"),
])
def test_bad_switches_name_the_field(sim3, bus, kwargs, field):
    sim3.clear_log()
    with pytest.raises(InputError) as err:
        bus.set_operating_mode(**kwargs)
    assert err.value.field == field
    assert writes(sim3) == []


def test_a_model_without_current_control_is_refused():
    with SimBus((1,), model="xl430-w250", timing="fast") as sim:
        with open_bus(sim, specs((1,), "xl430-w250")) as b:
            with pytest.raises(InputError) as err:
                b.set_operating_mode(OPERATING_MODE_CURRENT)
            assert err.value.field == "mode" and "xl430-w250" in err.value.message
            with pytest.raises(InputError) as err:
                b.write_goal_current(1, 0.1)
            assert err.value.field == "servo"
            assert not writes(sim)


def test_goal_currents_go_out_in_one_sync_write(sim3, bus):
    bus.set_operating_mode(OPERATING_MODE_CURRENT)
    sim3.clear_log()
    units = bus.write_goal_currents([0.1, -0.25, 0.0])
    assert units.tolist() == [round(0.1 / UNIT), -round(0.25 / UNIT), 0]
    bus.read(1, ADDR_GOAL_CURRENT, 2)      # a round trip: the sim has handled the write
    assert len(sim3.packets("rx", "SYNC_WRITE")) == 1 and writes(sim3) == []
    assert [item(sim3, i, ADDR_GOAL_CURRENT, 2) for i in (1, 2, 3)] == units.tolist()
    bus.write_goal_currents([0.2, 0.3], ids=[3, 1])
    bus.read(1, ADDR_GOAL_CURRENT, 2)
    assert [item(sim3, i, ADDR_GOAL_CURRENT, 2) for i in (3, 1)] == [74, 112]
    with pytest.raises(InputError) as err:
        bus.write_goal_currents([0.1, 0.1])
    assert err.value.field == "currents_a"
    with pytest.raises(InputError) as err:
        bus.write_goal_currents([0.1], ids=[7])
    assert err.value.field == "ids"


def test_present_current_follows_the_goal_in_current_mode():
    with SimBus((1, 2), timing="fast", dynamics=True) as sim:
        with open_bus(sim, specs((1, 2))) as b:
            b.verify()
            b.configure()
            b.set_operating_mode(OPERATING_MODE_CURRENT, goal_current_a=[0.2, -0.1])
            time.sleep(0.05)
            currents = b.read_currents()
            assert currents == pytest.approx([0.2, -0.1], abs=2 * UNIT)
            assert b.read_present_current(2) == pytest.approx(-0.1, abs=2 * UNIT)
            assert b.read_currents([2]) == pytest.approx([-0.1], abs=2 * UNIT)
            direct = [sim.servo(i).read(126, 2)[1] for i in (1, 2)]
            assert np.sign(currents).tolist() == [
                np.sign(int.from_bytes(d, "little", signed=True)) for d in direct]
            b.set_operating_mode(OPERATING_MODE_POSITION)
            assert all(sim.servo(i).torque_enabled for i in (1, 2))


def test_a_servo_of_the_wire_that_is_not_a_joint(sim3):
    """A gripper beside the joints: named by its spec, on the joints' open port."""
    gripper = ServoSpec(3, "xm430-w350", min_tick=1000, max_tick=3000)
    with open_bus(sim3, specs((1, 2))) as b:
        b.verify()
        b.set_operating_mode(OPERATING_MODE_CURRENT_POSITION, [gripper], torque=True,
                             goal_current_a=0.4)
        assert sim3.servo(3).operating_mode == 5 and sim3.servo(3).torque_enabled
        b.write_goal_position(gripper, 2500)
        assert sim3.servo(3).goal_position == 2500
        assert b.read_position(gripper) == sim3.servo(3).present_position
        with pytest.raises(TickLimitError) as err:
            b.write_goal_position(gripper, 3001)
        assert err.value.value == 3001 and sim3.servo(3).goal_position == 2500
        with pytest.raises(InputError) as err:
            b.read_position(3)             # by id it is not on this bus
        assert err.value.field == "servo"
        with pytest.raises(InputError):
            b.spec_of(ServoSpec(1, "xm430-w350", min_tick=5))   # a joint, another spec
        assert b.operating_modes() == {1: 3, 2: 3}
