"""SimBus driven by the real dynamixel-sdk over the pty: every instruction, the broadcast and
Status Return Level rules, error codes in the SDK's error byte, goal history, the log.

Addresses are the X-series control table (dynamixel-notes.md §2); expected values come
from the servo objects themselves or from the protocol rules, never from a recorded run.
"""

from __future__ import annotations

import itertools
import time

import pytest
from dynamixel_sdk import (
    COMM_RX_CORRUPT,
    COMM_RX_TIMEOUT,
    COMM_SUCCESS,
    GroupBulkRead,
    GroupBulkWrite,
    GroupSyncRead,
    GroupSyncWrite,
)
from fw_helpers import (
    PH,
    raw_instruction,
    raw_txrx,
    s32,
    sdk_port,
    settle,
    wait_ping,
    wait_until,
)

from firmware_sim.bus import SimBus
from firmware_sim.clock import VirtualClock
from firmware_sim.protocol import (
    BROADCAST_ID,
    Instruction,
    build_packet,
    parse_fast_status,
    parse_packet,
)

RETURN_DELAY, OPERATING_MODE, HOMING_OFFSET, MAX_POS = 9, 11, 20, 48
TORQUE, SRL, REGISTERED, HW_ERROR, BUS_WATCHDOG = 64, 68, 69, 70, 98
PROFILE_ACC, PROFILE_VEL, GOAL, MOVING, PRESENT_POS = 108, 112, 116, 122, 132
IND_ADDR_1, IND_DATA_1 = 168, 224

pytest_plugins = ["fw_helpers"]     # fixtures: bus (servos 1, 2, 3), port


def u32(value: int) -> list[int]:
    return list((value & 0xFFFF_FFFF).to_bytes(4, "little"))


# ---- PING ------------------------------------------------------------------------------
def test_ping_each_servo(bus, port):
    for sid in (1, 2, 3):
        model, result, error = PH.ping(port, sid)
        assert (result, error) == (COMM_SUCCESS, 0)
        assert model == bus.servo(sid).model_number
    _, result, _ = PH.ping(port, 9)
    assert result == COMM_RX_TIMEOUT


def test_broadcast_ping_three_ids_ascending():
    with SimBus(ids=[3, 1, 2], firmware={1: 46, 2: 45, 3: 44}) as bus, sdk_port(bus) as port:
        found, result = PH.broadcastPing(port)
        assert result == COMM_SUCCESS
        assert found == {s.id: [s.model_number, s.firmware_version] for s in bus.servos}
        assert [e.id for e in bus.packets("tx")] == [1, 2, 3]
        assert bus.errors == []


# ---- READ / WRITE, stuffing ------------------------------------------------------------
def test_write_then_read_round_trip(bus, port):
    for sid, value in ((1, 100), (2, 2000), (3, 32767)):
        result, error = PH.write4ByteTxRx(port, sid, PROFILE_VEL, value)
        assert (result, error) == (COMM_SUCCESS, 0)
    for sid, value in ((1, 100), (2, 2000), (3, 32767)):
        got, result, error = PH.read4ByteTxRx(port, sid, PROFILE_VEL)
        assert (got, result, error) == (value, COMM_SUCCESS, 0)
        assert bus.servo(sid).read(PROFILE_VEL, 4) == (0, value.to_bytes(4, "little"))


def test_stuffing_of_value_containing_header(bus, port):
    value = -131073                       # little-endian FF FF FD FF
    assert bytes(u32(value)) == b"\xff\xff\xfd\xff"
    result, error = PH.write4ByteTxRx(port, 1, HOMING_OFFSET, value & 0xFFFF_FFFF)
    assert (result, error) == (COMM_SUCCESS, 0)
    bus.clear_log()
    got, result, error = PH.read4ByteTxRx(port, 1, HOMING_OFFSET)
    assert (s32(got), result, error) == (value, COMM_SUCCESS, 0)
    (reply,) = bus.packets("tx")
    assert b"\xff\xff\xfd\xfd\xff" in reply.raw          # stuffed on the wire
    assert parse_packet(reply.raw).params[1:] == bytes(u32(value))
    # a stuffed instruction from the host is unstuffed by the sim
    pkt = build_packet(2, Instruction.WRITE, bytes([HOMING_OFFSET, 0, *u32(value)]))
    assert b"\xff\xff\xfd\xfd" in pkt
    rx, result = raw_txrx(port, pkt)
    assert result == COMM_SUCCESS and rx[8] == 0
    assert s32(int.from_bytes(bus.servo(2).read(HOMING_OFFSET, 4)[1], "little")) == value


