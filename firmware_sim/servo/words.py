"""Fixed-point words of the control table: rounding and int32 wrap as the firmware does them."""

from __future__ import annotations

import math
import struct

# Realtime Tick, Moving, Moving Status at 120; Present Velocity, Present Position,
# Velocity Trajectory, Position Trajectory at 128
TICK_MOVING = struct.Struct("<HBB")
VEL_POS_TRAJ = struct.Struct("<iiii")
S8 = struct.Struct("<b")
S16 = struct.Struct("<h")
S32 = struct.Struct("<i")
U16 = struct.Struct("<H")
U32 = struct.Struct("<I")


def round_half_up(x: float) -> int:
    """⌊x + ½⌋: the nearest integer, halves upwards."""
    return math.floor(x + 0.5)


def wrap32(x: int) -> int:
    """Two's-complement wrap to int32, as the firmware's 4-byte items do."""
    return (x + (1 << 31)) % (1 << 32) - (1 << 31)
