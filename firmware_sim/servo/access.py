"""Control-table access rules: what a READ returns and whether a WRITE is accepted.

Error precedence of a write (all-or-nothing, nothing written on any error):
Access (0x07: undefined, read-only, EEPROM while torque on) → Length (0x05: part of an
item) → Range (0x04: outside the item's range; goal items while the Bus Watchdog has
tripped) → Limit (0x06: Goal Position outside Min/Max Position Limit in mode 3, goal
PWM/current/velocity above their limit items) → Result Fail (0x01: torque on while a
shutdown error stands). Source: e-manual Protocol 2.0 "Status Packet" error numbers and
the X-series control table, as in dynamixel-notes.md §1.5 and §2.
"""

from __future__ import annotations

from firmware_sim import control_table as ct
from firmware_sim.control_table import (
    ERR_ACCESS,
    ERR_DATA_LENGTH,
    ERR_DATA_LIMIT,
    ERR_DATA_RANGE,
    ERR_RESULT_FAIL,
    TABLE_SIZE,
    ControlTable,
    Item,
    ModelSpec,
    indirect_data_slot,
)

#: The goal items, refused while the Bus Watchdog has tripped.
GOALS = (ct.GOAL_PWM, ct.GOAL_CURRENT, ct.GOAL_VELOCITY, ct.GOAL_POSITION)


def _touches_indirect_data(address: int, length: int) -> bool:
    return any(address < data_base + count and data_base < address + length
               for _, data_base, count in ct.INDIRECT_BANKS)


def read(table: ControlTable, spec: ModelSpec, address: int, length: int, *,
         follow: bool = True) -> tuple[int, bytes]:
    """READ: (error code, data); data is b"" on error.

    A read must start on a defined item and stay inside the table, else it is an Access
    Error; undefined gaps inside a longer block read 0 (block reads of the table work on
    the firmware). Indirect Data bytes read the byte their Indirect Address names (unless
    that is itself an Indirect Data byte: then the stored byte, so the factory
    self-mapping behaves as plain RAM). ``follow=False``: Indirect Data bytes are always
    plain storage (a firmware that does not resolve the map, :mod:`.indirect`).
    """
    if length <= 0:
        return ERR_DATA_LENGTH, b""
    if address < 0 or address + length > TABLE_SIZE or spec.owner(address) is None:
        return ERR_ACCESS, b""
    out = bytearray(table.raw(address, length))
    if not follow or not _touches_indirect_data(address, length):
        return 0, bytes(out)
    for i in range(length):
        slot = indirect_data_slot(address + i)
        if slot is not None:
            target = table.get(slot)
            if indirect_data_slot(target) is None:
                out[i] = table.data[target]
    return 0, bytes(out)


def _resolve(table: ControlTable, spec: ModelSpec, address: int, data: bytes, follow: bool
             ) -> tuple[int, dict[Item, dict[int, int]]]:
    """Map written bytes to target items (through indirect data); error on bad access."""
    if not data:
        return ERR_DATA_LENGTH, {}
    if address < 0 or address + len(data) > TABLE_SIZE:
        return ERR_ACCESS, {}
    items: dict[Item, dict[int, int]] = {}
    for i, byte in enumerate(data):
        a = address + i
        slot = indirect_data_slot(a) if follow else None
        if slot is not None:
            target = table.get(slot)
            # an Indirect Data target (the factory mapping points each at itself) is
            # not followed: the data byte is then plain storage
            if indirect_data_slot(target) is None:
                a = target
        owner = spec.owner(a)
        if owner is None or not owner.writable:
            return ERR_ACCESS, {}
        items.setdefault(owner, {})[a - owner.address] = byte
    return 0, items


def validate(table: ControlTable, spec: ModelSpec, address: int, data: bytes, *,
             watchdog_tripped: bool, follow: bool = True) -> tuple[int, dict[Item, int]]:
    """(error code, {item: value}) of a WRITE of ``data`` at ``address`` (module rules;
    ``follow`` as in :func:`read`)."""
    code, raw = _resolve(table, spec, address, data, follow)
    if code:
        return code, {}
    torque = table.get(ct.TORQUE_ENABLE)
    if torque and any(it.eeprom for it in raw):
        return ERR_ACCESS, {}
    if any(len(parts) != it.size for it, parts in raw.items()):
        return ERR_DATA_LENGTH, {}
    values = {it: it.decode(bytes(parts[k] for k in range(it.size)))
              for it, parts in raw.items()}
    for it, value in values.items():
        if not it.in_range(value):
            return ERR_DATA_RANGE, {}
        if watchdog_tripped and (it.address in GOALS
                                 or (it.address == ct.BUS_WATCHDOG and value)):
            return ERR_DATA_RANGE, {}
    for it, value in values.items():
        if it.limit and not within_limit(table, it.limit, value):
            return ERR_DATA_LIMIT, {}
    if values.get(spec.items[ct.TORQUE_ENABLE]) == 1 and not torque and \
            table.get(ct.HARDWARE_ERROR_STATUS) & table.get(ct.SHUTDOWN):
        return ERR_RESULT_FAIL, {}     # shut down: only a reboot re-enables torque
    return 0, values


def within_limit(table: ControlTable, kind: str, value: int) -> bool:
    """Whether a goal ``value`` keeps its limit item (``kind``: pwm, current, velocity,
    position; Goal Position is limited in position mode 3 only)."""
    if kind == "pwm":
        return abs(value) <= table.get(ct.PWM_LIMIT)
    if kind == "current":
        return abs(value) <= table.get(ct.CURRENT_LIMIT)
    if kind == "velocity":
        return abs(value) <= table.get(ct.VELOCITY_LIMIT)
    if table.get(ct.OPERATING_MODE) == ct.MODE_POSITION:
        return table.get(ct.MIN_POSITION_LIMIT) <= value <= table.get(ct.MAX_POSITION_LIMIT)
    return True
