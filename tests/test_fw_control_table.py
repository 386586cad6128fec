"""firmware_sim control table: item metadata and the write/read rules of Servo.

Everything here runs on a Servo with a VirtualClock (no pty). Expected values come from
the e-manual tables (dynamixel-notes.md §2) or from the item metadata itself.
"""

from __future__ import annotations

import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

from firmware_sim import control_table as ct
from firmware_sim.clock import VirtualClock
from firmware_sim.control_table import (
    ALERT_BIT,
    ERR_ACCESS,
    ERR_DATA_LENGTH,
    ERR_DATA_LIMIT,
    ERR_DATA_RANGE,
    MODELS,
    TABLE_SIZE,
    ControlTable,
    Item,
)
from firmware_sim.servo import Servo

MODEL_NAMES = sorted(MODELS)


def make(model: str = "xm430-w350", **kw) -> tuple[Servo, VirtualClock]:
    clock = VirtualClock()
    return Servo(1, model, clock=clock, **kw), clock


def enc(item: Item, value: int) -> bytes:
    return value.to_bytes(item.size, "little", signed=item.signed)


def value_of(servo: Servo, address: int) -> int:
    it = servo.spec.item(address)
    code, raw = servo.read(address, it.size)
    assert code == 0
    return it.decode(raw)


def write_item(servo: Servo, address: int, value: int) -> int:
    return servo.write(address, enc(servo.spec.item(address), value))


# ---- metadata ---------------------------------------------------------------------------
def test_model_numbers_and_names():
    assert MODELS["xm430-w350"].model_number == 1020
    assert MODELS["xl430-w250"].model_number == 1060
    for name in MODEL_NAMES:
        s, _ = make(name, firmware=44)
        assert s.model_number == MODELS[name].model_number == value_of(s, ct.MODEL_NUMBER)
        assert s.firmware_version == 44 == value_of(s, ct.FIRMWARE_VERSION)
        s.firmware_version = 46
        assert value_of(s, ct.FIRMWARE_VERSION) == 46


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_item_metadata_is_consistent(name):
    spec = MODELS[name]
    seen: set[int] = set()
    for address, it in spec.items.items():
        assert address == it.address and it.size in (1, 2, 4)
        assert it.eeprom == (address < ct.EEPROM_END)
        assert it.access in ("R", "RW")
        assert not seen & set(it.addresses), f"{it.name} overlaps"
        seen |= set(it.addresses)
        assert all(spec.owner(a) is it for a in it.addresses)
        if it.writable:
            assert it.in_range(it.default), f"{it.name} default {it.default} out of range"
    assert max(seen) == TABLE_SIZE - 1
    # undefined addresses really are gaps
    assert spec.owner(14) is None and spec.owner(99) is None and spec.owner(300) is None


def test_model_differences_follow_the_emanual():
    xm, xl = MODELS["xm430-w350"], MODELS["xl430-w250"]
    assert (xm.item(ct.VELOCITY_LIMIT).default, xl.item(ct.VELOCITY_LIMIT).default) == (200, 265)
    assert ct.GOAL_CURRENT in xm.items and ct.GOAL_CURRENT not in xl.items
    assert ct.CURRENT_LIMIT in xm.items and ct.CURRENT_LIMIT not in xl.items
    assert {0, 5} <= xm.operating_modes and not {0, 5} & xl.operating_modes
    assert {1, 3, 4, 16} <= xl.operating_modes


def test_indirect_banks():
    for name in MODEL_NAMES:
        spec = MODELS[name]
        for addr_base, data_base, count in ct.INDIRECT_BANKS:
            for k in range(count):
                a = spec.item(addr_base + 2 * k)
                assert (a.size, a.access, a.default) == (2, "RW", data_base + k)
                d = spec.item(data_base + k)
                assert (d.size, d.access) == (1, "RW")
                assert ct.indirect_data_slot(data_base + k) == addr_base + 2 * k
    assert ct.indirect_data_slot(223) is None and ct.indirect_data_slot(662) is None
    assert ct.indirect_data_slot(224) == 168 and ct.indirect_data_slot(634) == 578


def test_baud_rates_cover_items_range():
    item = MODELS["xm430-w350"].item(ct.BAUD_RATE)
    assert sorted(ct.BAUD_RATES) == list(range(item.min, item.max + 1))
    assert ct.BAUD_RATES[1] == 57_600 and ct.BAUD_RATES[3] == 1_000_000


