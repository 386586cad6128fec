"""Injected faults surface in the real dynamixel-sdk as the matching COMM_* results."""

from __future__ import annotations

import time

import pytest
from dynamixel_sdk import COMM_RX_CORRUPT, COMM_RX_TIMEOUT, COMM_SUCCESS, GroupSyncRead
from fw_helpers import PH, sdk_port

from firmware_sim.bus import SimBus
from firmware_sim.faults import Fault, FaultKind
from firmware_sim.protocol import Instruction

PRESENT_POS, HW_ERROR, TORQUE = 132, 70, 64

pytest_plugins = ["fw_helpers"]     # fixtures: port (on this module's bus)


@pytest.fixture
def bus():
    """fw_helpers' ``bus`` with seeded faults."""
    with SimBus(ids=[1, 2, 3], fault_seed=7) as b:
        yield b
        assert b.errors == []


def test_drop_once_then_recovers(bus, port):
    fault = bus.faults.drop(2)
    assert PH.ping(port, 2)[1] == COMM_RX_TIMEOUT
    assert PH.ping(port, 2)[1] == COMM_SUCCESS
    assert PH.ping(port, 1)[1] == COMM_SUCCESS
    assert fault.fired == 1 and fault.spent
    assert "dropped" in bus.packets("tx", servo_id=2)[0].note


def test_drop_n_times_and_only_for_an_instruction(bus, port):
    bus.faults.drop(1, times=2, instructions=[Instruction.READ])
    assert PH.ping(port, 1)[1] == COMM_SUCCESS           # pings unaffected
    results = [PH.read4ByteTxRx(port, 1, PRESENT_POS)[1] for _ in range(3)]
    assert results == [COMM_RX_TIMEOUT, COMM_RX_TIMEOUT, COMM_SUCCESS]


def test_drop_with_probability_counts_match(bus, port):
    fault = bus.faults.drop(3, times=None, probability=0.5)
    results = [PH.ping(port, 3)[1] for _ in range(12)]
    assert results.count(COMM_RX_TIMEOUT) == fault.fired
    assert 0 < fault.fired < 12                     # seed 7 gives a mix; 1 - 2·0.5¹² certain
    assert set(results) <= {COMM_SUCCESS, COMM_RX_TIMEOUT}


@pytest.fixture
def sdk_timeout_port(bus):
    """A port on the SDK's own ≈ 34 ms packet timeout (the tests below time against it)."""
    with sdk_port(bus, margin_ms=0.0) as p:
        yield p


@pytest.mark.serial  # times a 10 ms and a 60 ms delay against the 34 ms timeout
def test_delay_short_is_accepted_long_times_out(bus, sdk_timeout_port):
    port = sdk_timeout_port
    bus.faults.delay(0.010, 1)
    t0 = time.perf_counter()
    assert PH.ping(port, 1)[1] == COMM_SUCCESS
    assert time.perf_counter() - t0 >= 0.010
    bus.faults.delay(0.060, 1)                      # beyond the SDK's 34 ms timeout
    assert PH.ping(port, 1)[1] == COMM_RX_TIMEOUT
    time.sleep(0.05)                                # let the late reply pass
    assert PH.ping(port, 1)[1] == COMM_SUCCESS


def test_corrupt_crc(bus, port):
    bus.faults.corrupt_crc(2)
    assert PH.read4ByteTxRx(port, 2, PRESENT_POS)[1] == COMM_RX_CORRUPT
    assert PH.read4ByteTxRx(port, 2, PRESENT_POS)[1] == COMM_SUCCESS


def test_wrong_id(bus, port):
    fault = bus.faults.wrong_id(9, 1)
    assert PH.ping(port, 1)[1] == COMM_RX_TIMEOUT     # the SDK waits for ID 1 in vain
    assert fault.fired == 1
    assert bus.packets("tx")[-1].id == 9


def test_bus_wide_fault_hits_any_servo(bus, port):
    bus.faults.corrupt_crc(times=2)
    assert PH.ping(port, 3)[1] == COMM_RX_CORRUPT
    assert PH.ping(port, 1)[1] == COMM_RX_CORRUPT
    assert PH.ping(port, 2)[1] == COMM_SUCCESS


def _group(port, fast_ids=(1, 2, 3)):
    group = GroupSyncRead(port, PH, PRESENT_POS, 4)
    for sid in fast_ids:
        group.addParam(sid)
    return group


def test_drop_in_sync_read_times_out(bus, port):
    bus.faults.drop(2)
    assert _group(port).txRxPacket() == COMM_RX_TIMEOUT
    assert _group(port).txRxPacket() == COMM_SUCCESS


@pytest.mark.parametrize("keep", [0, 1, 2])
def test_truncate_fast_chain(bus, port, keep):
    bus.faults.truncate_fast(keep)
    expected = COMM_RX_TIMEOUT if keep == 0 else COMM_RX_CORRUPT
    assert _group(port).fastSyncRead() == expected
    assert _group(port).fastSyncRead() == COMM_SUCCESS


def test_fast_chain_member_faults(bus, port):
    bus.faults.drop(2, instructions=[Instruction.FAST_SYNC_READ])
    assert _group(port).fastSyncRead() == COMM_RX_CORRUPT   # short packet
    bus.faults.corrupt_crc(3)                                 # the last block: packet CRC
    assert _group(port).fastSyncRead() == COMM_RX_CORRUPT
    bus.faults.wrong_id(9, 1)
    assert _group(port).fastSyncRead() == COMM_RX_CORRUPT   # SDK checks each block's ID
    assert _group(port).fastSyncRead() == COMM_SUCCESS


def test_split_writes_are_reassembled(bus, port):
    fault = bus.faults.split(pieces=4, gap_s=0.002, times=None)
    t0 = time.perf_counter()
    assert PH.read4ByteTxRx(port, 1, PRESENT_POS)[1] == COMM_SUCCESS
    assert time.perf_counter() - t0 >= 3 * 0.002
    assert _group(port).fastSyncRead() == COMM_SUCCESS
    assert fault.fired == 2


def test_trip_sets_alert_and_stops_torque(bus, port):
    assert PH.write1ByteTxRx(port, 1, TORQUE, 1) == (COMM_SUCCESS, 0)
    bus.faults.trip(1, 0x20)
    value, result, error = PH.read1ByteTxRx(port, 1, HW_ERROR)
    assert (value, result) == (0x20, COMM_SUCCESS) and error & 0x80
    assert PH.read1ByteTxRx(port, 1, TORQUE)[0] == 0
    bus.faults.trip(bits=0x04)                      # bus-wide: every servo
    assert all(PH.ping(port, s)[2] & 0x80 for s in (2, 3))


def test_fault_validation_and_clear(bus, port):
    with pytest.raises(ValueError, match="probability"):
        Fault(FaultKind.DROP, probability=1.5)
    with pytest.raises(ValueError, match="times"):
        bus.faults.drop(times=0)
    bus.faults.drop(times=None)
    assert len(bus.faults.active) == 1
    bus.faults.clear()
    assert PH.ping(port, 1)[1] == COMM_SUCCESS


@pytest.mark.serial  # a 60 ms gap against the 34 ms timeout
def test_split_with_gap_beyond_timeout_is_a_partial_packet(bus, sdk_timeout_port):
    port = sdk_timeout_port
    bus.faults.split(pieces=2, gap_s=0.060, servo_id=3)
    assert PH.ping(port, 3)[1] == COMM_RX_CORRUPT           # half a packet, then timeout
    time.sleep(0.07)
    assert PH.ping(port, 3)[1] == COMM_SUCCESS
