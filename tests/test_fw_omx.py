"""The OpenMANIPULATOR-X on firmware_sim through the real dynamixel-sdk over the pty, on a
virtual clock: gravity on the yawed vertical chain, current control (mode 0) and
current-based position (mode 5), and the gripper squeezing an object (issue 18 §3, §4).

Expectations come from the arm's figures (../shared/omx.md) and the XM430-W350's control
table semantics, not from a run: an uncompensated P loop (Position P Gain 800, no I) needs
an error to push against gravity, so a stretched-out arm sags by tens of ticks (≈ 0.84 N·m
at the shoulder against ≈ 0.03 N·m a tick) where the same arm without gravity holds to the
tick; torque off, it falls. Goal Current (102) is the current in mode 0 and caps it in
mode 5; position mode (3) against an object draws the stall current until the overload
alert.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest
from dynamixel_sdk import COMM_RX_TIMEOUT, COMM_SUCCESS
from fw_helpers import PH, s32, sdk_port

from firmware_sim import control_table as ct
from firmware_sim.arm_model import END_STOP_MARGIN_DEG
from firmware_sim.bus import SimBus
from firmware_sim.clock import VirtualClock
from firmware_sim.control_socket import execute
from firmware_sim.drive import OVERLOAD_TIME_S
from firmware_sim.motor import CURRENT_UNIT_A

ROOT = Path(__file__).resolve().parent.parent
OMX = ROOT / "configs" / "omx.toml"
ARM_IDS = (11, 12, 13, 14)
GRIPPER = 15
#: Shoulder angle that lays the offset first link level (omx.md: 10.62° forward of vertical).
LEVEL = math.pi / 2 - math.atan2(0.024, 0.128)
#: The gripper's grip current (omx.toml grip_current_a = 0.5 A) in Goal Current units.
GRIP = round(0.5 / CURRENT_UNIT_A)
#: An object in the jaws at −20° (servo angle), the closed position at −60°.
OBJECT_DEG, CLOSED_DEG = -20.0, -60.0


def _tick(rad: float) -> int:
    return round(2048 + rad * 4096 / (2 * math.pi))


def _u16(value: int) -> int:
    return value & 0xFFFF


def _s16(value: int) -> int:
    return value - 65536 if value & 0x8000 else value


def _patient(call):
    """``call()`` again after an SDK timeout: on a virtual clock a repeated write or read
    answers the same state, and on a loaded machine the in-process server thread can miss
    one 34 ms packet timeout (as in test_fw_physics)."""
    for _ in range(3):
        out = call()
        if out[-2] != COMM_RX_TIMEOUT:
            break
    return out


def _write(port, servo_id: int, address: int, size: int, value: int) -> None:
    write = {1: PH.write1ByteTxRx, 2: PH.write2ByteTxRx, 4: PH.write4ByteTxRx}[size]
    result, error = _patient(lambda: write(port, servo_id, address, value))
    assert (result, error) == (COMM_SUCCESS, 0), (address, value, result, error)


def _read(port, servo_id: int, address: int, size: int) -> tuple[int, int]:
    """(signed value, status ERR byte) of one item."""
    read = {1: PH.read1ByteTxRx, 2: PH.read2ByteTxRx, 4: PH.read4ByteTxRx}[size]
    value, result, error = _patient(lambda: read(port, servo_id, address))
    assert result == COMM_SUCCESS
    return {1: value, 2: _s16(value), 4: s32(value)}[size], error


def _omx_bus(tmp_path: Path, gravity: float = 9.81, positions=None):
    text = OMX.read_text(encoding="utf-8")
    assert "gravity_m_s2 = 9.81" in text
    path = tmp_path / "omx.toml"
    path.write_text(text.replace("gravity_m_s2 = 9.81", f"gravity_m_s2 = {gravity}"),
                    encoding="utf-8")
    clock = VirtualClock()
    return SimBus(arm=path, dynamics=True, clock=clock, positions=positions), clock


def _sag(tmp_path: Path, gravity: float) -> dict[int, int]:
    """Ticks each joint ends past its goal after holding the arm stretched out level."""
    start = {12: _tick(LEVEL), 13: _tick(-LEVEL)}
    bus, clock = _omx_bus(tmp_path, gravity, start)
    with bus, sdk_port(bus) as port:
        for i in ARM_IDS:
            _write(port, i, ct.TORQUE_ENABLE, 1, 1)
        goals = {i: _read(port, i, ct.GOAL_POSITION, 4)[0] for i in ARM_IDS}
        assert goals[12] == start[12] and goals[13] == start[13]
        clock.advance(2.0)
        sag = {i: _read(port, i, ct.PRESENT_POSITION, 4)[0] - goals[i] for i in ARM_IDS}
        clock.advance(0.5)
        later = {i: _read(port, i, ct.PRESENT_POSITION, 4)[0] - goals[i] for i in ARM_IDS}
        assert later == sag                                  # settled, not still falling
        if gravity:
            for i in ARM_IDS:                                # torque off: it falls
                _write(port, i, ct.TORQUE_ENABLE, 1, 0)
            clock.advance(0.3)
            fallen = _read(port, 12, ct.PRESENT_POSITION, 4)[0] - goals[12]
            assert fallen > 4 * sag[12], (fallen, sag)
            # onto the shoulder's mechanical end stop, just beyond its 1.5 rad limit
            stop = _tick(1.5 + math.radians(END_STOP_MARGIN_DEG))
            assert abs(_read(port, 12, ct.PRESENT_POSITION, 4)[0] - stop) <= 1
    return sag


def test_uncompensated_omx_droops_under_gravity(tmp_path):
    sag = _sag(tmp_path, 9.81)
    # gravity turns the arm forward and down: towards positive shoulder and elbow ticks
    assert sag[12] >= 10, sag
    assert sag[13] >= 3, sag
    assert sag[11] == 0                                      # the yaw carries no gravity
    still = _sag(tmp_path, 0.0)
    assert all(abs(v) <= 1 for v in still.values()), still


def test_omx_bus_has_the_gripper_servo():
    bus = SimBus(arm="omx", dynamics=True, clock=VirtualClock())
    assert [s.id for s in bus.servos] == [11, 12, 13, 14, 15]
    # the gripper at its zero; the arm under gravity lies at its [arm.rest] pose
    # (joints ≈ 0, -1.40, 1.30, 0.80 rad, omx.toml)
    assert bus.servo(GRIPPER).present_position == 2048
    rest = [_tick(q) for q in (0.0, -1.40, 1.30, 0.80)]
    assert all([abs(bus.servo(i).present_position - t) <= 2 for i, t in zip(ARM_IDS, rest,
                                                                          strict=True)])


def _gripper(mode: int):
    """The omx bus with an object in the gripper's jaws and the gripper in ``mode``."""
    clock = VirtualClock()
    bus = SimBus(arm=OMX, dynamics=True, clock=clock)
    assert execute(bus, f"obstacle {GRIPPER} {OBJECT_DEG}") == "ok"
    return bus, clock


