"""X-series control table: item metadata, models, error codes and a typed byte table.

Source: ROBOTIS e-manual, XM430-W350 and XL430-W250 control tables (Protocol 2.0),
summarised in /work/shared/dynamixel-notes.md §2. EEPROM is addresses 0..63 (locked
while Torque Enable = 1), RAM is 64+. Indirect Address k (2 bytes at 168 + 2(k-1),
k = 1..28, and at 578 + 2(k-29), k = 29..56) names the byte that Indirect Data k
(224 + k - 1, resp. 634 + k - 29) mirrors.

This module holds data only; the behaviour (validation, motion, live items) lives in
:mod:`firmware_sim.servo`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

# ---- status error numbers (Protocol 2.0 status packet ERR byte, bits 0..6) -------------
ERR_RESULT_FAIL = 0x01
ERR_INSTRUCTION = 0x02
ERR_CRC = 0x03
ERR_DATA_RANGE = 0x04
ERR_DATA_LENGTH = 0x05
ERR_DATA_LIMIT = 0x06
ERR_ACCESS = 0x07
#: Bit 7 of the ERR byte: Hardware Error Status (70) is non-zero.
ALERT_BIT = 0x80

#: Baud Rate item value -> bits per second (e-manual "Baud Rate(8)").
BAUD_RATES: Mapping[int, int] = MappingProxyType({
    0: 9600, 1: 57_600, 2: 115_200, 3: 1_000_000, 4: 2_000_000, 5: 3_000_000,
    6: 4_000_000, 7: 4_500_000,
})

EEPROM_END = 64          # addresses below this are EEPROM
TABLE_SIZE = 662         # highest X430 address is Indirect Data 56 at 661

# ---- addresses used by name elsewhere --------------------------------------------------
MODEL_NUMBER = 0
MODEL_INFORMATION = 2
FIRMWARE_VERSION = 6
ID = 7
BAUD_RATE = 8
RETURN_DELAY_TIME = 9
DRIVE_MODE = 10
OPERATING_MODE = 11
SECONDARY_ID = 12
PROTOCOL_TYPE = 13
HOMING_OFFSET = 20
MOVING_THRESHOLD = 24
TEMPERATURE_LIMIT = 31
MAX_VOLTAGE_LIMIT = 32
MIN_VOLTAGE_LIMIT = 34
PWM_LIMIT = 36
CURRENT_LIMIT = 38
VELOCITY_LIMIT = 44
MAX_POSITION_LIMIT = 48
MIN_POSITION_LIMIT = 52
STARTUP_CONFIGURATION = 60
SHUTDOWN = 63
TORQUE_ENABLE = 64
LED = 65
STATUS_RETURN_LEVEL = 68
REGISTERED_INSTRUCTION = 69
HARDWARE_ERROR_STATUS = 70
VELOCITY_I_GAIN = 76
VELOCITY_P_GAIN = 78
POSITION_D_GAIN = 80
POSITION_I_GAIN = 82
POSITION_P_GAIN = 84
FEEDFORWARD_2ND_GAIN = 88
FEEDFORWARD_1ST_GAIN = 90
BUS_WATCHDOG = 98
GOAL_PWM = 100
GOAL_CURRENT = 102
GOAL_VELOCITY = 104
PROFILE_ACCELERATION = 108
PROFILE_VELOCITY = 112
GOAL_POSITION = 116
REALTIME_TICK = 120
MOVING = 122
MOVING_STATUS = 123
PRESENT_PWM = 124
PRESENT_CURRENT = 126       # Present Load on the XL430
PRESENT_VELOCITY = 128
PRESENT_POSITION = 132
VELOCITY_TRAJECTORY = 136
POSITION_TRAJECTORY = 140
PRESENT_INPUT_VOLTAGE = 144
PRESENT_TEMPERATURE = 146
BACKUP_READY = 147

INDIRECT_ADDRESS_1 = 168
INDIRECT_DATA_1 = 224
INDIRECT_ADDRESS_29 = 578
INDIRECT_DATA_29 = 634
INDIRECT_BANKS = ((INDIRECT_ADDRESS_1, INDIRECT_DATA_1, 28),
                  (INDIRECT_ADDRESS_29, INDIRECT_DATA_29, 28))
#: Values an Indirect Address may hold (e-manual: 64 ~ 661).
INDIRECT_TARGET_RANGE = (64, 661)

# ---- operating modes and bits ----------------------------------------------------------
MODE_CURRENT = 0
MODE_VELOCITY = 1
MODE_POSITION = 3
MODE_EXTENDED_POSITION = 4
MODE_CURRENT_POSITION = 5
MODE_PWM = 16
DRIVE_REVERSE = 0x01
DRIVE_TIME_BASED = 0x04
DRIVE_TORQUE_ON_BY_GOAL = 0x08

# Hardware Error Status / Shutdown bits
HW_INPUT_VOLTAGE = 0x01
HW_OVERHEATING = 0x04
HW_ENCODER = 0x08
HW_ELECTRICAL_SHOCK = 0x10
HW_OVERLOAD = 0x20

# Moving Status (123) bits
MS_IN_POSITION = 0x01
MS_PROFILE_ONGOING = 0x02
MS_FOLLOWING_ERROR = 0x08
MS_PROFILE_RECTANGLE = 0x10
MS_PROFILE_TRIANGLE = 0x20
MS_PROFILE_TRAPEZOID = 0x30

EXTENDED_POSITION_RANGE = 1_048_575


@dataclass(frozen=True)
class Item:
    """One control-table item.

    Attributes
    ----------
    name : str
        E-manual name.
    address, size : int
        First byte and length in bytes (1, 2 or 4; little endian on the wire).
    access : str
        ``"R"`` or ``"RW"``.
    default : int
        Value after factory reset (RAM items: after reboot).
    min, max : int
        Static range; a write outside it is a Data Range Error (0x04).
    signed : bool
        Two's complement.
    allowed : frozenset[int] | None
        If set, only these values are in range (e.g. Operating Mode).
    limit : str | None
        Names a dynamic limit the servo checks on top of the range (Data Limit Error 0x06):
        ``"pwm"``, ``"current"``, ``"velocity"``, ``"position"``.
    """

    name: str
    address: int
    size: int
    access: str
    default: int = 0
    min: int = 0
    max: int = 0
    signed: bool = False
    allowed: frozenset[int] | None = None
    limit: str | None = None

    @property
    def eeprom(self) -> bool:
        """True for EEPROM items (address < 64): locked while torque is on."""
        return self.address < EEPROM_END

    @property
    def writable(self) -> bool:
        return self.access == "RW"

    @property
    def addresses(self) -> range:
        return range(self.address, self.address + self.size)

    def in_range(self, value: int) -> bool:
        """Static range check (no dynamic limits)."""
        if self.allowed is not None:
            return value in self.allowed
        return self.min <= value <= self.max

    def decode(self, raw: bytes) -> int:
        return int.from_bytes(raw, "little", signed=self.signed)

    def encode(self, value: int) -> bytes:
        # wrap rather than raise: read-only live values are written by the model itself
        return (int(value) % (1 << (8 * self.size))).to_bytes(self.size, "little")


@dataclass(frozen=True)
class ModelSpec:
    """A servo model: its number, items by address and byte-to-item map."""

    name: str
    model_number: int
    items: Mapping[int, Item]
    has_current: bool
    byte_owner: Mapping[int, Item] = field(repr=False, default_factory=dict)

    def item(self, address: int) -> Item:
        """The item starting at ``address`` (KeyError if none)."""
        return self.items[address]

    def owner(self, address: int) -> Item | None:
        """The item that holds byte ``address``, or None for an undefined address."""
        return self.byte_owner.get(address)

    @property
    def operating_modes(self) -> frozenset[int]:
        return self.items[OPERATING_MODE].allowed or frozenset()


def _items(xm: bool) -> list[Item]:
    """Item list per the e-manual; ``xm`` selects XM430-W350 defaults and XM-only items."""
    def d(xm_value: int, xl_value: int) -> int:
        return xm_value if xm else xl_value

    vmin, vmax = d(95, 60), d(160, 140)
    modes = {MODE_VELOCITY, MODE_POSITION, MODE_EXTENDED_POSITION, MODE_PWM}
    if xm:
        modes |= {MODE_CURRENT, MODE_CURRENT_POSITION}
    drive_modes = frozenset(v for v in range(16) if not v & 0x02)     # bits 0, 2, 3
    shutdown = frozenset(v for v in range(64) if not v & 0x02)        # bits 0, 2..5
    items = [
        Item("Model Number", MODEL_NUMBER, 2, "R", d(1020, 1060)),
        Item("Model Information", MODEL_INFORMATION, 4, "R"),
        Item("Firmware Version", FIRMWARE_VERSION, 1, "R"),
        Item("ID", ID, 1, "RW", 1, 0, 252),
        Item("Baud Rate", BAUD_RATE, 1, "RW", 1, 0, 7),
        Item("Return Delay Time", RETURN_DELAY_TIME, 1, "RW", 250, 0, 254),
        Item("Drive Mode", DRIVE_MODE, 1, "RW", 0, allowed=drive_modes),
        Item("Operating Mode", OPERATING_MODE, 1, "RW", 3, allowed=frozenset(modes)),
        Item("Secondary(Shadow) ID", SECONDARY_ID, 1, "RW", 255,
             allowed=frozenset(range(253)) | {255}),
        Item("Protocol Type", PROTOCOL_TYPE, 1, "RW", 2, 1, 2),
        Item("Homing Offset", HOMING_OFFSET, 4, "RW", 0, -1_044_479, 1_044_479, signed=True),
        Item("Moving Threshold", MOVING_THRESHOLD, 4, "RW", 10, 0, 1023),
        Item("Temperature Limit", TEMPERATURE_LIMIT, 1, "RW", d(80, 72), 0, 100),
        Item("Max Voltage Limit", MAX_VOLTAGE_LIMIT, 2, "RW", vmax, vmin, vmax),
        Item("Min Voltage Limit", MIN_VOLTAGE_LIMIT, 2, "RW", vmin, vmin, vmax),
        Item("PWM Limit", PWM_LIMIT, 2, "RW", 885, 0, 885),
        Item("Velocity Limit", VELOCITY_LIMIT, 4, "RW", d(200, 265), 0, 1023),
        Item("Max Position Limit", MAX_POSITION_LIMIT, 4, "RW", 4095, 0, 4095),
        Item("Min Position Limit", MIN_POSITION_LIMIT, 4, "RW", 0, 0, 4095),
        Item("Startup Configuration", STARTUP_CONFIGURATION, 1, "RW", 0, 0, 3),
        Item("Shutdown", SHUTDOWN, 1, "RW", 0x34, allowed=shutdown),
        Item("Torque Enable", TORQUE_ENABLE, 1, "RW", 0, 0, 1),
        Item("LED", LED, 1, "RW", 0, 0, 1),
        Item("Status Return Level", STATUS_RETURN_LEVEL, 1, "RW", 2, 0, 2),
        Item("Registered Instruction", REGISTERED_INSTRUCTION, 1, "R"),
        Item("Hardware Error Status", HARDWARE_ERROR_STATUS, 1, "R"),
        Item("Velocity I Gain", VELOCITY_I_GAIN, 2, "RW", d(1920, 1000), 0, 16383),
        Item("Velocity P Gain", VELOCITY_P_GAIN, 2, "RW", 100, 0, 16383),
        Item("Position D Gain", POSITION_D_GAIN, 2, "RW", d(0, 4000), 0, 16383),
        Item("Position I Gain", POSITION_I_GAIN, 2, "RW", 0, 0, 16383),
        Item("Position P Gain", POSITION_P_GAIN, 2, "RW", d(800, 640), 0, 16383),
        Item("Feedforward 2nd Gain", FEEDFORWARD_2ND_GAIN, 2, "RW", 0, 0, 16383),
        Item("Feedforward 1st Gain", FEEDFORWARD_1ST_GAIN, 2, "RW", 0, 0, 16383),
        Item("Bus Watchdog", BUS_WATCHDOG, 1, "RW", 0, 0, 127, signed=True),
        Item("Goal PWM", GOAL_PWM, 2, "RW", 885, -885, 885, signed=True, limit="pwm"),
        Item("Goal Velocity", GOAL_VELOCITY, 4, "RW", 0, -1023, 1023, signed=True,
             limit="velocity"),
        Item("Profile Acceleration", PROFILE_ACCELERATION, 4, "RW", 0, 0, 32767),
        Item("Profile Velocity", PROFILE_VELOCITY, 4, "RW", 0, 0, 32767),
        Item("Goal Position", GOAL_POSITION, 4, "RW", 0, -EXTENDED_POSITION_RANGE,
             EXTENDED_POSITION_RANGE, signed=True, limit="position"),
        Item("Realtime Tick", REALTIME_TICK, 2, "R"),
        Item("Moving", MOVING, 1, "R"),
        Item("Moving Status", MOVING_STATUS, 1, "R"),
        Item("Present PWM", PRESENT_PWM, 2, "R", signed=True),
        Item("Present Current" if xm else "Present Load", PRESENT_CURRENT, 2, "R", signed=True),
        Item("Present Velocity", PRESENT_VELOCITY, 4, "R", signed=True),
        Item("Present Position", PRESENT_POSITION, 4, "R", signed=True),
        Item("Velocity Trajectory", VELOCITY_TRAJECTORY, 4, "R", signed=True),
        Item("Position Trajectory", POSITION_TRAJECTORY, 4, "R", signed=True),
        Item("Present Input Voltage", PRESENT_INPUT_VOLTAGE, 2, "R", d(120, 111)),
        Item("Present Temperature", PRESENT_TEMPERATURE, 1, "R", 30),
        Item("Backup Ready", BACKUP_READY, 1, "R"),
    ]
    if xm:
        items += [
            Item("Current Limit", CURRENT_LIMIT, 2, "RW", 1193, 0, 1193),
            Item("Goal Current", GOAL_CURRENT, 2, "RW", 1193, -1193, 1193, signed=True,
                 limit="current"),
        ]
    lo, hi = INDIRECT_TARGET_RANGE
    for addr_base, data_base, count in INDIRECT_BANKS:
        first = 1 if addr_base == INDIRECT_ADDRESS_1 else 29
        for k in range(count):
            items.append(Item(f"Indirect Address {first + k}", addr_base + 2 * k, 2, "RW",
                              data_base + k, lo, hi))
            items.append(Item(f"Indirect Data {first + k}", data_base + k, 1, "RW", 0, 0, 255))
    return items


def _model(name: str, xm: bool) -> ModelSpec:
    items = sorted(_items(xm), key=lambda it: it.address)
    owner: dict[int, Item] = {}
    for it in items:
        for a in it.addresses:
            if a in owner:
                raise AssertionError(f"{name}: items {owner[a].name} and {it.name} overlap at {a}")
            owner[a] = it
    spec = ModelSpec(name, items[0].default, MappingProxyType({it.address: it for it in items}),
                     has_current=xm, byte_owner=MappingProxyType(owner))
    return spec


#: Supported models by name.
MODELS: Mapping[str, ModelSpec] = MappingProxyType({
    "xm430-w350": _model("xm430-w350", xm=True),
    "xl430-w250": _model("xl430-w250", xm=False),
})


def indirect_data_slot(address: int) -> int | None:
    """Address of the Indirect Address item serving Indirect Data byte ``address``, else None."""
    for addr_base, data_base, count in INDIRECT_BANKS:
        if data_base <= address < data_base + count:
            return addr_base + 2 * (address - data_base)
    return None


def is_indirect_data(address: int) -> bool:
    return indirect_data_slot(address) is not None


class ControlTable:
    """The byte image of one servo's control table with typed item access.

    Parameters
    ----------
    spec : ModelSpec
        Which model's items and defaults.

    Notes
    -----
    Plain storage: no access checks, no indirect resolution, no live values. The
    :class:`firmware_sim.servo.Servo` layers the firmware's rules on top.
    """

    def __init__(self, spec: ModelSpec) -> None:
        self.spec = spec
        self.data = bytearray(TABLE_SIZE)
        self.reset(lambda it: True)

    def reset(self, which: Callable[[Item], bool]) -> None:
        """Set every item for which ``which(item)`` is true to its default."""
        for it in self.spec.items.values():
            if which(it):
                self.data[it.address:it.address + it.size] = it.encode(it.default)

    def get(self, address: int) -> int:
        """Typed value of the item starting at ``address``."""
        it = self.spec.items[address]
        return it.decode(bytes(self.data[it.address:it.address + it.size]))

    def set(self, address: int, value: int) -> None:
        """Store ``value`` into the item starting at ``address`` (no checks)."""
        it = self.spec.items[address]
        self.data[it.address:it.address + it.size] = it.encode(value)

    def raw(self, address: int, length: int) -> bytes:
        return bytes(self.data[address:address + length])

    def snapshot(self, items: Iterable[Item]) -> dict[int, bytes]:
        """Raw bytes of the given items, keyed by address (for backup/restore)."""
        return {it.address: self.raw(it.address, it.size) for it in items}

    def restore(self, saved: Mapping[int, bytes]) -> None:
        for address, raw in saved.items():
            self.data[address:address + len(raw)] = raw
