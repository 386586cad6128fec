"""Feedback of one cycle in one packet: the Indirect Address map and its decoding.

:meth:`ServoBus.configure` points Indirect Address 29.. (578, data at 634, the bank ROBOTIS's
own ros2_control stack reads from, leaving 1–28 free) at Present Position (132, 4 bytes),
Present Velocity (128, 4), Present Current (126, 2; Present Load on the XL430) and Hardware
Error Status (70, 1), so one (Fast) Sync Read of ``FEEDBACK_LENGTH`` bytes at
``ADDR_FEEDBACK`` returns all of them from every servo (e-manual "Indirect Address";
dynamixel-notes §2).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodcn.servo_models import SERVO_SPECS, XM430_W350

#: Indirect Address 29 and the Indirect Data 29 it serves.
ADDR_INDIRECT_ADDRESS_29 = 578
ADDR_FEEDBACK = 634
#: (address, size) of each item, in the order they sit in the feedback block.
FEEDBACK_ITEMS: tuple[tuple[int, int], ...] = ((132, 4), (128, 4), (126, 2), (70, 1))
FEEDBACK_LENGTH = sum(size for _, size in FEEDBACK_ITEMS)
#: Present Velocity unit, rad/s (0.229 rpm).
VELOCITY_UNIT_RAD_S = 0.229 * 2.0 * np.pi / 60.0
#: Present Current unit per model, A (the records' ``present_current_unit``: 2.69 mA on the
#: XM430; the XL430 reports Present Load in 0.1 % of its stall current, 1.4 A at 12 V, shown
#: as the current it stands for).
CURRENT_UNIT_A: dict[str, float] = {name: model.present_current_unit
                                    for name, model in SERVO_SPECS.items()}


def indirect_map() -> list[int]:
    """Bytes of one WRITE at Indirect Address 29: the target address of each feedback byte."""
    out: list[int] = []
    for address, size in FEEDBACK_ITEMS:
        for b in range(size):
            out += list((address + b).to_bytes(2, "little"))
    return out


@dataclass(frozen=True)
class Feedback:
    """One feedback read, bus order: positions (ticks), velocities (rad/s of the servo
    shaft, signed as Present Velocity), currents (A), hardware error bits."""

    positions: NDArray[np.int64]
    velocities: NDArray[np.float64]
    currents: NDArray[np.float64]
    hardware_errors: NDArray[np.int64]


#: The block as a numpy record (little-endian, packed): one decode for all servos.
FEEDBACK_DTYPE = np.dtype([("position", "<i4"), ("velocity", "<i4"), ("current", "<i2"),
                           ("error", "u1")])


def current_units(models: Sequence[str]) -> NDArray[np.float64]:
    """Amperes per Present Current (or Present Load) unit of each servo model (a model
    robodcn does not know reads as an XM430)."""
    return np.array([CURRENT_UNIT_A.get(m, XM430_W350.present_current_unit) for m in models])


def decode_feedback(blocks: Sequence[bytes], units: NDArray[np.float64]) -> Feedback:
    """The ``FEEDBACK_LENGTH``-byte block of each servo → :class:`Feedback` (vectorised);
    ``units`` from :func:`current_units`."""
    rec = np.frombuffer(b"".join(blocks), dtype=FEEDBACK_DTYPE)
    return Feedback(rec["position"].astype(np.int64),
                    rec["velocity"] * VELOCITY_UNIT_RAD_S, rec["current"] * units,
                    rec["error"].astype(np.int64))


__all__ = ["ADDR_FEEDBACK", "ADDR_INDIRECT_ADDRESS_29", "CURRENT_UNIT_A", "FEEDBACK_DTYPE",
           "FEEDBACK_ITEMS", "FEEDBACK_LENGTH", "VELOCITY_UNIT_RAD_S", "Feedback",
           "current_units", "decode_feedback", "indirect_map"]
