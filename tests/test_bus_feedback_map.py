"""The indirect feedback map is checked when configuring (issue 17 §4), on the wire: the real
dynamixel-sdk against firmware_sim servos that acknowledge the map but do not serve it.

firmware_sim's per-servo ``indirect`` option makes such a servo: ``"off"`` acknowledges a
WRITE to Indirect Address and stores nothing (an older firmware, a clone: the factory map
stays), ``"unresolved"`` stores the map but its Indirect Data never follows it (reads 0).
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator

import pytest
from conftest import ARM3R, ROOT, open_bus

from firmware_sim.bus import SimBus
from robodcn.bus import ADDR_FEEDBACK, ADDR_PRESENT_POSITION, FEEDBACK_LENGTH
from robodcn.bus.feedback import ADDR_INDIRECT_ADDRESS_29, indirect_map
from robodcn.cli.exit_codes import Exit, exit_for_error
from robodcn.errors import FeedbackMapError


@pytest.fixture
def sim_with(request) -> Iterator[SimBus]:
    """Servos 1, 2, 3 as sim3, with the test's ``indirect`` modes ({id: "off" or
    "unresolved"}, see the markers below); no protocol errors."""
    with SimBus((1, 2, 3), timing="fast", indirect=request.param) as bus:
        yield bus
    assert not bus.errors, bus.errors


def ignoring_map_writes(servo_id: int) -> pytest.MarkDecorator:
    """Servo ``servo_id`` acknowledges a WRITE to Indirect Address 29.. and keeps its
    factory map."""
    return pytest.mark.parametrize("sim_with", [{servo_id: "off"}], indirect=True)


def zero_feedback_block(servo_id: int) -> pytest.MarkDecorator:
    """Servo ``servo_id`` stores the map but its Indirect Data 29.. reads zeros (a clone)."""
    return pytest.mark.parametrize("sim_with", [{servo_id: "unresolved"}], indirect=True)


def test_an_honest_servo_passes_and_the_map_is_read_back(sim3):
    with open_bus(sim3, ARM3R.servos) as bus:
        bus.verify()
        sim3.clear_log()
        bus.configure()
        assert bus.configured and bus.feedback_mapped
        reads = [(e.id, e.params[:4]) for e in sim3.packets("rx", "READ")]
    block = ADDR_INDIRECT_ADDRESS_29.to_bytes(2, "little") + \
        len(indirect_map()).to_bytes(2, "little")
    assert [i for i, params in reads if params == block] == [1, 2, 3]


def refused(sim) -> tuple[FeedbackMapError, dict[int, bool], list[int]]:
    """Verify and configure a bus on ``sim``: the FeedbackMapError configure raises, then
    the torque and the present positions the bus reads after it."""
    with open_bus(sim, ARM3R.servos) as bus:
        bus.verify()
        with pytest.raises(FeedbackMapError) as err:
            bus.configure()
        assert not bus.configured and not bus.feedback_mapped
        return err.value, bus.torque_enabled(), bus.read_positions().tolist()


@ignoring_map_writes(2)
def test_a_servo_ignoring_the_map_writes_is_named(sim_with):
    exc, torque, _ = refused(sim_with)
    # The arm is left holding where it was (torque on, goal = present).
    assert all(torque.values())
    assert exc.servo_id == 2 and exc.item == "indirect_address"
    assert exc.field == "servo[2]" and exc.value["servo_id"] == 2
    # Factory map: Indirect Address 29 points at Indirect Data 29 (634); 132 was written.
    assert exc.expected[0] == ADDR_PRESENT_POSITION and exc.got[0] == ADDR_FEEDBACK
    assert "indirect feedback map" in exc.message and "servo 2" in exc.message
    assert exit_for_error(exc) == Exit.FAULT == 4
    assert exc.http_status == 503 and exc.to_dict()["code"] == "feedback_map"


@zero_feedback_block(3)
def test_a_map_that_reads_zeros_is_caught_against_present_position(sim_with):
    exc, _, present = refused(sim_with)
    assert exc.servo_id == 3 and exc.item == "present_position"
    assert exc.got == 0 and exc.expected == present[2] == sim_with.servo(3).present_position
    assert "indirect feedback map" in exc.message and "servo 3" in exc.message


@zero_feedback_block(1)
def test_the_map_check_runs_on_the_fast_sync_read_path_too(sim_with):
    with open_bus(sim_with, ARM3R.servos) as bus:
        bus.verify()
        assert bus.fast_read          # firmware 46: the streamer's Fast Sync Read
        sim_with.clear_log()
        with pytest.raises(FeedbackMapError, match="servo 1"):
            bus.configure()
        block = ADDR_FEEDBACK.to_bytes(2, "little") + FEEDBACK_LENGTH.to_bytes(2, "little")
        assert any(e.params[:4] == block for e in sim_with.packets("rx", "FAST_SYNC_READ"))


@ignoring_map_writes(2)
def test_move_exits_4_naming_the_map_and_the_servo(sim_with):
    # The CLI in a subprocess against this process's simulated bus on its pty.
    out = subprocess.run([sys.executable, "-m", "robodcn", "move", "--arm",
                          str(ROOT / "configs" / "arm3r.toml"), "--device", sim_with.port_path,
                          "--to", "0.12,0.24,60"], capture_output=True, text=True,
                         timeout=120, cwd=ROOT)
    assert out.returncode == 4, out.stderr
    assert "indirect feedback map" in out.stderr and "servo 2" in out.stderr
    assert "Traceback" not in out.stderr
