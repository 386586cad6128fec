"""firmware_sim Servo: Bus Watchdog, hardware errors, registered writes and the
maintenance instructions (REBOOT, FACTORY_RESET, CLEAR, CONTROL_TABLE_BACKUP), with a
VirtualClock and no pty (e-manual rules as in dynamixel-notes.md §1.4 and §2)."""

from __future__ import annotations

import pytest
from fw_helpers import PERIOD, make, put, setup_move

from firmware_sim import control_table as ct
from firmware_sim.clock import VirtualClock
from firmware_sim.control_table import (
    ALERT_BIT,
    ERR_ACCESS,
    ERR_DATA_LENGTH,
    ERR_DATA_RANGE,
    ERR_INSTRUCTION,
    ERR_RESULT_FAIL,
)
from firmware_sim.servo import BACKUP_MAGIC, CLEAR_MULTI_TURN, Servo


# ---- bus watchdog -----------------------------------------------------------------------
def test_bus_watchdog_trips_and_recovers():
    servo, clock = make()
    setup_move(servo, 100, 10)
    put(servo, ct.BUS_WATCHDOG, 5)                   # 100 ms
    t0 = clock.now()
    put(servo, ct.GOAL_POSITION, 3500)
    for _ in range(10):                              # fed every 60 ms: keeps running
        clock.advance(0.06)
        servo.note_instruction()
    assert servo.get(ct.BUS_WATCHDOG) == 5 and servo.moving
    deadline = clock.now() + 0.1
    clock.advance(0.5)
    assert servo.read(ct.BUS_WATCHDOG, 1) == (0, b"\xff")    # -1
    stopped = servo.present_position
    assert not servo.moving and 2048 < stopped < 3500
    # it stopped where the same move was at the deadline, not at the time of the read
    ref, ref_clock = make()
    setup_move(ref, 100, 10)
    ref_t0 = ref_clock.now()
    put(ref, ct.GOAL_POSITION, 3500)
    ref_clock.set(ref_t0 + (deadline - t0))
    assert ref.present_position == stopped
    for address, size in ((ct.GOAL_POSITION, 4), (ct.GOAL_VELOCITY, 4), (ct.GOAL_PWM, 2),
                          (ct.GOAL_CURRENT, 2)):
        assert servo.write(address, bytes(size)) == ERR_DATA_RANGE
    assert servo.write(ct.BUS_WATCHDOG, b"\x05") == ERR_DATA_RANGE
    # e-manual: the stop sets both profile items to 0
    assert servo.get(ct.PROFILE_VELOCITY) == servo.get(ct.PROFILE_ACCELERATION) == 0
    clock.advance(1.0)
    assert servo.present_position == stopped
    put(servo, ct.BUS_WATCHDOG, 0)
    put(servo, ct.GOAL_POSITION, 3500)             # step now: the profile was zeroed
    clock.advance(PERIOD)
    assert servo.present_position == 3500


def test_bus_watchdog_deadline_is_value_times_20ms():
    servo, clock = make()
    setup_move(servo, 0, 0)
    put(servo, ct.BUS_WATCHDOG, 10)
    servo.note_instruction()
    clock.advance(0.2 - PERIOD)
    assert servo.get(ct.BUS_WATCHDOG) == 10
    clock.advance(2 * PERIOD)
    assert servo.get(ct.BUS_WATCHDOG) == -1
    # with torque off the watchdog does not run
    servo2, clock2 = make()
    put(servo2, ct.BUS_WATCHDOG, 1)
    clock2.advance(1.0)
    assert servo2.get(ct.BUS_WATCHDOG) == 1