def test_read_error_has_no_params(bus, port):
    # undefined address: Access Error, status without data (as real firmware)
    rx, result = raw_instruction(port, 1, Instruction.READ, bytes([0xFF, 0x03, 4, 0]))
    assert result == COMM_SUCCESS
    status = parse_packet(bytes(rx))
    assert status.error == 0x07 and status.params == b"\x07"


# ---- REG_WRITE / ACTION ----------------------------------------------------------------
def test_reg_write_then_action(bus, port):
    before = bus.servo(2).goal_position
    result, error = PH.regWriteTxRx(port, 2, GOAL, 4, u32(before + 100))
    assert (result, error) == (COMM_SUCCESS, 0)
    assert bus.servo(2).goal_position == before
    assert PH.read1ByteTxRx(port, 2, REGISTERED)[:2] == (1, COMM_SUCCESS)
    assert PH.action(port, 2) == COMM_SUCCESS
    settle(port, 2)
    assert bus.servo(2).goal_position == before + 100
    assert PH.read1ByteTxRx(port, 2, REGISTERED)[:2] == (0, COMM_SUCCESS)
    assert bus.goal_history(2) == [before + 100]
    # ACTION with nothing registered: Instruction Error, read as a raw status packet
    rx, result = raw_instruction(port, 2, Instruction.ACTION)
    assert result == COMM_SUCCESS and parse_packet(bytes(rx)).error == 0x02


def test_broadcast_action_runs_every_registered_write(bus, port):
    for sid in (1, 2, 3):
        assert PH.regWriteTxRx(port, sid, GOAL, 4, u32(1000 + sid))[:2] == (COMM_SUCCESS, 0)
    assert PH.action(port, BROADCAST_ID) == COMM_SUCCESS
    settle(port, 3)
    assert [bus.goal_history(s) for s in (1, 2, 3)] == [[1001], [1002], [1003]]


# ---- REBOOT / FACTORY_RESET / CLEAR / BACKUP ---------------------------------------------
def test_reboot_clears_hardware_error(bus, port):
    bus.faults.trip(1, 0x20)
    value, result, error = PH.read1ByteTxRx(port, 1, HW_ERROR)
    assert (value, result) == (0x20, COMM_SUCCESS)
    assert error & 0x80
    assert bus.servo(1).torque_enabled is False
    result, error = PH.reboot(port, 1)
    assert result == COMM_SUCCESS and error & 0x80        # status formed before the reboot
    wait_ping(port, 1)
    value, result, error = PH.read1ByteTxRx(port, 1, HW_ERROR)
    assert (value, result, error) == (0, COMM_SUCCESS, 0)


@pytest.mark.parametrize(("option", "keeps_id", "keeps_baud"),
                         [(0x02, True, True), (0x01, True, False), (0xFF, False, False)])