@given(st.sampled_from(MODEL_NAMES), st.data())
def test_table_typed_round_trip(name, data):
    table = ControlTable(MODELS[name])
    it = data.draw(st.sampled_from(list(MODELS[name].items.values())))
    bits = 8 * it.size
    lo, hi = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if it.signed else (0, (1 << bits) - 1)
    v = data.draw(st.integers(lo, hi))
    table.set(it.address, v)
    assert table.get(it.address) == v
    assert table.raw(it.address, it.size) == v.to_bytes(it.size, "little", signed=it.signed)


# ---- write-then-read round trip of any RW item --------------------------------------------
def _in_range_values(servo: Servo, it: Item) -> st.SearchStrategy[int]:
    t = servo.table
    if it.allowed is not None:
        return st.sampled_from(sorted(it.allowed))
    lo, hi = it.min, it.max
    limit = {"pwm": ct.PWM_LIMIT, "current": ct.CURRENT_LIMIT, "velocity": ct.VELOCITY_LIMIT}
    if it.limit in limit:
        bound = t.get(limit[it.limit])
        lo, hi = -bound, bound
    elif it.limit == "position":
        lo, hi = t.get(ct.MIN_POSITION_LIMIT), t.get(ct.MAX_POSITION_LIMIT)
    elif it.address == ct.TORQUE_ENABLE:
        hi = 0              # torque on changes Goal Position; covered elsewhere
    return st.integers(lo, hi)


@settings(max_examples=300)
@given(st.sampled_from(MODEL_NAMES), st.data())
def test_write_then_read_round_trip_any_rw_item(name, data):
    servo, clock = make(name)
    writable = [it for it in servo.spec.items.values() if it.writable]
    it = data.draw(st.sampled_from(writable))
    value = data.draw(_in_range_values(servo, it))
    before = bytes(servo.table.data)
    assert write_item(servo, it.address, value) == 0
    assert value_of(servo, it.address) == value
    if it.address not in (ct.OPERATING_MODE, ct.GOAL_POSITION, ct.GOAL_VELOCITY,
                          ct.HOMING_OFFSET, ct.DRIVE_MODE):
        # no side effects: only the item's own bytes changed (live items aside)
        clock.advance(0)
        servo.update()
        after = bytes(servo.table.data)
        live = set(range(ct.REALTIME_TICK, ct.BACKUP_READY + 1))
        changed = {a for a in range(TABLE_SIZE) if before[a] != after[a]} - live
        assert changed <= set(it.addresses)


# ---- error codes --------------------------------------------------------------------------
@pytest.mark.parametrize("name", MODEL_NAMES)
def test_read_only_and_undefined_addresses_are_access_errors(name):
    servo, _ = make(name)
    before = bytes(servo.table.data)
    for it in servo.spec.items.values():
        if not it.writable:
            assert servo.write(it.address, bytes(it.size)) == ERR_ACCESS, it.name
    for a in range(TABLE_SIZE):
        if servo.spec.owner(a) is None:
            assert servo.write(a, b"\x00") == ERR_ACCESS, a
    assert servo.write(TABLE_SIZE, b"\x00") == ERR_ACCESS
    assert servo.write(TABLE_SIZE - 1, b"\x00\x00") == ERR_ACCESS
    # a write that starts on a good item but runs into a gap fails as a whole
    assert servo.write(ct.PROTOCOL_TYPE, b"\x02\x00") == ERR_ACCESS
    assert servo.table.data[:ct.REALTIME_TICK] == before[:ct.REALTIME_TICK]


def test_reads():
    servo, _ = make()
    assert servo.read(TABLE_SIZE - 1, 1)[0] == 0
    assert servo.read(TABLE_SIZE - 1, 2) == (ERR_ACCESS, b"")
    assert servo.read(5000, 4) == (ERR_ACCESS, b"")
    assert servo.read(0, 0) == (ERR_DATA_LENGTH, b"")
    assert servo.read(14, 1) == (ERR_ACCESS, b"")          # starts on an undefined address
    assert servo.read(99, 4) == (ERR_ACCESS, b"")
    # a gap reads as zeros inside a longer read, and a partial read of an item is allowed
    code, raw = servo.read(ct.PROTOCOL_TYPE, ct.HOMING_OFFSET - ct.PROTOCOL_TYPE + 4)
    assert code == 0 and raw[1:7] == bytes(6)
    assert servo.read(ct.PRESENT_POSITION, 2) == (0, (2048).to_bytes(2, "little"))


