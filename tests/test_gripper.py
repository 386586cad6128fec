"""The gripper (robodcn.workflow.gripper): goals from the [gripper] table, and open/close/width
on the wire against firmware_sim's OpenMANIPULATOR-X (servo physics, the gripper servo 15
beside the joints; ``set_obstacle`` is an object in the jaws)."""

from __future__ import annotations

import time

import pytest
from conftest import CONFIGS, open_bus

from firmware_sim.bus import SimBus
from robodcn.bus import ADDR_GOAL_CURRENT, GOAL_CURRENT_UNIT_A
from robodcn.config import load_arm
from robodcn.errors import InputError
from robodcn.workflow import gripper as gr

OMX = load_arm(CONFIGS / "omx.toml")
GRIPPER = OMX.gripper
UNIT = GOAL_CURRENT_UNIT_A["xm430-w350"]
#: 60° of an XM430 from tick 2048 (omx.toml: open 60°, closed −60°).
OPEN_TICK, CLOSED_TICK = 2048 + 683, 2048 - 683


# -- goals, no wire -----------------------------------------------------------------------------

def test_goals_follow_the_gripper_table():
    assert gr.gripper_goal(GRIPPER, "open") == gr.GripperGoal(
        "open", GRIPPER.open_angle, OPEN_TICK, 0.075)
    assert gr.gripper_goal(GRIPPER, "close").tick == CLOSED_TICK
    middle = gr.gripper_goal(GRIPPER, width_m=0.0475)        # half way: angle 0
    assert middle.command == "width" and middle.tick == 2048
    assert middle.angle == pytest.approx(0.0, abs=1e-12)
    for width in (0.02, 0.03, 0.061, 0.075):
        goal = gr.gripper_goal(GRIPPER, width_m=width)
        assert GRIPPER.width_of_angle(goal.angle) == pytest.approx(width)


@pytest.mark.parametrize("command, width, field, words", [
    (None, 0.08, "width_m", "80.0 mm is outside the stroke 20.0–75.0 mm"),
    (None, 0.0199, "width_m", "19.9 mm"),
    (None, float("nan"), "width_m", "number of metres"),
    (None, True, "width_m", "number of metres"),
    ("squeeze", None, "command", "open or close"),
    (None, None, "command", "neither"),
    ("open", 0.03, "command", "both"),
])
def test_bad_goals_name_the_field(command, width, field, words):
    with pytest.raises(InputError) as err:
        gr.gripper_goal(GRIPPER, command, width_m=width)
    assert err.value.field == field and words in err.value.message


# -- on the wire --------------------------------------------------------------------------------

@pytest.fixture
def omx_sim():
    with SimBus(arm=CONFIGS / "omx.toml", dynamics=True, timing="fast") as sim:
        yield sim
    assert not sim.errors, sim.errors


@pytest.fixture
def bus(omx_sim):
    with open_bus(omx_sim, OMX.servos) as b:
        b.verify()
        yield b


def test_close_without_an_object_reaches_the_closed_jaws(omx_sim, bus):
    result = gr.close_gripper(bus, GRIPPER)
    servo = omx_sim.servo(15)
    assert servo.operating_mode == 5 and servo.torque_enabled
    assert int.from_bytes(servo.read(ADDR_GOAL_CURRENT, 2)[1], "little") == round(0.5 / UNIT)
    assert result.settled and not result.blocked
    assert abs(result.final_tick - CLOSED_TICK) <= gr.TOLERANCE_TICKS
    assert result.final_width_m == pytest.approx(0.020, abs=0.001)
    assert result.goal_tick == CLOSED_TICK and result.command == "close"
    assert bus.operating_modes() == {11: 3, 12: 3, 13: 3, 14: 3}     # the joints untouched


def test_an_object_in_the_jaws_is_held_without_an_overload(omx_sim, bus):
    gr.open_gripper(bus, GRIPPER)
    omx_sim.servo(15).set_obstacle(-20.0)          # an object 20° short of closed... at −20°
    result = gr.close_gripper(bus, GRIPPER)
    assert result.settled and result.blocked
    assert result.final_tick == pytest.approx(2048 - 228, abs=3)
    assert result.final_width_m == pytest.approx(GRIPPER.width_of_angle(-0.349), abs=0.001)
    assert abs(result.present_current_a) == pytest.approx(0.5, abs=0.02)
    time.sleep(1.3)                                # longer than the servo's overload time
    assert bus.hardware_errors() == {11: 0, 12: 0, 13: 0, 14: 0}
    assert omx_sim.servo(15).read(70, 1)[1] == b"\x00" and omx_sim.servo(15).torque_enabled
    assert not gr.open_gripper(bus, GRIPPER).blocked


def test_squeezing_in_position_mode_overloads_for_comparison(omx_sim, bus):
    """Why mode 5: the same squeeze in position mode (3) trips the overload alert."""
    omx_sim.servo(15).set_obstacle(-20.0)
    bus.set_operating_mode(3, [GRIPPER.servo], torque=True)
    bus.write_goal_position(GRIPPER.servo, CLOSED_TICK)
    deadline = time.monotonic() + 3.0
    while omx_sim.servo(15).read(70, 1)[1] == b"\x00" and time.monotonic() < deadline:
        time.sleep(0.05)
    assert omx_sim.servo(15).read(70, 1)[1][0] & 0x20      # overload


def test_a_width_goes_to_its_angle_and_bad_widths_write_nothing(omx_sim, bus):
    result = gr.set_width(bus, GRIPPER, 0.0475)
    assert result.goal_tick == 2048 and not result.blocked and result.settled
    assert result.final_width_m == pytest.approx(0.0475, abs=0.001)
    omx_sim.clear_log()
    with pytest.raises(InputError) as err:
        gr.set_width(bus, GRIPPER, 0.1)
    assert err.value.field == "width_m" and "100.0 mm" in err.value.message
    assert not omx_sim.packets("rx", "WRITE")


def test_the_wait_ends_at_the_timeout_with_an_injected_clock(omx_sim, bus):
    """A clock that jumps past the timeout at once: the result says not settled."""
    ticks = iter([0.0, 10.0, 10.0, 10.0])
    result = gr.actuate(bus, GRIPPER, "open", timeout_s=1.0, clock=lambda: next(ticks),
                        sleep=lambda s: None)
    assert not result.settled and not result.blocked and result.elapsed_s == 10.0


def test_the_state_reads_the_jaw_width_and_whether_an_object_is_held(omx_sim, bus):
    from robodcn.workflow.admin import present_state

    result = gr.open_gripper(bus, GRIPPER)
    jaws = present_state(bus, OMX).gripper
    assert jaws is not None and not jaws.holding
    assert jaws.width_m == pytest.approx(result.final_width_m, abs=1e-9)
    omx_sim.servo(15).set_obstacle(-20.0)
    held = gr.close_gripper(bus, GRIPPER)
    jaws = present_state(bus, OMX).gripper
    assert held.blocked and jaws.holding
    assert jaws.width_m == pytest.approx(held.final_width_m, abs=5e-4)
    assert present_state(bus, OMX).to_dict(OMX)["holding"] is True
    omx_sim.servo(15).set_obstacle(None)
