"""Group packets without the port: decoding Fast Sync Read replies, checking and encoding
goal rows for Sync Write. Pure functions over bytes and arrays (the hot path's data work)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.errors import CommError, InputError, TickLimitError


def fast_sync_read_blocks(raw: Sequence[int], ids: Sequence[int],
                          length: int) -> list[tuple[int, bytes]]:
    """(ERR byte, data) per servo from a Fast Sync Read status packet's parameters.

    The reply is one packet: per servo ERR, ID, ``length`` data bytes and a CRC
    (dynamixel-notes §1.7), stride length + 4. The SDK's own parser drops the ERR bytes
    (hiding the Alert bit), so they are decoded here; CommError when the size or an id is
    not what the instruction asked for.
    """
    stride = length + 4
    if len(raw) != stride * len(ids):
        raise CommError(f"fast sync read returned {len(raw)} bytes, expected "
                        f"{stride * len(ids)}", field="bus", value=len(raw))
    out = []
    for index, servo_id in enumerate(ids):
        block = raw[index * stride:(index + 1) * stride]
        if block[1] != servo_id:
            raise CommError(f"fast sync read: block {index} is from id {block[1]}, expected "
                            f"{servo_id}", field=f"servo[{servo_id}]", value=block[1])
        out.append((int(block[0]), bytes(block[2:2 + length])))
    return out


def check_ticks(ticks: ArrayLike, limits: NDArray[np.int64],
                ids: Sequence[int]) -> NDArray[np.int64]:
    """``ticks`` (n, k) or (k,) as int64, every value inside ``limits`` (k, 2).

    Raises InputError for a wrong shape or dtype, TickLimitError naming the first sample
    and servo outside its limits.
    """
    k = len(ids)
    array = np.asarray(ticks)
    if array.ndim not in (1, 2) or array.shape[-1] != k:
        raise InputError(f"ticks must have shape (n, {k}) or ({k},), got shape "
                         f"{array.shape}", field="ticks", value=array)
    if not np.issubdtype(array.dtype, np.integer):
        raise InputError(f"ticks must be integers, got dtype {array.dtype}", field="ticks",
                         value=array)
    rows = array.reshape(-1, k).astype(np.int64)
    bad = (rows < limits[:, 0]) | (rows > limits[:, 1])
    if bad.any():
        sample, column = (int(i) for i in np.argwhere(bad)[0])
        low, high = (int(v) for v in limits[column])
        raise TickLimitError(
            f"sample {sample}: servo {ids[column]} goal {int(rows[sample, column])} is "
            f"outside its limits [{low}, {high}] ticks", field="ticks",
            value=int(rows[sample, column]), sample=sample)
    return rows.reshape(array.shape)


def encode_rows(rows: NDArray[np.int64]) -> list[list[list[int]]]:
    """Goal rows (n, k) → per sample, per servo, the 4 little-endian bytes (int32) to send."""
    n, k = rows.shape
    return rows.astype("<i4").view(np.uint8).reshape(n, k, 4).tolist()


def decode_row(row: Sequence[Sequence[int]]) -> list[int]:
    """Goal ticks (k,) of one encoded Sync Write row (4 little-endian bytes per servo,
    int32: one sample of :func:`encode_rows`)."""
    out = []
    for b in row:
        v = b[0] | b[1] << 8 | b[2] << 16 | b[3] << 24
        out.append(v - (1 << 32) if v & 0x80000000 else v)
    return out


def encode_row(goals: Sequence[int]) -> list[list[int]]:
    """One Sync Write row of goal ticks (k,): the inverse of :func:`decode_row`."""
    return [list((int(g) & 0xFFFFFFFF).to_bytes(4, "little")) for g in goals]