def test_current_mode_holds_the_goal_current(tmp_path):
    bus, clock = _gripper(ct.MODE_CURRENT)
    with bus, sdk_port(bus) as port:
        _write(port, GRIPPER, ct.OPERATING_MODE, 1, ct.MODE_CURRENT)
        _write(port, GRIPPER, ct.CURRENT_LIMIT, 2, 1000)          # EEPROM: torque off
        _write(port, GRIPPER, ct.TORQUE_ENABLE, 1, 1)
        # above Current Limit (38) the goal is refused: Data Limit Error
        result, error = _patient(lambda: PH.write2ByteTxRx(port, GRIPPER, ct.GOAL_CURRENT,
                                                           1001))
        assert (result, error) == (COMM_SUCCESS, ct.ERR_DATA_LIMIT)
        _write(port, GRIPPER, ct.GOAL_CURRENT, 2, _u16(-GRIP))     # close on the object
        currents = []
        for _ in range(20):
            clock.advance(0.1)
            currents.append(_read(port, GRIPPER, ct.PRESENT_CURRENT, 2)[0])
        assert all(abs(c + GRIP) <= 2 for c in currents[2:]), currents
        position, _ = _read(port, GRIPPER, ct.PRESENT_POSITION, 4)
        assert abs(position - _tick(math.radians(OBJECT_DEG))) <= 1
        _, error = _read(port, GRIPPER, ct.HARDWARE_ERROR_STATUS, 1)
        assert error == 0
        # the current is the command: take the object away and the jaw closes
        assert execute(bus, f"obstacle {GRIPPER} off") == "ok"
        clock.advance(0.05)
        assert _read(port, GRIPPER, ct.PRESENT_VELOCITY, 4)[0] < -10
        assert _read(port, GRIPPER, ct.PRESENT_POSITION, 4)[0] < position