def test_xl_has_no_current_items():
    servo, _ = make("xl430-w250")
    assert servo.write(ct.GOAL_CURRENT, b"\x00\x00") == ERR_ACCESS
    assert servo.write(ct.CURRENT_LIMIT, b"\x00\x00") == ERR_ACCESS
    assert write_item(servo, ct.OPERATING_MODE, ct.MODE_CURRENT) == ERR_DATA_RANGE
    assert write_item(servo, ct.OPERATING_MODE, ct.MODE_CURRENT_POSITION) == ERR_DATA_RANGE


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_out_of_range_values_are_range_errors(name):
    servo, _ = make(name)
    checked = 0
    for it in servo.spec.items.values():
        if not it.writable:
            continue
        bits = 8 * it.size
        lo = -(1 << (bits - 1)) if it.signed else 0
        hi = (1 << (bits - 1)) - 1 if it.signed else (1 << bits) - 1
        bad = [v for v in (it.min - 1, it.max + 1, lo, hi) if lo <= v <= hi and not it.in_range(v)]
        for v in bad:
            before = servo.table.get(it.address)
            assert write_item(servo, it.address, v) == ERR_DATA_RANGE, (it.name, v)
            assert servo.table.get(it.address) == before
            checked += 1
    assert checked > 50
    assert write_item(servo, ct.OPERATING_MODE, 2) == ERR_DATA_RANGE
    assert write_item(servo, ct.DRIVE_MODE, 2) == ERR_DATA_RANGE


def test_partial_item_writes_are_length_errors():
    servo, _ = make()
    before = servo.table.get(ct.PROFILE_VELOCITY)
    assert servo.write(ct.PROFILE_VELOCITY, b"\x10\x00") == ERR_DATA_LENGTH
    assert servo.write(ct.PROFILE_VELOCITY + 1, b"\x10") == ERR_DATA_LENGTH
    # a whole item followed by half of the next one
    assert servo.write(ct.PROFILE_ACCELERATION, bytes(6)) == ERR_DATA_LENGTH
    assert servo.write(ct.PROFILE_VELOCITY, b"") == ERR_DATA_LENGTH
    assert servo.table.get(ct.PROFILE_VELOCITY) == before


def test_eeprom_locked_while_torque_on():
    servo, _ = make()
    eeprom = [it for it in servo.spec.items.values() if it.writable and it.eeprom]
    assert write_item(servo, ct.TORQUE_ENABLE, 1) == 0
    for it in eeprom:
        assert write_item(servo, it.address, it.default) == ERR_ACCESS, it.name
    assert write_item(servo, ct.RETURN_DELAY_TIME, 0) == ERR_ACCESS
    assert servo.return_delay_us == 500
    # RAM stays writable
    assert write_item(servo, ct.LED, 1) == 0
    assert write_item(servo, ct.TORQUE_ENABLE, 0) == 0
    assert write_item(servo, ct.RETURN_DELAY_TIME, 0) == 0
    assert servo.return_delay_us == 0
    for it in eeprom:
        assert write_item(servo, it.address, it.default) == 0, it.name


def test_goal_position_limit_in_position_mode_only():
    servo, clock = make()
    for address, value in ((ct.MIN_POSITION_LIMIT, 1000), (ct.MAX_POSITION_LIMIT, 3000)):
        assert write_item(servo, address, value) == 0
    assert write_item(servo, ct.TORQUE_ENABLE, 1) == 0
    for goal in (999, 3001, 4095, -5):
        assert write_item(servo, ct.GOAL_POSITION, goal) == ERR_DATA_LIMIT
        clock.advance(0.5)
        assert servo.goal_position == 2048 and servo.present_position == 2048
        assert not servo.moving
    assert write_item(servo, ct.GOAL_POSITION, 3000) == 0
    clock.advance(0.5)
    assert servo.present_position == 3000
    # extended position mode ignores the limits (and its range is ±1 048 575)
    assert write_item(servo, ct.TORQUE_ENABLE, 0) == 0
    assert write_item(servo, ct.OPERATING_MODE, ct.MODE_EXTENDED_POSITION) == 0
    assert write_item(servo, ct.TORQUE_ENABLE, 1) == 0
    assert write_item(servo, ct.GOAL_POSITION, 9000) == 0
    clock.advance(0.5)
    assert servo.present_position == 9000
    assert write_item(servo, ct.GOAL_POSITION, ct.EXTENDED_POSITION_RANGE + 1) == ERR_DATA_RANGE