# ---- hardware errors --------------------------------------------------------------------
def test_trip_shutdown_and_reboot():
    servo, clock = make()
    setup_move(servo, 100, 10)
    put(servo, ct.LED, 1)
    put(servo, ct.GOAL_POSITION, 3500)
    clock.advance(0.5)
    servo.trip(ct.HW_OVERLOAD)                       # in Shutdown (0x34): torque off
    where = servo.present_position
    assert not servo.torque_enabled and servo.hardware_error == ct.HW_OVERLOAD
    assert servo.status_error(0) == ALERT_BIT
    clock.advance(2.0)
    assert servo.present_position == where
    assert servo.write(ct.TORQUE_ENABLE, b"\x01") == ERR_RESULT_FAIL
    assert servo.status_error(ERR_RESULT_FAIL) == ALERT_BIT | ERR_RESULT_FAIL
    clock.advance(10.0)
    assert servo.hardware_error == ct.HW_OVERLOAD    # nothing but a reboot clears it
    servo.reboot()
    assert servo.hardware_error == 0 and servo.status_error(0) == 0
    assert servo.get(ct.LED) == 0                    # RAM back to defaults
    put(servo, ct.TORQUE_ENABLE, 1)


def test_trip_outside_shutdown_keeps_torque():
    servo, _ = make()
    setup_move(servo, 0, 0)
    servo.trip(ct.HW_INPUT_VOLTAGE)                  # not in the default Shutdown 0x34
    assert servo.torque_enabled and servo.status_error(0) == ALERT_BIT
    put(servo, ct.GOAL_POSITION, 100)
    assert servo.present_position == 100
    with pytest.raises(ValueError, match="bits"):
        servo.trip(0)


# ---- reboot, factory reset ---------------------------------------------------------------
def test_reboot_keeps_eeprom_resets_ram_and_boots():
    servo, clock = make()
    put(servo, ct.RETURN_DELAY_TIME, 7)
    put(servo, ct.OPERATING_MODE, ct.MODE_EXTENDED_POSITION)
    put(servo, ct.PROFILE_VELOCITY, 300)
    put(servo, ct.TORQUE_ENABLE, 1)
    put(servo, ct.GOAL_POSITION, 2048 + 3 * 4096)
    clock.advance(10.0)
    assert servo.present_position == 2048 + 3 * 4096
    tick = servo.get(ct.REALTIME_TICK)
    servo.reboot()
    assert servo.booting()
    clock.advance(servo.boot_delay_s)
    assert not servo.booting()
    assert servo.return_delay_us == 14 and servo.get(ct.OPERATING_MODE) == 4
    assert servo.get(ct.PROFILE_VELOCITY) == 0 and not servo.torque_enabled
    assert servo.present_position == 2048            # multi-turn is lost on a reboot
    assert servo.get(ct.REALTIME_TICK) != tick


@pytest.mark.parametrize("option, keeps_id, keeps_baud", [(0xFF, False, False),
                                                          (0x01, True, False),
                                                          (0x02, True, True)])
@pytest.mark.parametrize("model", sorted(ct.MODELS))
def test_factory_reset_options(option, keeps_id, keeps_baud, model):
    clock = VirtualClock()
    servo = Servo(7, model, baud_index=4, clock=clock, firmware=45)
    put(servo, ct.RETURN_DELAY_TIME, 0)
    put(servo, ct.HOMING_OFFSET, 100)
    put(servo, ct.LED, 1)
    assert servo.factory_reset(option) == 0
    assert servo.id == (7 if keeps_id else 1)
    assert servo.baud_index == (4 if keeps_baud else 1)
    spec = servo.spec
    assert servo.return_delay_us == 2 * spec.item(ct.RETURN_DELAY_TIME).default
    assert servo.get(ct.HOMING_OFFSET) == 0 and servo.get(ct.LED) == 0
    assert servo.firmware_version == 45 and servo.model_number == spec.model_number
    assert servo.present_position == 2048 and servo.booting()


def test_factory_reset_bad_option_changes_nothing():
    servo, _ = make()
    put(servo, ct.RETURN_DELAY_TIME, 0)
    assert servo.factory_reset(0x03) == ERR_DATA_RANGE
    assert servo.return_delay_us == 0 and not servo.booting()


