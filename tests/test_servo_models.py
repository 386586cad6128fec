"""One record per servo model (robodcn.servo_models): the configuration, the bus and the
stream read it, and the simulator on the other side of the wire (its own tables) agrees."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from conftest import open_bus

from firmware_sim.bus import SimBus
from firmware_sim.control_table import MODELS as SIM_MODELS
from firmware_sim.motor import MOTORS as SIM_MOTORS
from robodcn.bus import GOAL_CURRENT_UNIT_A, MODEL_NUMBERS, MODEL_OPERATING_MODES
from robodcn.bus.feedback import current_units
from robodcn.config import SERVO_SPECS, ServoSpec, example_path, load_arm, rotor_inertias
from robodcn.errors import ConfigError, InputError
from robodcn.servo_models import OPERATING_MODE_CURRENT_POSITION, OPERATING_MODE_NAMES
from robodcn.stream.servo_model import DEFAULT_P_GAIN, motor_of


@pytest.mark.parametrize("name", sorted(SERVO_SPECS))
def test_each_record_agrees_with_the_simulated_servo(name: str) -> None:
    """The simulator keeps independent tables (it never imports robodcn): the record's model
    number, current control and reflected rotor inertia match what it answers with."""
    model, sim = SERVO_SPECS[name], SIM_MODELS[name]
    assert model.name == name
    assert model.model_number == sim.model_number == MODEL_NUMBERS[name]
    assert model.current_control == sim.has_current
    assert model.offers(OPERATING_MODE_CURRENT_POSITION) == sim.has_current
    assert model.rotor_inertia == pytest.approx(SIM_MOTORS[name].inertia, rel=1e-12)
    assert model.rotor_inertia == pytest.approx(model.motor_inertia * model.gear_ratio ** 2)


@pytest.mark.parametrize("name", sorted(SERVO_SPECS))
def test_the_bus_and_stream_tables_are_the_record(name: str) -> None:
    model = SERVO_SPECS[name]
    assert MODEL_OPERATING_MODES[name] == model.operating_modes
    assert GOAL_CURRENT_UNIT_A.get(name) == model.goal_current_unit
    assert current_units([name])[0] == model.present_current_unit
    assert DEFAULT_P_GAIN[name] == model.default_p_gain
    # the stream's DC-motor model: stall current at 12 V from the record's R = V/I_s
    motor = motor_of(name)
    assert motor.voltage / motor.resistance == pytest.approx(model.stall_current)
    assert motor.inertia == pytest.approx(model.rotor_inertia)
    # the no-load speed: k·ω_nl + R·i_nl = V, i_nl = 0.1·I_s (stream.servo_model)
    assert motor.k * model.rated_speed + motor.resistance * 0.1 * model.stall_current == (
        pytest.approx(motor.voltage))


def test_the_xl430_has_no_current_modes() -> None:
    xl = SERVO_SPECS["xl430-w250"]
    assert not xl.current_control and xl.goal_current_unit is None
    assert {OPERATING_MODE_NAMES[m] for m in xl.operating_modes} == {
        "velocity", "position", "extended position", "PWM"}


@pytest.mark.parametrize("name", sorted(SERVO_SPECS))
def test_the_bus_refuses_exactly_the_modes_the_record_lacks(name: str) -> None:
    """Over the real dynamixel-sdk: every mode the record offers switches on the simulated
    servo, every other one is refused before anything is written."""
    model = SERVO_SPECS[name]
    with SimBus((1,), model=name, timing="fast") as sim, \
            open_bus(sim, [ServoSpec(1, name)]) as bus:
        for mode in OPERATING_MODE_NAMES:
            if model.offers(mode):
                bus.set_operating_mode(mode, [1])
                assert sim.servo(1).operating_mode == mode
            else:
                before = sim.servo(1).operating_mode
                with pytest.raises(InputError) as err:
                    bus.set_operating_mode(mode, [1])
                assert err.value.field == "mode" and name in err.value.message
                assert sim.servo(1).operating_mode == before


def test_rotor_inertias_default_to_the_record() -> None:
    arm = load_arm(example_path("arm2r"))
    assert rotor_inertias(arm) == tuple(SERVO_SPECS[s.model].rotor_inertia for s in arm.servos)


def _omx_with_gripper_model(tmp_path: Path, model: str, current: float = 0.5) -> Path:
    text = example_path("omx").read_text()
    head, sep, gripper = text.partition("[gripper]")
    assert sep, "the OM-X example has a [gripper] table"
    gripper = gripper.replace('model = "xm430-w350"', f'model = "{model}"', 1)
    gripper = gripper.replace("grip_current_a = 0.5", f"grip_current_a = {current}", 1)
    path = tmp_path / "px100.toml"
    path.write_text(head + sep + gripper)
    return path


def test_an_xl430_gripper_is_refused_when_the_file_loads(tmp_path: Path) -> None:
    """A PincherX-100-style gripper on an XL430: refused at load time naming the file, the
    [gripper] model key and why, not at the first gripper command on the wire."""
    path = _omx_with_gripper_model(tmp_path, "xl430-w250", current=0.4)
    with pytest.raises(ConfigError) as err:
        load_arm(path)
    assert err.value.key == "gripper.model" and err.value.value == "xl430-w250"
    text = str(err.value)
    assert str(path) in text or path.name in text
    assert "current-based position mode" in text and "xm430-w350" in text
    # the same file with an XM430 gripper loads
    ok = load_arm(_omx_with_gripper_model(tmp_path, "xm430-w350"))
    assert ok.gripper is not None and ok.gripper.servo.model == "xm430-w350"
    assert math.isclose(ok.gripper.grip_current, 0.5)
