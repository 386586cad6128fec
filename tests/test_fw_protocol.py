"""firmware_sim.protocol: CRC vectors, stuffing, packet build/parse, the stream parser.

Vectors are the e-manual example packets (dynamixel-notes.md §1.2, §1.7); the SDK's own
CRC and stuffing routines are used as an independent second implementation.
"""

from __future__ import annotations

import pytest
from dynamixel_sdk.protocol2_packet_handler import Protocol2PacketHandler
from hypothesis import given
from hypothesis import strategies as st

from firmware_sim.protocol import (
    BROADCAST_ID,
    FastStatusWriter,
    Instruction,
    PacketParser,
    ProtocolError,
    build_fast_status,
    build_packet,
    build_status,
    crc16,
    fast_status_length,
    instruction_name,
    parse_fast_status,
    parse_packet,
    stuff,
    unstuff,
)

SDK = Protocol2PacketHandler()

# (packet without CRC, CRC bytes as sent) from the e-manual / dynamixel-notes.md §1.2
VECTORS = [
    ("FF FF FD 00 01 03 00 01", "19 4E"),
    ("FF FF FD 00 FE 03 00 01", "31 42"),
    ("FF FF FD 00 01 07 00 55 00 06 04 26", "65 5D"),
    ("FF FF FD 00 01 07 00 02 84 00 04 00", "1D 15"),
    ("FF FF FD 00 01 08 00 55 00 A6 00 00 00", "8C C0"),
    ("FF FF FD 00 01 09 00 03 74 00 00 02 00 00", "CA 89"),
    ("FF FF FD 00 01 04 00 55 00", "A1 0C"),
    ("FF FF FD 00 FE 11 00 83 74 00 04 00 01 96 00 00 00 02 AA 00 00 00", "82 87"),
    ("FF FF FD 00 FE 0A 00 8A 84 00 04 00 03 07 04", "20 F2"),
    ("FF FF FD 00 01 03 00 08", "2F 4E"),                       # REBOOT id 1
    ("FF FF FD 00 01 04 00 06 01", "A1 E6"),                    # FACTORY_RESET 0x01
    ("FF FF FD 00 01 08 00 10 01 44 58 4C 22", "B1 DC"),        # CLEAR
    ("FF FF FD 00 FE 09 00 82 84 00 04 00 01 02", "CE FA"),     # SYNC_READ 132/4 ids 1,2
    ("FF FF FD 00 02 08 00 55 00 1F 08 00 00", "BA BE"),        # its reply from id 2
    ("FF FF FD 00 FE 0D 00 92 01 90 00 02 00 02 92 00 01 00", "1A 05"),  # BULK_READ
    ("FF FF FD 00 01 06 00 55 00 77 00", "C3 69"),
    ("FF FF FD 00 02 05 00 55 00 24", "8B A9"),
    ("FF FF FD 00 FE 10 00 93 01 20 00 02 00 A0 00 02 1F 00 01 00 50", "B7 68"),  # BULK_WRITE
]


@pytest.mark.parametrize(("body", "crc"), VECTORS)
def test_crc_vectors(body: str, crc: str) -> None:
    data = bytes.fromhex(body)
    assert crc16(data).to_bytes(2, "little") == bytes.fromhex(crc)


def test_crc_check_value() -> None:
    # CRC-16/BUYPASS check value over ASCII "123456789"
    assert crc16(b"123456789") == 0xFEE8


@given(st.binary(max_size=300), st.integers(0, 0xFFFF))
def test_crc_matches_sdk_and_chains(data: bytes, start: int) -> None:
    assert crc16(data) == SDK.updateCRC(0, list(data), len(data))
    assert crc16(data, start) == SDK.updateCRC(start, list(data), len(data))
    cut = len(data) // 3
    assert crc16(data[cut:], crc16(data[:cut])) == crc16(data)