def test_goal_pwm_current_velocity_limits():
    servo, _ = make()
    for limit_addr, goal_addr, limit in ((ct.PWM_LIMIT, ct.GOAL_PWM, 300),
                                         (ct.CURRENT_LIMIT, ct.GOAL_CURRENT, 500),
                                         (ct.VELOCITY_LIMIT, ct.GOAL_VELOCITY, 100)):
        assert write_item(servo, limit_addr, limit) == 0
        assert write_item(servo, goal_addr, limit) == 0
        assert write_item(servo, goal_addr, -limit) == 0
        assert write_item(servo, goal_addr, limit + 1) == ERR_DATA_LIMIT
        assert write_item(servo, goal_addr, -limit - 1) == ERR_DATA_LIMIT
        assert servo.table.get(goal_addr) == -limit


def test_multi_item_writes_are_all_or_nothing():
    servo, _ = make()
    acc, vel = servo.spec.item(ct.PROFILE_ACCELERATION), servo.spec.item(ct.PROFILE_VELOCITY)
    good = enc(acc, 10) + enc(vel, 20)
    bad = enc(acc, 10) + enc(vel, 40000)
    assert servo.write(ct.PROFILE_ACCELERATION, bad) == ERR_DATA_RANGE
    assert (servo.table.get(ct.PROFILE_ACCELERATION), servo.table.get(ct.PROFILE_VELOCITY)) \
        == (0, 0)
    assert servo.write(ct.PROFILE_ACCELERATION, good) == 0
    assert (servo.table.get(ct.PROFILE_ACCELERATION), servo.table.get(ct.PROFILE_VELOCITY)) \
        == (10, 20)


_ADDRESSES = st.one_of(st.integers(0, TABLE_SIZE - 1),
                       st.sampled_from([it.address for it in MODELS["xm430-w350"].items.values()
                                        if it.writable]))


@settings(max_examples=500)
@given(st.lists(st.integers(0, 255), min_size=1, max_size=40), _ADDRESSES)
def test_writes_are_all_or_nothing_for_any_bytes(raw, address):
    servo, _ = make()
    event("accepted" if servo.write(address, bytes(raw)) == 0 else "refused")
    servo, _ = make()
    before = bytes(servo.table.data)
    code = servo.write(address, bytes(raw))
    if code:
        servo.update()
        after = bytes(servo.table.data)
        live = set(range(ct.REALTIME_TICK, ct.BACKUP_READY + 1))
        assert all(before[a] == after[a] for a in range(TABLE_SIZE) if a not in live)
    else:
        # what was accepted reads back as written (byte-for-byte, through any indirection)
        assert servo.read(address, len(raw)) == (0, bytes(raw))


def test_status_error_alert_bit():
    servo, _ = make()
    assert [servo.status_error(c) for c in (0, ERR_DATA_RANGE)] == [0, ERR_DATA_RANGE]
    servo.trip(ct.HW_OVERLOAD)
    assert [servo.status_error(c) for c in (0, ERR_DATA_RANGE)] == \
        [ALERT_BIT, ALERT_BIT | ERR_DATA_RANGE]


# ---- indirect addressing ----------------------------------------------------------------
def _map(servo: Servo, first_slot: int, target: int, n: int) -> None:
    for k in range(n):
        assert write_item(servo, first_slot + 2 * k, target + k) == 0


@pytest.mark.parametrize("slot, data", [(168, 224), (578, 634), (168 + 2 * 24, 248),
                                        (578 + 2 * 24, 658)])
