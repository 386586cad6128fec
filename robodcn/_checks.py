"""Argument checks shared by every layer: number kinds, shapes, finiteness, names, unit norms.

Every failure raises :class:`robodcn.errors.InputError` (or ``DegenerateError``) naming the
argument and showing the offending value, so callers never have to guess which input was bad.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.errors import InputError

#: Norm deviation accepted (and silently repaired) before an input counts as non-unit.
UNIT_TOLERANCE = 1e-9


def is_int(value: Any) -> bool:
    """True for a Python or numpy integer that is not a bool (True is an int in Python)."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


def is_real(value: Any) -> bool:
    """True for an int or float (numpy's too) that is not a bool; NaN and inf included."""
    return isinstance(value, int | float | np.integer | np.floating) \
        and not isinstance(value, bool | np.bool_)


def is_finite_real(value: Any) -> bool:
    """:func:`is_real` and finite (an int too large for a float is not finite)."""
    if not is_real(value):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def show(value: Any, limit: int = 80) -> str:
    """A short repr of ``value`` for error messages (arrays are abbreviated)."""
    if isinstance(value, np.ndarray):
        text = np.array2string(value, threshold=6, edgeitems=2, precision=6)
    else:
        text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def as_float_array(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """``value`` as a float64 array; raises InputError naming ``name`` when impossible."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be numeric, got {show(value)}", field=name,
                         value=value) from exc
    return array


def finite(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """Float array whose entries are all finite; names the first bad entry otherwise."""
    array = as_float_array(name, value)
    if not np.isfinite(array).all():
        index = tuple(int(i) for i in np.argwhere(~np.isfinite(array))[0])
        where = f"{name}{list(index)}" if index else name
        raise InputError(f"{where} must be finite, got {array[index]!r}", field=name,
                         value=value)
    return array


def last_axis(name: str, value: ArrayLike, size: int) -> NDArray[np.float64]:
    """Finite float array of shape (..., size)."""
    array = finite(name, value)
    if array.ndim == 0 or array.shape[-1] != size:
        raise InputError(f"{name} must have shape (..., {size}), got shape {array.shape}",
                         field=name, value=value)
    return array


def samples(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """A finite 1-D array of interpolation parameters, shape (n,)."""
    array = finite(name, value)
    if array.ndim != 1:
        raise InputError(f"{name} must be a 1-D array of shape (n,), got shape {array.shape}",
                         field=name, value=value)
    return array


def one_of(name: str, value: Any, allowed: Iterable[str]) -> str:
    """``value`` when it is one of ``allowed``; InputError listing the choices otherwise."""
    allowed = tuple(allowed)
    if not isinstance(value, str) or value not in allowed:
        raise InputError(f"{name} must be one of {', '.join(allowed)}, got {show(value)}",
                         field=name, value=value)
    return value


def unit_scale(name: str, norm: NDArray[np.float64]) -> NDArray[np.float64]:
    """Check that ``norm`` is 1 within UNIT_TOLERANCE; returns the factor 1/norm to repair it."""
    deviation = np.abs(norm - 1.0)
    if deviation.size and deviation.max() > UNIT_TOLERANCE:
        index = np.unravel_index(int(np.argmax(deviation)), deviation.shape)
        where = f"{name}{list(index)}" if index else name
        raise InputError(f"{where} must be a unit element (norm 1 within {UNIT_TOLERANCE:g}), "
                         f"its norm is {float(norm[index]):.12g}", field=name,
                         value=float(norm[index]))
    return 1.0 / norm
