"""X-series control table (Protocol 2.0): addresses, baud and error codes.

The servo models' facts (model numbers, modes, units) are :mod:`robodcn.servo_models`'s
records; the tables here that name models are derived from them.

Addresses and units follow the ROBOTIS e-manual for the XM430-W350 / XL430-W250
(``/work/shared/dynamixel-notes.md`` §2).
"""

from __future__ import annotations

from robodcn.servo_models import (
    OPERATING_MODE_CURRENT,
    OPERATING_MODE_CURRENT_POSITION,
    OPERATING_MODE_EXTENDED_POSITION,
    OPERATING_MODE_POSITION,
    SERVO_SPECS,
)

ADDR_MODEL_NUMBER = 0          # 2 bytes, R
ADDR_FIRMWARE_VERSION = 6      # 1 byte, R
ADDR_ID = 7                    # 1 byte, EEPROM
ADDR_BAUD_RATE = 8             # 1 byte, EEPROM
ADDR_RETURN_DELAY_TIME = 9     # 1 byte, EEPROM, 2 µs a unit
ADDR_OPERATING_MODE = 11       # 1 byte, EEPROM
ADDR_MAX_POSITION_LIMIT = 48   # 4 bytes, EEPROM
ADDR_MIN_POSITION_LIMIT = 52   # 4 bytes, EEPROM
ADDR_CURRENT_LIMIT = 38        # 2 bytes, EEPROM, 2.69 mA a unit (XM430 only)
ADDR_POSITION_D_GAIN = 80      # 2 bytes, RAM
ADDR_POSITION_I_GAIN = 82      # 2 bytes, RAM
ADDR_POSITION_P_GAIN = 84      # 2 bytes, RAM
ADDR_TORQUE_ENABLE = 64        # 1 byte, RAM; 1 locks the EEPROM area
ADDR_STATUS_RETURN_LEVEL = 68  # 1 byte, RAM (0: PING only, 1: + READ, 2: all)
ADDR_REGISTERED_INSTRUCTION = 69  # 1 byte, R (1: a REG_WRITE waits for ACTION)
ADDR_HARDWARE_ERROR = 70       # 1 byte, R
ADDR_BUS_WATCHDOG = 98         # 1 byte, RAM, 20 ms a unit, -1 (0xFF) once tripped
ADDR_GOAL_CURRENT = 102        # 2 bytes, RAM, signed, 2.69 mA a unit (XM430 only)
ADDR_PROFILE_ACCELERATION = 108
ADDR_PROFILE_VELOCITY = 112
ADDR_GOAL_POSITION = 116       # 4 bytes, RAM
ADDR_PRESENT_CURRENT = 126     # 2 bytes, R, signed (Present Load on the XL430)
ADDR_PRESENT_POSITION = 132    # 4 bytes, R, signed
ADDR_PRESENT_INPUT_VOLTAGE = 144  # 2 bytes, R, 0.1 V a unit
ADDR_PRESENT_TEMPERATURE = 146    # 1 byte, R, °C

#: The modes each model offers (its record's ``operating_modes``): the XL430 has no current
#: sensing (no modes 0 and 5).
MODEL_OPERATING_MODES: dict[str, frozenset[int]] = {
    name: model.operating_modes for name, model in SERVO_SPECS.items()}
#: Modes with a Goal Current (102): the goal itself (0) or the limit of the position loop (5).
CURRENT_MODES = frozenset({OPERATING_MODE_CURRENT, OPERATING_MODE_CURRENT_POSITION})
#: Modes with a Goal Position (116) that torque-on would move to.
POSITION_MODES = frozenset({OPERATING_MODE_POSITION, OPERATING_MODE_EXTENDED_POSITION,
                            OPERATING_MODE_CURRENT_POSITION})
#: Goal Current / Current Limit unit (A) of the models that have the items (the records'
#: ``goal_current_unit``).
GOAL_CURRENT_UNIT_A: dict[str, float] = {
    name: model.goal_current_unit for name, model in SERVO_SPECS.items()
    if model.goal_current_unit is not None}
#: Datasheet stall current at 12 V, A (the current limit of models without the item).
STALL_CURRENT_A: dict[str, float] = {name: model.stall_current
                                     for name, model in SERVO_SPECS.items()}
ALERT_BIT = 0x80
WATCHDOG_UNIT_MS = 20
WATCHDOG_MAX = 127
#: Fast Sync Read needs X430/X540 firmware 45 or newer (e-manual, protocol2 "Fast Sync Read").
FAST_SYNC_READ_MIN_FIRMWARE = 45

#: Baud Rate item value → bits/s (address 8).
BAUD_INDEX: dict[int, int] = {0: 9_600, 1: 57_600, 2: 115_200, 3: 1_000_000, 4: 2_000_000,
                              5: 3_000_000, 6: 4_000_000, 7: 4_500_000}

#: Hardware Error Status bits (address 70), for messages.
HARDWARE_ERROR_BITS: dict[int, str] = {
    0x01: "input voltage", 0x04: "overheating", 0x08: "motor encoder",
    0x10: "electrical shock", 0x20: "overload",
}


def describe_hardware_error(bits: int) -> str:
    """Names of the Hardware Error Status bits set in ``bits`` ("overload, overheating")."""
    names = [name for bit, name in HARDWARE_ERROR_BITS.items() if bits & bit]
    return ", ".join(names) if names else f"0x{bits:02x}"
