"""How far a servo's firmware implements indirect addressing (Indirect Address/Data).

On the X-series (e-manual, XM430-W350 control table) Indirect Address k (168 + 2(k−1),
k = 1..28; 578 + 2(k−29), k = 29..56) names the byte that Indirect Data k (224 + k−1;
634 + k−29) reads and writes. Not every servo on a bus does that: an older firmware or a
clone may acknowledge the map and not serve it. A servo's ``indirect`` mode says which:

=============  ==========================================================================
``"on"``       the firmware's rules (:mod:`.access`): the default
``"off"``      a WRITE to an Indirect Address answers OK and stores nothing: the factory
               map (each Indirect Data byte naming itself) stays, and reads back
``"unresolved"``  the Indirect Address items store and read back what was written, but
               Indirect Data bytes never follow them: plain storage (reads 0 until
               written)
=============  ==========================================================================

``True`` and ``False`` stand for ``"on"`` and ``"off"``.
"""

from __future__ import annotations

from collections.abc import Mapping

from firmware_sim import control_table as ct
from firmware_sim.control_table import Item

ON, OFF, UNRESOLVED = "on", "off", "unresolved"
INDIRECT_MODES = (ON, OFF, UNRESOLVED)


def indirect_mode(value: bool | str) -> str:
    """The mode ``value`` names (module table); ValueError otherwise."""
    if value is True:
        return ON
    if value is False:
        return OFF
    if isinstance(value, str) and value.lower() in INDIRECT_MODES:
        return value.lower()
    raise ValueError(f"indirect must be one of {', '.join(INDIRECT_MODES)} (or true/false), "
                     f"got {value!r}")


def is_indirect_address(address: int) -> bool:
    """Whether ``address`` is the first byte of an Indirect Address item."""
    return any(base <= address < base + 2 * count and (address - base) % 2 == 0
               for base, _, count in ct.INDIRECT_BANKS)


def accepted(mode: str, values: Mapping[Item, int]) -> dict[Item, int]:
    """What a validated WRITE stores under ``mode``: ``"off"`` drops Indirect Address
    items (the write still answers OK)."""
    if mode != OFF:
        return dict(values)
    return {it: v for it, v in values.items() if not is_indirect_address(it.address)}
