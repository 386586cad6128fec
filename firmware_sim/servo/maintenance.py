"""REBOOT, FACTORY_RESET, CLEAR and CONTROL_TABLE_BACKUP (Protocol 2.0 instructions 0x08,
0x06, 0x10, 0x20; e-manual protocol2 and dynamixel-notes.md §1.4).

A reboot turns the torque off, resets RAM (64+) to defaults, clears the hardware error,
loses the multi-turn count (the absolute encoder reports one revolution) and ignores the
bus for the boot delay; Startup Configuration (60, fw ≥ 45) may restore the RAM backup
and turn the torque on.
"""

from __future__ import annotations

from firmware_sim import control_table as ct
from firmware_sim.control_table import (
    ERR_DATA_LENGTH,
    ERR_DATA_RANGE,
    ERR_INSTRUCTION,
    ERR_RESULT_FAIL,
)
from firmware_sim.servo.effects import reset_goals, torque_on
from firmware_sim.servo.live import refresh
from firmware_sim.servo.motion import PULSES_PER_REV
from firmware_sim.servo.state import ServoState
from firmware_sim.servo.words import round_half_up

#: Parameters of CLEAR (0x10) for a multi-turn clear: 0x01 'D' 'X' 'L' '"'.
CLEAR_MULTI_TURN = b"\x01DXL\x22"
#: Magic of CONTROL_TABLE_BACKUP (0x20) after the option byte: 'C' 'T' 'R' 'L'.
BACKUP_MAGIC = b"CTRL"
BACKUP_STORE = 0x01
BACKUP_RESTORE = 0x02
#: FACTORY_RESET options: reset all / all but ID / all but ID and Baud Rate.
RESET_ALL, RESET_KEEP_ID, RESET_KEEP_ID_BAUD = 0xFF, 0x01, 0x02
#: Startup Configuration (60) bits (fw >= 45).
STARTUP_TORQUE_ON = 0x01
STARTUP_RAM_RESTORE = 0x02
#: First firmware with CONTROL_TABLE_BACKUP on the X430 (e-manual: Backup Ready from V45).
BACKUP_MIN_FIRMWARE = 45


def _ram_part(saved: dict[int, bytes]) -> dict[int, bytes]:
    return {a: raw for a, raw in saved.items() if a >= ct.EEPROM_END}


def reboot(st: ServoState, now: float) -> None:
    """REBOOT at ``now`` (module notes)."""
    motion = st.motion
    actual = motion.actual_now(now) % PULSES_PER_REV
    st.table.reset(lambda it: not it.eeprom)
    st.registered = None
    st.watchdog.restart(now)
    motion.set_actual(now, actual)
    reset_goals(st)
    st.boot_time = now
    st.boot_until = now + st.boot_delay_s
    startup = st.table.get(ct.STARTUP_CONFIGURATION)
    if startup & STARTUP_RAM_RESTORE and st.backup is not None:
        st.table.restore(_ram_part(st.backup))
        st.table.set(ct.GOAL_POSITION, round_half_up(motion.profile.state(now)[0]))
    if startup & STARTUP_TORQUE_ON:
        st.table.set(ct.TORQUE_ENABLE, 1)
        torque_on(st, now, keep_goal=False)
    refresh(st, now)


def factory_reset(st: ServoState, option: int) -> int:
    """FACTORY_RESET: 0xFF all items, 0x01 all but ID, 0x02 all but ID and Baud Rate;
    then reboot. Another option is a Data Range Error and changes nothing."""
    if option not in (RESET_ALL, RESET_KEEP_ID, RESET_KEEP_ID_BAUD):
        return ERR_DATA_RANGE
    now = st.clock.now()
    actual = st.motion.actual_now(now)
    keep = {ct.MODEL_NUMBER, ct.FIRMWARE_VERSION}
    if option in (RESET_KEEP_ID, RESET_KEEP_ID_BAUD):
        keep.add(ct.ID)
    if option == RESET_KEEP_ID_BAUD:
        keep.add(ct.BAUD_RATE)
    st.table.reset(lambda it: it.address not in keep)
    st.table.set(ct.FIRMWARE_VERSION, st.firmware)
    st.motion.set_actual(now, actual)
    reboot(st, now)
    return 0


def clear(st: ServoState, params: bytes) -> int:
    """CLEAR multi-turn (params 0x01 'D' 'X' 'L' '"'): Present Position back into one
    revolution of the actual position. Result Fail while moving."""
    if len(params) != len(CLEAR_MULTI_TURN):
        return ERR_DATA_LENGTH
    if params != CLEAR_MULTI_TURN:
        return ERR_DATA_RANGE
    now = st.clock.now()
    motion = st.motion
    if st.table.get(ct.MOVING) or motion.profile.ongoing(now):
        return ERR_RESULT_FAIL
    actual = motion.actual_now(now) % PULSES_PER_REV
    motion.set_actual(now, actual)
    if st.table.get(ct.TORQUE_ENABLE):
        st.table.set(ct.GOAL_POSITION, round_half_up(motion.present(actual)))
    refresh(st, now)
    return 0


def backup(st: ServoState, params: bytes) -> int:
    """CONTROL_TABLE_BACKUP: 0x01 'C' 'T' 'R' 'L' stores every writable item, 0x02 ...
    restores them after a reboot. Result Fail while torque is on or with no backup;
    Instruction Error below firmware 45 (no such instruction there)."""
    if st.firmware < BACKUP_MIN_FIRMWARE:
        return ERR_INSTRUCTION
    if len(params) != 1 + len(BACKUP_MAGIC):
        return ERR_DATA_LENGTH
    if params[1:] != BACKUP_MAGIC or params[0] not in (BACKUP_STORE, BACKUP_RESTORE):
        return ERR_DATA_RANGE
    if st.table.get(ct.TORQUE_ENABLE):
        return ERR_RESULT_FAIL
    now = st.clock.now()
    saved_items = [it for it in st.spec.items.values()
                   if it.writable and it.address != ct.TORQUE_ENABLE]
    if params[0] == BACKUP_STORE:
        st.backup = st.table.snapshot(saved_items)
        refresh(st, now)
        return 0
    if st.backup is None:
        return ERR_RESULT_FAIL
    actual = st.motion.actual_now(now)
    st.table.restore(st.backup)
    st.motion.set_actual(now, actual)
    reboot(st, now)
    st.table.restore(_ram_part(st.backup))
    refresh(st, now)
    return 0