def test_factory_reset_options(option, keeps_id, keeps_baud):
    with SimBus(ids=[5]) as bus, sdk_port(bus) as port:
        servo = bus.servo(5)
        default_rdt = servo.return_delay_us
        assert PH.write1ByteTxRx(port, 5, RETURN_DELAY, 7) == (COMM_SUCCESS, 0)
        result, error = PH.factoryReset(port, 5, option)
        assert (result, error) == (COMM_SUCCESS, 0)
        new_id = 5 if keeps_id else 1
        if not keeps_baud:
            # factory baud (Baud Rate item default) differs from the 1 Mbps we used
            _, result, _ = PH.ping(port, new_id)
            assert result == COMM_RX_TIMEOUT
            from firmware_sim.control_table import BAUD_RATES
            assert port.setBaudRate(BAUD_RATES[servo.baud_index])
        wait_ping(port, new_id)
        assert servo.id == new_id
        assert servo.return_delay_us == default_rdt
        if not keeps_id:
            assert PH.ping(port, 5)[1] == COMM_RX_TIMEOUT
        assert bus.errors == []


def test_broadcast_factory_reset_all_is_ignored(bus, port):
    assert PH.write1ByteTxRx(port, 1, RETURN_DELAY, 7) == (COMM_SUCCESS, 0)
    result, _ = PH.factoryReset(port, BROADCAST_ID, 0xFF)
    assert result == COMM_SUCCESS
    assert PH.read1ByteTxRx(port, 1, RETURN_DELAY)[:2] == (7, COMM_SUCCESS)


def test_clear_multi_turn(bus, port):
    assert PH.clearMultiTurn(port, 1) == (COMM_SUCCESS, 0)
    # moving: Result Fail
    s = bus.servo(3)
    assert PH.write4ByteTxRx(port, 3, PROFILE_VEL, 1)[0] == COMM_SUCCESS
    assert PH.write1ByteTxRx(port, 3, TORQUE, 1) == (COMM_SUCCESS, 0)
    target = 0 if s.present_position > 2048 else 4095
    assert PH.write4ByteTxRx(port, 3, GOAL, target) == (COMM_SUCCESS, 0)
    assert PH.read1ByteTxRx(port, 3, MOVING)[:2] == (1, COMM_SUCCESS)
    assert PH.clearMultiTurn(port, 3) == (COMM_SUCCESS, 0x01)


def test_control_table_backup(bus, port):
    store = bytes([0x01, 0x43, 0x54, 0x52, 0x4C])
    restore = bytes([0x02, 0x43, 0x54, 0x52, 0x4C])
    rx, result = raw_instruction(port, 1, Instruction.CONTROL_TABLE_BACKUP, restore)
    assert result == COMM_SUCCESS and parse_packet(bytes(rx)).error == 0x01   # nothing stored
    assert PH.write1ByteTxRx(port, 1, RETURN_DELAY, 42) == (COMM_SUCCESS, 0)
    rx, result = raw_instruction(port, 1, Instruction.CONTROL_TABLE_BACKUP, store)
    assert result == COMM_SUCCESS and parse_packet(bytes(rx)).error == 0
    assert PH.write1ByteTxRx(port, 1, RETURN_DELAY, 7) == (COMM_SUCCESS, 0)
    rx, result = raw_instruction(port, 1, Instruction.CONTROL_TABLE_BACKUP, restore)
    assert result == COMM_SUCCESS and parse_packet(bytes(rx)).error == 0
    wait_ping(port, 1)                     # restore reboots the servo
    assert PH.read1ByteTxRx(port, 1, RETURN_DELAY)[:2] == (42, COMM_SUCCESS)
    assert PH.write1ByteTxRx(port, 1, TORQUE, 1) == (COMM_SUCCESS, 0)
    rx, result = raw_instruction(port, 1, Instruction.CONTROL_TABLE_BACKUP, store)
    assert result == COMM_SUCCESS and parse_packet(bytes(rx)).error == 0x01


# ---- SYNC / BULK ------------------------------------------------------------------------
def _set_distinct(port, address=PROFILE_VEL, values=None):
    values = values or {1: 11, 2: 222, 3: 3333}
    for sid, v in values.items():
        assert PH.write4ByteTxRx(port, sid, address, v) == (COMM_SUCCESS, 0)
    return values