def test_indirect_data_mirrors_target_bytes(slot, data):
    servo, clock = make()
    _map(servo, slot, ct.PRESENT_POSITION, 4)
    _map(servo, ct.INDIRECT_ADDRESS_29 if slot < 578 else ct.INDIRECT_ADDRESS_1,
         ct.GOAL_POSITION, 4)
    goal_data = ct.INDIRECT_DATA_29 if slot < 578 else ct.INDIRECT_DATA_1
    assert write_item(servo, ct.PROFILE_VELOCITY, 50) == 0
    assert write_item(servo, ct.TORQUE_ENABLE, 1) == 0
    # a write through indirect data lands on the target item, with the item's rules
    assert servo.write(goal_data, (3000).to_bytes(4, "little")) == 0
    assert servo.goal_position == 3000
    seen = set()
    for _ in range(5):
        clock.advance(0.2)
        code, raw = servo.read(data, 4)
        assert code == 0 and raw == servo.read(ct.PRESENT_POSITION, 4)[1]
        seen.add(raw)
    assert len(seen) > 1                    # it really followed a moving value
    clock.advance(1.0)
    assert servo.read(data, 4) == (0, (3000).to_bytes(4, "little"))


def test_indirect_inherits_size_and_access():
    servo, _ = make()
    _map(servo, ct.INDIRECT_ADDRESS_29, ct.PROFILE_VELOCITY, 2)   # only half of a 4-byte item
    assert servo.write(ct.INDIRECT_DATA_29, b"\x05\x00") == ERR_DATA_LENGTH
    _map(servo, ct.INDIRECT_ADDRESS_29, ct.PROFILE_VELOCITY, 4)
    assert servo.write(ct.INDIRECT_DATA_29, (40000).to_bytes(4, "little")) == ERR_DATA_RANGE
    assert servo.write(ct.INDIRECT_DATA_29, (77).to_bytes(4, "little")) == 0
    assert servo.table.get(ct.PROFILE_VELOCITY) == 77
    _map(servo, ct.INDIRECT_ADDRESS_1, ct.PRESENT_POSITION, 4)      # read-only target
    assert servo.write(ct.INDIRECT_DATA_1, bytes(4)) == ERR_ACCESS
    _map(servo, ct.INDIRECT_ADDRESS_1, 99, 1)                       # undefined target
    assert servo.write(ct.INDIRECT_DATA_1, b"\x00") == ERR_ACCESS
    assert servo.read(ct.INDIRECT_DATA_1, 1) == (0, b"\x00")
    # the address itself must point into 64..661
    for bad in (63, 662):
        assert write_item(servo, ct.INDIRECT_ADDRESS_1, bad) == ERR_DATA_RANGE


def test_indirect_scatter_gathers_several_items():
    servo, _ = make()
    # ros2_control style: LED, Moving, Present Position packed at Indirect Data 29..
    targets = [ct.LED, ct.MOVING, *range(ct.PRESENT_POSITION, ct.PRESENT_POSITION + 4)]
    for k, target in enumerate(targets):
        assert write_item(servo, ct.INDIRECT_ADDRESS_29 + 2 * k, target) == 0
    assert write_item(servo, ct.LED, 1) == 0
    code, raw = servo.read(ct.INDIRECT_DATA_29, len(targets))
    assert code == 0
    assert raw == bytes([1, servo.get(ct.MOVING)]) + servo.read(ct.PRESENT_POSITION, 4)[1]


def test_factory_mapping_is_plain_storage():
    servo, _ = make()
    assert servo.write(ct.INDIRECT_DATA_1, b"\xab\xcd") == 0
    assert servo.read(ct.INDIRECT_DATA_1, 2) == (0, b"\xab\xcd")


def test_operating_mode_change_resets_profile():
    servo, _ = make()
    assert write_item(servo, ct.PROFILE_VELOCITY, 100) == 0
    assert write_item(servo, ct.PROFILE_ACCELERATION, 10) == 0
    assert write_item(servo, ct.PWM_LIMIT, 500) == 0
    assert write_item(servo, ct.GOAL_PWM, 100) == 0
    assert write_item(servo, ct.OPERATING_MODE, ct.MODE_POSITION) == 0      # unchanged: kept
    assert servo.table.get(ct.PROFILE_VELOCITY) == 100
    assert write_item(servo, ct.OPERATING_MODE, ct.MODE_EXTENDED_POSITION) == 0
    assert servo.table.get(ct.PROFILE_VELOCITY) == 0
    assert servo.table.get(ct.PROFILE_ACCELERATION) == 0
    assert servo.table.get(ct.GOAL_PWM) == 500
