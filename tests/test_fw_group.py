"""Group instruction parsing of firmware_sim.group, and malformed group packets over the pty:
a Sync/Bulk Write whose parameters do not parse is ignored as a whole (no part written),
a malformed Sync/Bulk Read gets no reply."""

from __future__ import annotations

import pytest
from dynamixel_sdk import COMM_SUCCESS

from firmware_sim import control_table as ct
from firmware_sim.bus import SimBus
from firmware_sim.group import read_requests, write_requests
from firmware_sim.protocol import BROADCAST_ID, Instruction, Packet, build_packet
from tests.fw_helpers import PH, sdk_port, wait_until


def _pkt(instruction: int, params: bytes) -> Packet:
    return Packet(BROADCAST_ID, instruction, params)


def _u16(x: int) -> bytes:
    return x.to_bytes(2, "little")


def test_sync_read_requests_share_one_span_in_request_order():
    params = _u16(132) + _u16(4) + bytes([3, 1, 2])
    for inst in (Instruction.SYNC_READ, Instruction.FAST_SYNC_READ):
        assert read_requests(_pkt(inst, params)) == [(3, 132, 4), (1, 132, 4), (2, 132, 4)]
        assert read_requests(_pkt(inst, params[:4])) is None      # no id


def test_bulk_read_requests_carry_their_own_span():
    params = bytes([2]) + _u16(132) + _u16(4) + bytes([1]) + _u16(64) + _u16(1)
    for inst in (Instruction.BULK_READ, Instruction.FAST_BULK_READ):
        assert read_requests(_pkt(inst, params)) == [(2, 132, 4), (1, 64, 1)]
        assert read_requests(_pkt(inst, params[:-1])) is None     # not a multiple of 5
        assert read_requests(_pkt(inst, b"")) is None


def test_sync_write_parts_have_the_stride_of_the_length():
    params = _u16(116) + _u16(4) + bytes([1]) + _u16(100) + _u16(0) + bytes([2]) + bytes(4)
    assert write_requests(_pkt(Instruction.SYNC_WRITE, params)) == [
        (1, 116, _u16(100) + _u16(0)), (2, 116, bytes(4))]
    assert write_requests(_pkt(Instruction.SYNC_WRITE, params[:-1])) is None
    assert write_requests(_pkt(Instruction.SYNC_WRITE, _u16(116) + _u16(0))) is None
    assert write_requests(_pkt(Instruction.SYNC_WRITE, _u16(116))) is None


def test_bulk_write_parts_and_a_part_longer_than_the_packet():
    params = bytes([1]) + _u16(65) + _u16(1) + b"\x01" + bytes([2]) + _u16(116) + _u16(2) + b"ab"
    assert write_requests(_pkt(Instruction.BULK_WRITE, params)) == [
        (1, 65, b"\x01"), (2, 116, b"ab")]
    assert write_requests(_pkt(Instruction.BULK_WRITE, params[:-1])) is None   # part cut short
    assert write_requests(_pkt(Instruction.BULK_WRITE, params + b"\x07")) is None  # trailing byte


@pytest.mark.parametrize("instruction", [Instruction.SYNC_WRITE, Instruction.BULK_WRITE])
def test_malformed_group_write_writes_no_part(instruction):
    led_on = b"\x01"
    if instruction == Instruction.SYNC_WRITE:      # a second part one byte short
        params = _u16(ct.LED) + _u16(1) + bytes([1]) + led_on + bytes([2])
    else:                                          # the second part's data missing
        params = bytes([1]) + _u16(ct.LED) + _u16(1) + led_on + bytes([2]) + _u16(ct.LED) + _u16(1)
    with SimBus(ids=[1, 2]) as bus, sdk_port(bus) as port:
        port.writePort(list(build_packet(BROADCAST_ID, instruction, params)))
        # a well-formed write after it marks when the malformed one has been handled
        assert PH.write1ByteTxRx(port, 2, ct.RETURN_DELAY_TIME, 0)[0] == COMM_SUCCESS
        wait_until(lambda: bus.rx_packets >= 2)
        assert [bus.servo(i).get(ct.LED) for i in (1, 2)] == [0, 0]
        assert bus.packets("tx", servo_id=BROADCAST_ID) == []
        assert bus.errors == []
