"""Ratios of sines that the algebra modules need near 0/0, with their Taylor series.

Below ``SERIES_ANGLE`` the truncation error (x⁴ terms) is under 1e-16 while the direct
quotient would lose digits or divide 0 by 0.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

SERIES_ANGLE = 1e-4


def sinc(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """sin(x)/x, by its series 1 − x²/6 + x⁴/120 for |x| < SERIES_ANGLE."""
    small = np.abs(x) < SERIES_ANGLE
    safe = np.where(small, 1.0, x)
    x2 = x * x
    return np.where(small, 1.0 - x2 / 6.0 + x2 * x2 / 120.0, np.sin(safe) / safe)


def sin_ratio(t: NDArray[np.float64], phi: NDArray[np.float64]) -> NDArray[np.float64]:
    """sin(tφ)/sin(φ), by its series t·(1 + (1 − t²)φ²/6) for |φ| < SERIES_ANGLE."""
    small = np.abs(phi) < SERIES_ANGLE
    safe = np.where(small, 1.0, phi)
    return np.where(small, t * (1.0 + (1.0 - t * t) * phi * phi / 6.0),
                    np.sin(t * safe) / np.sin(safe))
