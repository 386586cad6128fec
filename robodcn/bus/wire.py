"""Wire time of one streaming cycle, and the rate a bus can carry.

Model (dynamixel-notes §5, design.md §5): 10 bits a byte (start, 8 data, stop), pure wire
time. Per cycle a Sync Write of N 4-byte goals is 14 + 5N bytes; a read-back of L bytes a
servo adds its instruction (14 + N bytes) and the replies: N status packets of 11 + L bytes
for Sync Read, one packet of 8 + (L + 4)·N bytes for Fast Sync Read (L = 4: Present Position
alone, 15 and 8 + 8N; L = 11: the feedback block of :mod:`robodcn.bus.feedback`).
Return Delay Time (RDT) adds before each reply: N times for Sync Read, once for Fast Sync
Read (how RDT applies inside a fast chain is undocumented; "once" is the lower bound, so a
rate above the limit is surely too fast).
Firmware turnaround and the USB adapter come on top: the model is a floor, not a forecast.
"""

from __future__ import annotations

from robodcn import _checks
from robodcn.errors import InputError

#: Feedback kinds: no read-back, Sync Read (0x82), Fast Sync Read (0x8A).
FEEDBACK = ("none", "sync", "fast")
BITS_PER_BYTE = 10


def write_bytes(n_servos: int) -> int:
    """Bytes of a Sync Write of 4-byte goals to ``n_servos`` servos: 14 + 5N."""
    return 14 + 5 * n_servos


def read_bytes(n_servos: int, feedback: str, item_bytes: int = 4) -> int:
    """Bytes of one group read of ``item_bytes`` (L) a servo: instruction 14 + N plus replies
    (11 + L)·N (Sync Read) or 8 + (L + 4)·N (Fast Sync Read); 0 for ``feedback="none"``."""
    if feedback == "none":
        return 0
    reply = ((11 + item_bytes) * n_servos if feedback == "sync"
             else 8 + (item_bytes + 4) * n_servos)
    return 14 + n_servos + reply


def cycle_wire_time(n_servos: int, baud: int, *, feedback: str = "fast",
                    return_delay_us: float = 0.0, item_bytes: int = 4) -> float:
    """Seconds on the wire for one write (+ one read-back) cycle.

    t = 10·(bytes_write + bytes_read)/baud + RDT·m, with m = N for Sync Read, 1 for Fast
    Sync Read and 0 without feedback (module docstring; dynamixel-notes §5 table: N = 3 at
    1 Mbps gives 290 µs write only, 910 µs with Sync Read, 780 µs with Fast Sync Read).
    """
    if not _checks.is_int(n_servos) or n_servos < 1:
        raise InputError(f"n_servos must be an integer ≥ 1, got {n_servos!r}",
                         field="n_servos", value=n_servos)
    if not _checks.is_real(baud) or not baud > 0:
        raise InputError(f"baud must be a positive number, got {baud!r}", field="baud",
                         value=baud)
    if feedback not in FEEDBACK:
        raise InputError(f"feedback must be one of {', '.join(FEEDBACK)}, got {feedback!r}",
                         field="feedback", value=feedback)
    if not return_delay_us >= 0:
        raise InputError(f"return_delay_us must be ≥ 0, got {return_delay_us!r}",
                         field="return_delay_us", value=return_delay_us)
    wire = BITS_PER_BYTE * (write_bytes(n_servos)
                            + read_bytes(n_servos, feedback, item_bytes)) / baud
    delays = {"none": 0, "sync": n_servos, "fast": 1}[feedback]
    return wire + delays * return_delay_us * 1e-6


def mean_cycle_wire_time(n_servos: int, baud: int, *, feedback: str, feedback_every: int,
                         return_delay_us: float = 0.0, item_bytes: int = 4) -> float:
    """Average wire time per sample when every ``feedback_every``-th sample reads back
    (0: never): t_write + (t_cycle − t_write)/k."""
    write = cycle_wire_time(n_servos, baud, feedback="none")
    if feedback == "none" or not feedback_every:
        return write
    full = cycle_wire_time(n_servos, baud, feedback=feedback, return_delay_us=return_delay_us,
                           item_bytes=item_bytes)
    return write + (full - write) / feedback_every


__all__ = ["FEEDBACK", "cycle_wire_time", "mean_cycle_wire_time", "read_bytes", "write_bytes"]
