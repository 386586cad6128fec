"""The indirect feedback map is checked when configuring (issue 17 §4), on the wire: the real
dynamixel-sdk against firmware_sim servos that acknowledge the map but do not serve it.

firmware_sim has no knob for a servo that ignores Indirect Address writes (an older
firmware, a clone), so the tests replace one simulated servo's ``write`` or ``read`` in
process; the bytes still cross the pty through the SDK.
"""

from __future__ import annotations

import subprocess
import sys

import pytest
from conftest import ARM3R, ROOT, open_bus

from robodcn.bus import ADDR_FEEDBACK, ADDR_PRESENT_POSITION, FEEDBACK_LENGTH
from robodcn.bus.feedback import ADDR_INDIRECT_ADDRESS_29, indirect_map
from robodcn.cli.exit_codes import Exit, exit_for_error
from robodcn.errors import FeedbackMapError

#: Indirect Address 29..56 (2 bytes each) and Indirect Data 29..56.
INDIRECT_ADDRESSES = range(ADDR_INDIRECT_ADDRESS_29, ADDR_INDIRECT_ADDRESS_29 + 2 * 28)
FEEDBACK_BLOCK = range(ADDR_FEEDBACK, ADDR_FEEDBACK + FEEDBACK_LENGTH)


def ignore_map_writes(monkeypatch, servo) -> None:
    """``servo`` acknowledges a WRITE to Indirect Address 29.. and keeps its factory map."""
    real = servo.write

    def write(address: int, data: bytes) -> int:
        if address in INDIRECT_ADDRESSES:
            return 0
        return real(address, data)

    monkeypatch.setattr(servo, "write", write)


def zero_feedback_block(monkeypatch, servo) -> None:
    """``servo`` stores the map but its Indirect Data 29.. always reads zeros (a clone)."""
    real = servo.read

    def read(address: int, length: int) -> tuple[int, bytes]:
        code, data = real(address, length)
        if code == 0 and set(range(address, address + length)) & set(FEEDBACK_BLOCK):
            return 0, bytes(length)
        return code, data

    monkeypatch.setattr(servo, "read", read)


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


def test_a_servo_ignoring_the_map_writes_is_named(sim3, monkeypatch):
    ignore_map_writes(monkeypatch, sim3.servo(2))
    exc, torque, _ = refused(sim3)
    # The arm is left holding where it was (torque on, goal = present).
    assert all(torque.values())
    assert exc.servo_id == 2 and exc.item == "indirect_address"
    assert exc.field == "servo[2]" and exc.value["servo_id"] == 2
    # Factory map: Indirect Address 29 points at Indirect Data 29 (634); 132 was written.
    assert exc.expected[0] == ADDR_PRESENT_POSITION and exc.got[0] == ADDR_FEEDBACK
    assert "indirect feedback map" in exc.message and "servo 2" in exc.message
    assert exit_for_error(exc) == Exit.FAULT == 4
    assert exc.http_status == 503 and exc.to_dict()["code"] == "feedback_map"


def test_a_map_that_reads_zeros_is_caught_against_present_position(sim3, monkeypatch):
    zero_feedback_block(monkeypatch, sim3.servo(3))
    exc, _, present = refused(sim3)
    assert exc.servo_id == 3 and exc.item == "present_position"
    assert exc.got == 0 and exc.expected == present[2] == sim3.servo(3).present_position
    assert "indirect feedback map" in exc.message and "servo 3" in exc.message


def test_the_map_check_runs_on_the_fast_sync_read_path_too(sim3, monkeypatch):
    zero_feedback_block(monkeypatch, sim3.servo(1))
    with open_bus(sim3, ARM3R.servos) as bus:
        bus.verify()
        assert bus.fast_read          # firmware 46: the streamer's Fast Sync Read
        sim3.clear_log()
        with pytest.raises(FeedbackMapError, match="servo 1"):
            bus.configure()
        block = ADDR_FEEDBACK.to_bytes(2, "little") + FEEDBACK_LENGTH.to_bytes(2, "little")
        assert any(e.params[:4] == block for e in sim3.packets("rx", "FAST_SYNC_READ"))


def test_move_exits_4_naming_the_map_and_the_servo(sim3, monkeypatch):
    # The CLI in a subprocess against this process's simulated bus on its pty.
    ignore_map_writes(monkeypatch, sim3.servo(2))
    out = subprocess.run([sys.executable, "-m", "robodcn", "move", "--arm",
                          str(ROOT / "configs" / "arm3r.toml"), "--device", sim3.port_path,
                          "--to", "0.12,0.24,60"], capture_output=True, text=True,
                         timeout=120, cwd=ROOT)
    assert out.returncode == 4, out.stderr
    assert "indirect feedback map" in out.stderr and "servo 2" in out.stderr
    assert "Traceback" not in out.stderr