# ---- clear, backup, registered write -----------------------------------------------------
def test_clear_multi_turn():
    servo, clock = make()
    setup_move(servo, 200, 0, mode=ct.MODE_EXTENDED_POSITION)
    put(servo, ct.GOAL_POSITION, 2 * 4096 + 100)
    clock.advance(0.1)
    assert servo.moving
    assert servo.clear(CLEAR_MULTI_TURN) == ERR_RESULT_FAIL
    clock.advance(10.0)
    assert servo.present_position == 2 * 4096 + 100
    assert servo.clear(b"\x01DXL!") == ERR_DATA_RANGE
    assert servo.clear(b"\x01DXL") == ERR_DATA_LENGTH
    assert servo.clear(CLEAR_MULTI_TURN) == 0
    assert servo.present_position == 100 and servo.goal_position == 100
    clock.advance(1.0)
    assert servo.present_position == 100             # no drive back to the old turn


def test_control_table_backup_store_and_restore():
    servo, _ = make()
    put(servo, ct.RETURN_DELAY_TIME, 3)
    put(servo, ct.INDIRECT_ADDRESS_1, ct.LED)
    put(servo, ct.PROFILE_VELOCITY, 77)
    assert servo.backup(b"\x02" + BACKUP_MAGIC) == ERR_RESULT_FAIL      # nothing stored yet
    put(servo, ct.TORQUE_ENABLE, 1)
    assert servo.backup(b"\x01" + BACKUP_MAGIC) == ERR_RESULT_FAIL      # torque on
    put(servo, ct.TORQUE_ENABLE, 0)
    assert servo.get(ct.BACKUP_READY) == 0
    assert servo.backup(b"\x01" + BACKUP_MAGIC) == 0
    assert servo.get(ct.BACKUP_READY) == 1
    put(servo, ct.RETURN_DELAY_TIME, 200)
    put(servo, ct.INDIRECT_ADDRESS_1, ct.MOVING)
    put(servo, ct.PROFILE_VELOCITY, 5)
    assert servo.backup(b"\x03" + BACKUP_MAGIC) == ERR_DATA_RANGE
    assert servo.backup(b"\x02CTRX") == ERR_DATA_RANGE
    assert servo.backup(b"\x02CTR") == ERR_DATA_LENGTH
    assert servo.backup(b"\x02" + BACKUP_MAGIC) == 0
    assert servo.return_delay_us == 6
    assert servo.get(ct.INDIRECT_ADDRESS_1) == ct.LED
    assert servo.get(ct.PROFILE_VELOCITY) == 77
    assert servo.booting()


def test_reg_write_and_action():
    servo, _ = make()
    setup_move(servo, 0, 0)
    assert servo.action() == ERR_INSTRUCTION
    assert servo.reg_write(ct.GOAL_POSITION, (1000).to_bytes(4, "little")) == 0
    assert servo.get(ct.REGISTERED_INSTRUCTION) == 1
    assert servo.goal_position == 2048 and servo.present_position == 2048
    assert servo.action() == 0
    assert servo.goal_position == 1000 and servo.present_position == 1000
    assert servo.get(ct.REGISTERED_INSTRUCTION) == 0
    assert servo.action() == ERR_INSTRUCTION
    # a registered write is checked like a write, and a bad one is not registered
    assert servo.reg_write(ct.GOAL_POSITION, b"\x00\x00") == ERR_DATA_LENGTH
    assert servo.reg_write(ct.RETURN_DELAY_TIME, b"\x00") == ERR_ACCESS       # torque on
    assert servo.get(ct.REGISTERED_INSTRUCTION) == 0