def _squeeze(mode: int, goal_current: int | None):
    """Close the gripper towards CLOSED_DEG on the object; present current, hardware error
    and torque at 0.9 s and at 0.3 s past the overload time."""
    bus, clock = _gripper(mode)
    out = []
    with bus, sdk_port(bus) as port:
        _write(port, GRIPPER, ct.OPERATING_MODE, 1, mode)
        if goal_current is not None:
            _write(port, GRIPPER, ct.GOAL_CURRENT, 2, goal_current)
        _write(port, GRIPPER, ct.TORQUE_ENABLE, 1, 1)
        _write(port, GRIPPER, ct.GOAL_POSITION, 4, _tick(math.radians(CLOSED_DEG)))
        for t in (0.9, OVERLOAD_TIME_S + 0.3):
            clock.set(clock.now() + t - (out[-1]["t"] if out else 0.0))
            current, _ = _read(port, GRIPPER, ct.PRESENT_CURRENT, 2)
            position, _ = _read(port, GRIPPER, ct.PRESENT_POSITION, 4)
            hw, error = _read(port, GRIPPER, ct.HARDWARE_ERROR_STATUS, 1)
            torque, _ = _read(port, GRIPPER, ct.TORQUE_ENABLE, 1)
            out.append({"t": t, "current": current, "position": position, "hw": hw,
                        "alert": bool(error & ct.ALERT_BIT), "torque": torque})
    return out


def test_current_based_position_grips_without_overload():
    held, later = _squeeze(ct.MODE_CURRENT_POSITION, GRIP)
    for s in (held, later):
        assert abs(s["position"] - _tick(math.radians(OBJECT_DEG))) <= 1   # on the object
        assert GRIP - 5 <= -s["current"] <= GRIP + 2, s       # squeezing at the goal current
        assert s["hw"] == 0 and not s["alert"] and s["torque"] == 1


def test_position_mode_squeezing_trips_overload():
    early, late = _squeeze(ct.MODE_POSITION, None)
    stall = 12.0 / (12.0 / 2.3)                               # V / R at 12 V: 2.3 A
    assert early["hw"] == 0 and early["torque"] == 1           # within the overload time
    assert -early["current"] * CURRENT_UNIT_A >= 0.9 * stall, early
    assert late["hw"] & ct.HW_OVERLOAD and late["alert"], late
    assert late["torque"] == 0                                 # Shutdown: torque off
    assert late["current"] == 0


@pytest.mark.parametrize("name", ["omx", "arm3r"])
def test_arm_names_resolve_without_robodcn(name):
    from firmware_sim.arm_files import find_arm
    from firmware_sim.arm_model import load_arm
    assert find_arm(name) == ROOT / "configs" / f"{name}.toml"
    assert load_arm(name) == load_arm(ROOT / "configs" / f"{name}.toml")


@pytest.mark.parametrize("servo_id", [*ARM_IDS, GRIPPER])
def test_console_commands_reach_the_gripper_and_every_yawed_joint(servo_id):
    """move (a hand backdriving the shaft), obstacle and push on the omx's servos: a joint
    of the yawed chain in its joint angle (ROBOTIS's: tick 2048 = 0°, these maps have
    direction +1), the gripper, which is no joint, in its own servo angle. A push of 2 N·m
    beats gravity's ≤ 0.84 N·m at any joint (omx.md), so each ends at its obstacle."""
    clock = VirtualClock()
    with SimBus(arm="omx", dynamics=True, clock=clock) as bus:
        servo = bus.servo(servo_id)
        assert execute(bus, f"move {servo_id} 2048") == "ok"
        assert servo.present_position == 2048
        assert execute(bus, f"obstacle {servo_id} 10") == "ok"
        assert execute(bus, f"push {servo_id} 2") == "ok"
        clock.advance(0.5)
        wall = 2048 + 10 * 4096 / 360
        assert abs(servo.present_position - wall) <= 1
        assert execute(bus, f"get {servo_id}").split()[:2] == ["ok", str(servo.present_position)]
        assert execute(bus, f"obstacle {servo_id} off") == "ok"
        clock.advance(0.2)
        assert servo.present_position > wall + 20             # nothing holds it now
        assert execute(bus, f"push {servo_id} 0") == "ok"
        assert execute(bus, f"obstacle {servo_id} -30") == "ok"    # the other side
        assert execute(bus, f"push {servo_id} -2") == "ok"
        clock.advance(1.0)
        assert abs(servo.present_position - (2048 - 30 * 4096 / 360)) <= 1


def test_help_names_the_omx():
    out = subprocess.run([sys.executable, "-m", "firmware_sim", "--arm", "omx", "--help"],
                         cwd=ROOT, capture_output=True, text=True, timeout=20)
    assert out.returncode == 0, out.stderr
    text = " ".join(out.stdout.split())
    assert "``--arm omx`` is the OpenMANIPULATOR-X, ids 11-14" in text
    assert "the gripper 15" in text and "an object in the jaws" in text