def _sync_read_distinct(bus, port, order, fast):
    """Distinct Profile Velocities (:func:`_set_distinct`) sync-read in ``order`` (a Fast Sync
    Read if ``fast``) after clearing the log: each servo's own value comes back."""
    values = _set_distinct(port)
    group = GroupSyncRead(port, PH, PROFILE_VEL, 4)
    for sid in order:
        group.addParam(sid)
    bus.clear_log()
    assert (group.fastSyncRead() if fast else group.txRxPacket()) == COMM_SUCCESS
    assert {sid: group.getData(sid, PROFILE_VEL, 4) for sid in (1, 2, 3)} == values


def test_sync_read_in_request_order(bus, port):
    _sync_read_distinct(bus, port, (3, 1, 2), fast=False)
    assert [e.id for e in bus.packets("tx")] == [3, 1, 2]


def test_fast_sync_read_three_ids(bus, port):
    _sync_read_distinct(bus, port, (2, 3, 1), fast=True)
    (reply,) = bus.packets("tx")
    assert len(reply.raw) == 8 + 8 * 3
    blocks = parse_fast_status(reply.raw, [4, 4, 4])
    assert [b[1] for b in blocks] == [2, 3, 1] and all(b[3] for b in blocks)


def test_fast_sync_read_fails_with_old_firmware_but_sync_read_works():
    with SimBus(ids=[1, 2, 3], firmware={1: 46, 2: 44, 3: 46}) as bus, sdk_port(bus) as port:
        group = GroupSyncRead(port, PH, PRESENT_POS, 4)
        for sid in (1, 2, 3):
            group.addParam(sid)
        assert group.fastSyncRead() == COMM_RX_CORRUPT
        assert group.txRxPacket() == COMM_SUCCESS
        assert [s32(group.getData(s, PRESENT_POS, 4)) for s in (1, 2, 3)] == \
            [bus.servo(s).present_position for s in (1, 2, 3)]
        assert bus.packets("tx")[-4].note == "fast: 1,2 silent,3"
        # every servo below 45: nobody answers at all
    with SimBus(ids=[1, 2], firmware=44) as bus, sdk_port(bus) as port:
        group = GroupSyncRead(port, PH, PRESENT_POS, 4)
        group.addParam(1)
        group.addParam(2)
        assert group.fastSyncRead() == COMM_RX_TIMEOUT


@pytest.mark.parametrize("stops", [False, True])
def test_fast_chain_with_a_silent_member(stops):
    with SimBus(ids=[1, 2, 3], firmware={1: 46, 2: 44, 3: 46}, fast_chain_stops=stops) as bus, \
            sdk_port(bus) as port:
        group = GroupSyncRead(port, PH, PRESENT_POS, 4)
        for sid in (1, 2, 3):
            group.addParam(sid)
        assert group.fastSyncRead() == COMM_RX_CORRUPT
        (reply,) = bus.packets("tx")
        assert len(reply.raw) == 8 + 8 * (1 if stops else 2)
        assert reply.raw[5] == 1 + 3 * 8                 # LEN still announces all three
        assert bus.errors == []


def _bulk_read(port, fast):
    group = GroupBulkRead(port, PH)
    layout = {1: (PROFILE_VEL, 4), 2: (RETURN_DELAY, 1), 3: (MAX_POS, 4)}
    for sid, (address, length) in layout.items():
        assert group.addParam(sid, address, length)
    result = group.fastBulkRead() if fast else group.txRxPacket()
    return result, {sid: group.getData(sid, a, n) for sid, (a, n) in layout.items()}, layout


@pytest.mark.parametrize("fast", [False, True])
def test_bulk_read_and_fast_bulk_read(bus, port, fast):
    _set_distinct(port, values={1: 77})
    result, got, layout = _bulk_read(port, fast)
    assert result == COMM_SUCCESS
    expect = {sid: int.from_bytes(bus.servo(sid).read(a, n)[1], "little")
              for sid, (a, n) in layout.items()}
    assert got == expect and got[1] == 77


