"""Joint angles (radians) ↔ Dynamixel goal ticks, per servo offset, direction and resolution.

tick = zero_offset + direction·angle·ticks_per_turn / 2π, rounded half away from zero
(so a joint angle and its mirror image round symmetrically about the zero offset), and
angle = direction·(tick − zero_offset)·2π / ticks_per_turn. ``ticks → radians → ticks`` is
exact; ``radians → ticks → radians`` is within half a tick (π / ticks_per_turn).
Tick limits are checked by the planner, never clamped here.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn.config import ServoSpec
from robodcn.errors import InputError
from robodcn.servo_models import SERVO_SPECS


def _columns(servos: Sequence[ServoSpec]) -> tuple[NDArray[np.float64], ...]:
    offset = np.array([s.zero_offset for s in servos], dtype=np.float64)
    direction = np.array([s.direction for s in servos], dtype=np.float64)
    per_radian = np.array([s.ticks_per_turn for s in servos], dtype=np.float64) / (2.0 * np.pi)
    return offset, direction, per_radian


def radians_per_tick(servos: Sequence[ServoSpec]) -> NDArray[np.float64]:
    """One tick of each servo in joint radians (k,): 2π / ticks_per_turn."""
    return 2.0 * np.pi / np.array([s.ticks_per_turn for s in servos], dtype=np.float64)


def half_tick(servos: Sequence[ServoSpec]) -> float:
    """The smallest half tick among ``servos`` in radians: how far a rounded goal can be
    from its angle (π / ticks_per_turn)."""
    return float(np.min(radians_per_tick(servos))) / 2.0


def _shape(name: str, array: NDArray, servos: Sequence[ServoSpec]) -> None:
    if array.ndim not in (1, 2) or array.shape[-1] != len(servos):
        raise InputError(f"{name} must have shape (n, {len(servos)}) or ({len(servos)},) "
                         f"(one column per servo), got shape {array.shape}", field=name,
                         value=array)


def round_half_away(x: ArrayLike) -> NDArray[np.float64]:
    """Round to the nearest integer, halves away from zero (np.round rounds halves to even)."""
    x = np.asarray(x, dtype=np.float64)
    return np.copysign(np.floor(np.abs(x) + 0.5), x)


def radians_to_ticks(angles: ArrayLike, servos: Sequence[ServoSpec]) -> NDArray[np.int64]:
    """Goal ticks for joint angles: zero_offset + round(direction·angle·ticks_per_turn/2π).

    Parameters
    ----------
    angles : (n, k) or (k,) joint angles in radians, one column per servo.
    servos : k servo specs in column order.

    Returns
    -------
    int64 array of the same shape. Rounding is half away from zero about the zero offset.
    """
    angles = _checks.finite("angles", angles)
    _shape("angles", angles, servos)
    if angles.ndim == 1:
        return ticks_unchecked(angles[None, :], servos)[0]
    return ticks_unchecked(angles, servos)


#: Arrays with fewer rows than this are converted whole, longer ones a column at a time.
WHOLE_ROWS = 512


def tick_columns(servos: Sequence[ServoSpec]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The servos' (direction·ticks_per_turn/2π, zero_offset) arrays (k,) that
    :func:`ticks_unchecked` converts with."""
    return (np.array([s.direction * s.ticks_per_turn / (2.0 * np.pi) for s in servos]),
            np.array([s.zero_offset for s in servos], dtype=np.int64))


def ticks_unchecked(angles: NDArray[np.float64], servos: Sequence[ServoSpec],
                    columns: tuple[NDArray[np.float64], NDArray[np.int64]] | None = None
                    ) -> NDArray[np.int64]:
    """:func:`radians_to_ticks` for a finite (n, k) array, without the argument checks.

    Works one contiguous column at a time (each stays in cache), a short plan's whole array
    at once (fewer numpy calls; the same products and rounding, so the same ticks): the
    planner's hot path. ``columns``: the servos' :func:`tick_columns` when the caller keeps
    them (planner.arm_arrays; ``servos`` is then not read), else built here.
    """
    scale, offset = tick_columns(servos) if columns is None else columns
    if angles.shape[0] < WHOLE_ROWS:
        # round_half_away in place (the same floor(|x| + 0.5) with x's sign)
        x = angles * scale
        r = np.abs(x)
        r += 0.5
        np.floor(r, out=r)
        np.copysign(r, x, out=r)
        whole = r.astype(np.int64)
        whole += offset
        return whole
    out = np.empty(angles.shape, dtype=np.int64)
    # round_half_away per column into two buffers made once (the same operations): fresh
    # temporaries of a long plan's columns cost more than the arithmetic
    x = np.empty(angles.shape[0])
    r = np.empty(angles.shape[0])
    for j in range(angles.shape[1]):
        np.multiply(angles[:, j], scale[j], out=x)
        np.abs(x, out=r)
        r += 0.5
        np.floor(r, out=r)
        np.copysign(r, x, out=r)
        out[:, j] = r
        out[:, j] += offset[j]
    return out


def ticks_to_radians(ticks: ArrayLike, servos: Sequence[ServoSpec]) -> NDArray[np.float64]:
    """Joint angles (radians) for ticks: direction·(tick − zero_offset)·2π/ticks_per_turn.

    ticks : (n, k) or (k,) integer ticks, one column per servo. Returns floats, same shape.
    """
    raw = _checks.finite("ticks", ticks)
    _shape("ticks", raw, servos)
    if not np.array_equal(raw, np.round(raw)):
        raise InputError(f"ticks must be whole numbers, got {_checks.show(raw)}", field="ticks",
                         value=ticks)
    offset, direction, per_radian = _columns(servos)
    return direction * (raw - offset) / per_radian


def joint_velocities(shaft: ArrayLike, servos: Sequence[ServoSpec]) -> NDArray[np.float64]:
    """Joint velocities (rad/s) of the servos' shaft velocities (rad/s, signed as Present
    Velocity: :class:`robodcn.bus.feedback.Feedback`): q̇ = direction·ω, the sense
    :func:`ticks_to_radians` gives the angles (a servo's ticks are its shaft's).

    shaft : (n, k) or (k,), one column per servo. Returns the same shape.
    """
    raw = np.asarray(shaft, dtype=np.float64)
    _shape("velocities", raw, servos)
    return _columns(servos)[1] * raw


def joint_efforts(currents: ArrayLike, servos: Sequence[ServoSpec]) -> NDArray[np.float64]:
    """Joint torques (N·m) the servos' currents (A, signed as Present Current) stand for:
    τ = direction·K_t·i, K_t = τ_stall/I_stall of the servo model
    (:attr:`robodcn.servo_models.ServoModel.torque_constant`) — the motor torque at the output,
    friction and the rotor's inertia included.

    currents : (n, k) or (k,), one column per servo. Returns the same shape.
    """
    raw = np.asarray(currents, dtype=np.float64)
    _shape("currents", raw, servos)
    kt = np.array([s.direction * SERVO_SPECS[s.model].torque_constant for s in servos])
    return kt * raw