# ---- one-turn resets, startup configuration, firmware gates ------------------------------
def test_present_position_resets_to_one_turn_per_emanual():
    servo, _ = make()
    setup_move(servo, 0, 0, mode=ct.MODE_EXTENDED_POSITION)
    put(servo, ct.GOAL_POSITION, 3 * 4096 + 500)
    assert servo.present_position == 3 * 4096 + 500
    put(servo, ct.TORQUE_ENABLE, 0)
    put(servo, ct.HOMING_OFFSET, 10)
    assert servo.present_position == 3 * 4096 + 510            # torque off: continuous range
    put(servo, ct.TORQUE_ENABLE, 1)                            # mode 4: torque-on keeps turns
    assert servo.present_position == 3 * 4096 + 510
    put(servo, ct.TORQUE_ENABLE, 0)
    put(servo, ct.OPERATING_MODE, ct.MODE_POSITION)            # entering mode 3: one turn
    assert servo.present_position == 510
    servo2, _ = make()
    setup_move(servo2, 0, 0, mode=ct.MODE_EXTENDED_POSITION)
    put(servo2, ct.GOAL_POSITION, -2 * 4096 + 7)
    put(servo2, ct.TORQUE_ENABLE, 0)
    put(servo2, ct.OPERATING_MODE, ct.MODE_VELOCITY)
    assert servo2.present_position == -2 * 4096 + 7            # not on leaving position modes
    put(servo2, ct.OPERATING_MODE, ct.MODE_POSITION)
    assert servo2.present_position == 7


def test_startup_configuration_torque_on_and_ram_restore():
    servo, _ = make()
    put(servo, ct.PROFILE_VELOCITY, 33)
    assert servo.backup(b"\x01" + BACKUP_MAGIC) == 0
    put(servo, ct.STARTUP_CONFIGURATION, 0x03)
    put(servo, ct.PROFILE_VELOCITY, 44)
    servo.reboot()
    assert servo.torque_enabled and servo.goal_position == servo.present_position
    assert servo.get(ct.PROFILE_VELOCITY) == 33                # RAM restored from the backup
    put(servo, ct.TORQUE_ENABLE, 0)
    put(servo, ct.STARTUP_CONFIGURATION, 0)
    servo.reboot()
    assert not servo.torque_enabled and servo.get(ct.PROFILE_VELOCITY) == 0


def test_backup_needs_firmware_45():
    servo, _ = make(firmware=44)
    assert servo.backup(b"\x01" + BACKUP_MAGIC) == ERR_INSTRUCTION
    servo.firmware_version = 45
    assert servo.backup(b"\x01" + BACKUP_MAGIC) == 0


def test_moving_follows_threshold_and_watchdog_stops_velocity_mode():
    servo, clock = make()
    setup_move(servo, 0, 0, mode=ct.MODE_VELOCITY)
    threshold = servo.get(ct.MOVING_THRESHOLD)
    put(servo, ct.GOAL_VELOCITY, threshold)           # no ramp (A = 0), at the threshold
    clock.advance(0.5)
    assert servo.present_velocity == threshold and not servo.moving
    put(servo, ct.GOAL_VELOCITY, threshold + 1)
    clock.advance(0.5)
    assert servo.moving
    # e-manual Bus Watchdog example: velocity mode spinning, then the bus goes quiet
    put(servo, ct.BUS_WATCHDOG, 3)
    servo.note_instruction()
    clock.advance(0.059)
    assert servo.get(ct.BUS_WATCHDOG) == 3 and servo.moving
    clock.advance(0.002)
    p = servo.present_position
    assert servo.get(ct.BUS_WATCHDOG) == -1 and servo.present_velocity == 0
    assert not servo.moving
    assert servo.write(ct.GOAL_VELOCITY, (50).to_bytes(4, "little")) == ERR_DATA_RANGE
    clock.advance(1.0)
    assert servo.present_position == p
    put(servo, ct.BUS_WATCHDOG, 0)
    put(servo, ct.GOAL_VELOCITY, 50)
    clock.advance(1.0)
    assert servo.present_velocity == 50 and servo.present_position > p