def test_sync_write_and_bulk_write(bus, port):
    group = GroupSyncWrite(port, PH, GOAL, 4)
    for sid in (1, 2, 3):
        group.addParam(sid, u32(1000 + 10 * sid))
    assert group.txPacket() == COMM_SUCCESS
    bulk = GroupBulkWrite(port, PH)
    bulk.addParam(1, GOAL, 4, u32(3000))
    bulk.addParam(2, PROFILE_VEL, 4, u32(55))
    assert bulk.txPacket() == COMM_SUCCESS
    settle(port, 1)
    assert [bus.servo(s).goal_position for s in (1, 2, 3)] == [3000, 1020, 1030]
    assert bus.servo(2).read(PROFILE_VEL, 4) == (0, (55).to_bytes(4, "little"))
    assert bus.goal_history(1) == [1010, 3000]
    assert bus.goal_history(2) == [1020]
    # no status packets for writes to the broadcast ID
    assert bus.packets("tx") == [e for e in bus.packets("tx") if e.id != BROADCAST_ID]
    assert all(e.instruction == "STATUS" for e in bus.packets("tx"))


def test_goal_history_skips_rejected_and_follows_indirect(bus, port):
    assert PH.write4ByteTxRx(port, 1, GOAL, 500) == (COMM_SUCCESS, 0)
    result, error = PH.write4ByteTxRx(port, 1, GOAL, 5000)      # above Max Position Limit
    assert (result, error) == (COMM_SUCCESS, 0x06)
    for k in range(4):    # Indirect Address k+1 -> Goal Position byte k
        assert PH.write2ByteTxRx(port, 1, IND_ADDR_1 + 2 * k, GOAL + k) == (COMM_SUCCESS, 0)
    assert PH.write4ByteTxRx(port, 1, IND_DATA_1, 700) == (COMM_SUCCESS, 0)
    assert bus.goal_history(1) == [500, 700]
    assert bus.servo(1).goal_position == 700


def test_goal_history_keeps_the_newest_goal_limit():
    with SimBus(ids=[1], goal_limit=3) as bus, sdk_port(bus) as port:
        goals = [100, 200, 300, 400, 500]
        for goal in goals:
            assert PH.write4ByteTxRx(port, 1, GOAL, goal) == (COMM_SUCCESS, 0)
        assert bus.goal_history(1) == goals[-3:]


# ---- broadcast and Status Return Level rules --------------------------------------------
def test_broadcast_write_is_silent_and_broadcast_read_not_executed(bus, port):
    assert PH.write1ByteTxOnly(port, BROADCAST_ID, RETURN_DELAY, 3) == COMM_SUCCESS
    settle(port, 1)
    assert all(s.return_delay_us == 6 for s in bus.servos)
    bus.clear_log()
    pkt = build_packet(BROADCAST_ID, Instruction.READ, bytes([RETURN_DELAY, 0, 1, 0]))
    _, result = raw_txrx(port, pkt)
    assert result == COMM_RX_TIMEOUT
    assert bus.packets("tx") == []


def test_status_return_level(bus, port):
    assert PH.write1ByteTxRx(port, 1, SRL, 1) == (COMM_SUCCESS, 0)
    # level 1: reads answer, writes execute silently
    assert PH.write4ByteTxRx(port, 1, PROFILE_VEL, 9)[0] == COMM_RX_TIMEOUT
    assert PH.read4ByteTxRx(port, 1, PROFILE_VEL)[:2] == (9, COMM_SUCCESS)
    assert PH.write1ByteTxRx(port, 1, SRL, 0)[0] == COMM_RX_TIMEOUT
    # level 0: only PING answers
    assert PH.read4ByteTxRx(port, 1, PROFILE_VEL)[1] == COMM_RX_TIMEOUT
    assert PH.ping(port, 1)[1] == COMM_SUCCESS
    assert bus.servo(1).status_return_level == 0


def test_baud_mismatch_is_silent(bus, port):
    assert port.setBaudRate(57600)
    assert PH.ping(port, 1)[1] == COMM_RX_TIMEOUT
    assert port.setBaudRate(1_000_000)
    assert PH.ping(port, 1)[1] == COMM_SUCCESS


