"""The named one-item reads and writes the stream and the workflows call instead of
addresses (robodcn.bus.single, .reads), through the real dynamixel-sdk against
firmware_sim: each must touch the item the e-manual names, which the simulator (its own
control table) reports back."""

from __future__ import annotations

from conftest import open_bus

from firmware_sim import control_table as fct
from robodcn.config import ServoSpec


def test_hold_in_place_sets_the_goal_to_where_a_hand_left_the_servo(sim3):
    with open_bus(sim3, [ServoSpec(i, "xm430-w350") for i in (1, 2, 3)]) as bus:
        other = sim3.servo(1).goal_position
        bus.torque(False, [2])
        sim3.servo(2).backdrive(1500)
        bus.write_goal_position(2, 3000)           # a stale goal far away
        assert bus.hold_in_place(2) == 1500
        assert sim3.servo(2).goal_position == 1500 == bus.read_goal_position(2)
        assert sim3.servo(1).goal_position == other          # one servo, not the bus


def test_named_reads_return_the_simulated_items(sim3):
    servo = sim3.servo(3)
    assert servo.write(fct.POSITION_I_GAIN, (37).to_bytes(2, "little")) == 0
    with open_bus(sim3, [ServoSpec(i, "xm430-w350") for i in (1, 2, 3)]) as bus:
        assert bus.read_position_i_gains()[2] == 37
        assert bus.read_operating_mode(3) == servo.operating_mode
        assert bus.read_hardware_error(3) == 0
        volts = int.from_bytes(servo.read(fct.PRESENT_INPUT_VOLTAGE, 2)[1], "little") / 10
        assert bus.read_input_voltage(3) == volts > 0
        temp = servo.read(fct.PRESENT_TEMPERATURE, 1)[1][0]
        assert bus.read_temperature(3) == temp > 0
