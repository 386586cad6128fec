"""Hypothesis strategies shared by the algebra tests."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

coordinate = st.floats(-5.0, 5.0, allow_nan=False, allow_infinity=False)
angle = st.floats(-np.pi, np.pi, allow_nan=False, allow_infinity=False)


@st.composite
def poses(draw, n: int | None = None) -> np.ndarray:
    """One pose (3,) or n poses (n, 3): x, y in [-5, 5] m, θ in [-π, π]."""
    shape = (3,) if n is None else (n, 3)
    array = draw(hnp.arrays(np.float64, shape, elements=coordinate))
    thetas = draw(hnp.arrays(np.float64, shape[:-1], elements=angle))
    array[..., 2] = thetas
    return array


unit_interval = st.floats(0.0, 1.0, allow_nan=False)
params = hnp.arrays(np.float64, st.integers(1, 20), elements=st.floats(-0.5, 1.5))