# ---- error codes ------------------------------------------------------------------------
def test_error_codes_surface_in_sdk_error_byte(bus, port):
    # 0x02 undefined instruction
    rx, result = raw_instruction(port, 1, 0x77)
    assert result == COMM_SUCCESS and rx[8] == 0x02
    # 0x03 CRC error: the servo answers a unicast packet whose CRC is wrong
    bad = bytearray(build_packet(1, Instruction.READ, bytes([PRESENT_POS, 0, 4, 0])))
    bad[-1] ^= 0x01
    rx, result = raw_txrx(port, bytes(bad))
    assert result == COMM_SUCCESS and rx[8] == 0x03
    # 0x04 value out of range (Operating Mode 2 does not exist)
    assert PH.write1ByteTxRx(port, 1, OPERATING_MODE, 2) == (COMM_SUCCESS, 0x04)
    # 0x05 wrong length: 2 bytes into the 4-byte Goal Position
    assert PH.write2ByteTxRx(port, 1, GOAL, 100) == (COMM_SUCCESS, 0x05)
    # 0x06 outside the position limits
    assert PH.write4ByteTxRx(port, 1, GOAL, 5000) == (COMM_SUCCESS, 0x06)
    # 0x07 read-only item
    assert PH.write4ByteTxRx(port, 1, PRESENT_POS, 0) == (COMM_SUCCESS, 0x07)
    # 0x80 alert while a hardware error is latched
    bus.faults.trip(2, 0x20)
    assert PH.ping(port, 2)[1:] == (COMM_SUCCESS, 0x80)
    assert PH.write4ByteTxRx(port, 2, GOAL, 5000) == (COMM_SUCCESS, 0x86)
    assert "Hardware error" in PH.getRxPacketError(0x80)


def test_eeprom_lock(bus, port):
    assert PH.write1ByteTxRx(port, 3, RETURN_DELAY, 10) == (COMM_SUCCESS, 0)
    assert PH.write1ByteTxRx(port, 3, TORQUE, 1) == (COMM_SUCCESS, 0)
    assert PH.write1ByteTxRx(port, 3, RETURN_DELAY, 20) == (COMM_SUCCESS, 0x07)
    assert PH.read1ByteTxRx(port, 3, RETURN_DELAY)[:2] == (10, COMM_SUCCESS)
    assert PH.write1ByteTxRx(port, 3, TORQUE, 0) == (COMM_SUCCESS, 0)
    assert PH.write1ByteTxRx(port, 3, RETURN_DELAY, 20) == (COMM_SUCCESS, 0)


# ---- framing ------------------------------------------------------------------------------
def test_partial_packet_dropped_after_gap(bus, port):
    pkt = build_packet(1, Instruction.PING)
    port.clearPort()
    port.writePort(list(pkt[:6]))
    time.sleep(0.01)
    _, result = raw_txrx(port, pkt[6:])
    assert result == COMM_RX_TIMEOUT
    # the line is clean again: a whole packet is answered
    assert PH.ping(port, 1)[1] == COMM_SUCCESS


def test_packet_log_decodes_both_directions(bus, port):
    bus.clear_log()
    assert PH.write4ByteTxRx(port, 2, PROFILE_VEL, 0x1234) == (COMM_SUCCESS, 0)
    rx, tx = bus.log
    assert (rx.direction, rx.id, rx.instruction) == ("rx", 2, "WRITE")
    assert rx.params == bytes([PROFILE_VEL, 0, 0x34, 0x12, 0, 0])
    assert (tx.direction, tx.id, tx.instruction, tx.error) == ("tx", 2, "STATUS", 0)
    assert tx.time >= rx.time
    assert "WRITE" in str(rx) and "err=0x00" in str(tx)