@pytest.mark.parametrize(("body", "crc"), [v for v in VECTORS if v[0].split()[7] != "55"])
def test_build_packet_reproduces_instruction_vectors(body: str, crc: str) -> None:
    raw = bytes.fromhex(body)
    pkt = build_packet(raw[4], raw[7], raw[8:])
    assert pkt == raw + bytes.fromhex(crc)
    parsed = parse_packet(pkt)
    assert (parsed.id, parsed.instruction, parsed.params) == (raw[4], raw[7], raw[8:])


@pytest.mark.parametrize(("body", "crc"), [v for v in VECTORS if v[0].split()[7] == "55"])
def test_build_status_reproduces_status_vectors(body: str, crc: str) -> None:
    raw = bytes.fromhex(body)
    assert build_status(raw[4], raw[8], raw[9:]) == raw + bytes.fromhex(crc)
    assert parse_packet(raw + bytes.fromhex(crc)).error == raw[8]


payload = st.lists(st.sampled_from([0xFF, 0xFD, 0x00, 0x55, 0x12]), max_size=40).map(bytes)


@given(payload)
def test_stuffing_round_trip_and_matches_sdk(params: bytes) -> None:
    body = bytes([Instruction.WRITE]) + params
    assert unstuff(stuff(body)) == body
    # stuffed body never carries a header-like FF FF FD 00
    assert b"\xff\xff\xfd\x00" not in stuff(body)
    pkt = build_packet(1, Instruction.WRITE, params)
    # the SDK's addStuffing over the same unstuffed packet must agree on bytes and LEN
    length = len(body) + 2
    plain = list(b"\xff\xff\xfd\x00" + bytes([1, length & 0xFF, length >> 8]) + body + b"\0\0")
    sdk = SDK.addStuffing(plain)
    assert bytes(sdk[:-2]) == pkt[:-2]
    assert parse_packet(pkt).params == params
    # (The SDK's removeStuffing is not a reference: on FF FF FD FF FD FD it also drops the FD
    # of the second, unstuffed FF FD — the SDK only ever unstuffs status packets it parsed.)


def test_stuffing_of_value_with_header_bytes() -> None:
    pkt = build_status(1, 0, bytes.fromhex("FF FF FD FF"))
    assert b"\xff\xff\xfd\xfd\xff" in pkt
    assert pkt[5] == 9  # LEN grew by one
    assert parse_packet(pkt).params == bytes.fromhex("00 FF FF FD FF")
    assert build_status(1, 0, bytes.fromhex("FF FF FD FF"), stuffing=False)[5] == 8


def test_fast_sync_read_vector() -> None:
    # e-manual Fast Sync Read example: ids 3, 7, 4 reading Present Position 166, 2079, 1023
    blocks = [(0, 3, (166).to_bytes(4, "little")), (0, 7, (2079).to_bytes(4, "little")),
              (0, 4, (1023).to_bytes(4, "little"))]
    raw = build_fast_status(blocks)
    assert raw[:8] == bytes.fromhex("FF FF FD 00 FE 19 00 55")
    crcs = [raw[8 + 8 * k + 6: 8 + 8 * k + 8] for k in range(3)]
    assert crcs == [bytes.fromhex(c) for c in ("84 08", "16 CA", "D1 9E")]
    # the final block CRC is the packet CRC: the SDK's rxPacket check accepts it
    assert crc16(raw[:-2]) == raw[-2] | raw[-1] << 8
    assert [b[:3] for b in parse_fast_status(raw, [4, 4, 4])] == blocks
    assert all(b[3] for b in parse_fast_status(raw, [4, 4, 4]))


def test_fast_bulk_read_vector() -> None:
    blocks = [(0, 3, (166).to_bytes(4, "little")), (0, 7, (421).to_bytes(2, "little")),
              (0, 4, bytes([31]))]
    raw = build_fast_status(blocks)
    assert raw[5] == fast_status_length([4, 2, 1]) == 0x14
    assert raw[14:16] == bytes.fromhex("67 A4")
    assert raw[20:22] == bytes.fromhex("24 74")
    assert raw[25:27] == bytes.fromhex("D9 C1")