def test_packet_log_can_be_kept_for_a_stretch(bus, port):
    bus.clear_log()
    bus.keep_log(False)
    assert PH.write4ByteTxRx(port, 2, PROFILE_VEL, 7) == (COMM_SUCCESS, 0)
    assert bus.log == []
    bus.keep_log()
    assert PH.write4ByteTxRx(port, 2, PROFILE_VEL, 8) == (COMM_SUCCESS, 0)
    assert [e.instruction for e in bus.log] == ["WRITE", "STATUS"]


# ---- a profiled move observed through the SDK ------------------------------------------
@pytest.mark.parametrize(("velocity", "accel", "distance"), [(100, 50, 300), (200, 20, 500)])
def test_profiled_move_matches_x_series_formula(velocity, accel, distance):
    clock = VirtualClock()
    with SimBus(ids=[1], clock=clock) as bus, sdk_port(bus) as port:
        start = s32(PH.read4ByteTxRx(port, 1, PRESENT_POS)[0])
        target = start + distance if start < 2048 else start - distance
        assert PH.write4ByteTxRx(port, 1, PROFILE_ACC, accel) == (COMM_SUCCESS, 0)
        assert PH.write4ByteTxRx(port, 1, PROFILE_VEL, velocity) == (COMM_SUCCESS, 0)
        assert PH.write1ByteTxRx(port, 1, TORQUE, 1) == (COMM_SUCCESS, 0)
        assert PH.write4ByteTxRx(port, 1, GOAL, target) == (COMM_SUCCESS, 0)
        step = 0.002
        seen, t = [], 0.0
        while True:
            pos, result, _ = PH.read4ByteTxRx(port, 1, PRESENT_POS)
            moving, result2, _ = PH.read1ByteTxRx(port, 1, MOVING)
            assert result == result2 == COMM_SUCCESS
            seen.append(s32(pos))
            if not moving:
                break
            assert t < 5.0, "move did not finish"
            clock.advance(step)
            t += step
        # X-series velocity profile (dynamixel-notes §2.1): accel time 64·V/A ms; a
        # trapezoid when |Δ| ≥ V²/A·(64/60000·...) else a triangle with a = 244.1·A pulse/s²
        v_pps = velocity * 0.229 * 4096 / 60          # pulse/s
        a_pps2 = accel * 214.577 * 4096 / 3600        # pulse/s²
        t_acc = v_pps / a_pps2
        assert t_acc == pytest.approx(64 * velocity / accel / 1e3, rel=1e-3)
        if distance >= v_pps * t_acc:
            expected = t_acc + distance / v_pps
        else:
            expected = 2 * (distance / a_pps2) ** 0.5
        assert seen[-1] == target
        assert all((b - a) * (target - start) >= 0 for a, b in itertools.pairwise(seen))
        assert t == pytest.approx(expected, abs=2 * step)
        assert bus.errors == []


def test_bus_watchdog_fed_only_by_instructions_addressed_to_the_servo():
    clock = VirtualClock()
    with SimBus(ids=[1, 2], clock=clock) as bus, sdk_port(bus) as port:
        for sid in (1, 2):
            assert PH.write1ByteTxRx(port, sid, TORQUE, 1) == (COMM_SUCCESS, 0)
            assert PH.write1ByteTxRx(port, sid, BUS_WATCHDOG, 2) == (COMM_SUCCESS, 0)  # 40 ms
        group = GroupSyncWrite(port, PH, GOAL, 4)
        group.addParam(1, u32(bus.servo(1).goal_position))
        for _ in range(4):
            clock.advance(0.030)
            seen = bus.rx_packets
            assert group.txPacket() == COMM_SUCCESS      # names servo 1 only
            wait_until(lambda n=seen: bus.rx_packets > n)
        assert not bus.servo(1).watchdog_tripped
        assert bus.servo(2).watchdog_tripped
        value, result, _ = PH.read1ByteTxRx(port, 2, BUS_WATCHDOG)
        assert (result, value) == (COMM_SUCCESS, 0xFF)      # -1 as a signed byte
        assert bus.errors == []