def test_fast_status_is_never_stuffed() -> None:
    data = bytes.fromhex("FF FF FD 00")
    raw = build_fast_status([(0, 1, data)])
    assert data in raw and raw[5] == fast_status_length([4])


def test_fast_writer_blockwise_equals_whole() -> None:
    blocks = [(0, 1, b"\x01\x02"), (0x80, 2, b"\x03\x04")]
    w = FastStatusWriter(fast_status_length([2, 2]))
    assert w.header + b"".join(w.block(*b) for b in blocks) == build_fast_status(blocks)


def test_parse_packet_rejects_bad_input() -> None:
    good = build_packet(1, Instruction.PING)
    with pytest.raises(ProtocolError, match="CRC"):
        parse_packet(good[:-1] + bytes([good[-1] ^ 1]))
    with pytest.raises(ProtocolError, match="LEN"):
        parse_packet(good + b"\x00")
    with pytest.raises(ProtocolError):
        parse_packet(b"\x00" + good[1:])


def test_instruction_names() -> None:
    assert instruction_name(0x8A) == "FAST_SYNC_READ"
    assert instruction_name(0x77) == "0x77"


def _stream(packets: list[bytes]) -> bytes:
    return b"".join(packets)


@given(st.lists(st.tuples(st.integers(0, 252), st.sampled_from(list(Instruction)), payload),
                min_size=1, max_size=5),
       st.binary(max_size=20).filter(lambda b: b"\xff" not in b),
       st.integers(1, 7))
def test_parser_recovers_packets_from_any_chunking(specs, junk: bytes, chunk: int) -> None:
    pkts = [build_packet(i, inst, p) for i, inst, p in specs]
    stream = junk + _stream(pkts)
    parser = PacketParser()
    got = []
    for k in range(0, len(stream), chunk):
        got += parser.feed(stream[k:k + chunk], now=0.0)
    assert [(p.id, p.instruction, p.params) for p in got] == [(i, int(n), p) for i, n, p in specs]
    assert all(p.crc_ok for p in got)


def test_parser_ignores_stuffed_fd_as_header() -> None:
    # a packet whose params contain FF FF FD: the stuffed FF FF FD FD must not restart the hunt
    pkt = build_packet(5, Instruction.WRITE, bytes.fromhex("14 00 FF FF FD FF"))
    parser = PacketParser()
    (p,) = parser.feed(pkt[9:] + pkt, now=0.0)   # garbage tail first, containing FF FF FD FD
    assert p.params == bytes.fromhex("14 00 FF FF FD FF")


def test_parser_flags_crc_error() -> None:
    pkt = bytearray(build_packet(3, Instruction.READ, bytes.fromhex("84 00 04 00")))
    pkt[-1] ^= 0x55
    (p,) = PacketParser().feed(bytes(pkt), now=0.0)
    assert not p.crc_ok and p.id == 3 and p.instruction == Instruction.READ


def test_parser_drops_partial_after_gap() -> None:
    pkt = build_packet(1, Instruction.PING)
    parser = PacketParser()
    assert parser.feed(pkt[:5], now=1.0) == []
    # 2 ms later the rest arrives: the partial is dropped, nothing completes
    assert parser.feed(pkt[5:], now=1.002) == []
    assert parser.dropped_partial == 1
    # within 1.5 ms the two halves join
    assert parser.feed(pkt[:5], now=2.0) == []
    (p,) = parser.feed(pkt[5:], now=2.001)
    assert p.instruction == Instruction.PING and p.time == 2.0
    # a fresh packet after a long silence is fine
    (q,) = parser.feed(build_packet(BROADCAST_ID, Instruction.PING), now=10.0)
    assert q.id == BROADCAST_ID


def test_parser_skips_bad_len() -> None:
    bogus = b"\xff\xff\xfd\x00\x01\xff\xff"      # LEN 65535: larger than any packet
    pkt = build_packet(2, Instruction.PING)
    (p,) = PacketParser().feed(bogus + pkt, now=0.0)
    assert p.id == 2
