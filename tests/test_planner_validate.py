"""The planner's fast validation path: the whole-array check of a short plan decides as the
column-at-a-time check does, on plans that pass and plans that fail each limit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robodcn.planner import validate


def _columns(joints, ticks, lo, hi, tmin, tmax, limits, rate, slack) -> bool:
    """validate._fine's per-column path, forced (FINE_BLOCK_ROWS = 0)."""
    saved = validate.FINE_BLOCK_ROWS
    validate.FINE_BLOCK_ROWS = 0
    try:
        return validate._fine(joints, ticks, lo, hi, tmin, tmax, limits, rate, slack)
    finally:
        validate.FINE_BLOCK_ROWS = saved


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 60), jerk=st.booleans(),
       tight=st.sampled_from(["none", "position", "ticks", "velocity", "acceleration",
                              "jerk"]))
@settings(max_examples=200, deadline=None)
def test_the_block_check_decides_as_the_column_check(seed: int, n: int, jerk: bool,
                                                     tight: str) -> None:
    rng = np.random.default_rng(seed)
    k = 3
    joints = np.cumsum(rng.normal(0.0, 0.01, (n, k)), axis=0)
    ticks = np.rint(joints * 651.9).astype(np.int64) + 2048
    rate = 100.0
    d1 = np.abs(np.diff(joints, axis=0)).max(initial=0.0) * rate
    d2 = np.abs(np.diff(joints, n=2, axis=0)).max(initial=0.0) * rate ** 2
    # limits just above what the plan needs, one of them just below where asked
    lo, hi = joints.min(axis=0) - 1e-3, joints.max(axis=0) + 1e-3
    tmin, tmax = ticks.min(axis=0) - 1, ticks.max(axis=0) + 1
    v = np.full(k, 1.01 * d1 + 1e-9)
    a = np.full(k, 1.01 * max(d2, np.abs(joints[1:2] - joints[:1]).max(initial=0.0) * rate ** 2)
                + 1e-9) * 4.0
    j = np.full(k, np.inf)
    if jerk:
        j[rng.integers(0, k)] = 1e9 if tight != "jerk" else 1e-6
    if tight == "position":
        hi[rng.integers(0, k)] -= 2e-3
    elif tight == "ticks":
        tmin[rng.integers(0, k)] += 2
    elif tight == "velocity":
        v[:] = 0.5 * d1 + 1e-12
    elif tight == "acceleration":
        a[:] = 1e-9
    limits = (v, a, j)
    for lim in (limits, None):
        assert validate._fine(joints, ticks, lo, hi, tmin, tmax, lim, rate, 1.0) == \
            _columns(joints, ticks, lo, hi, tmin, tmax, lim, rate, 1.0)


@pytest.mark.parametrize("n", [1, 2, 3, 40])
def test_a_plan_within_every_limit_passes_both_ways(n: int) -> None:
    joints = np.linspace(0.0, 0.01, n)[:, None] * np.ones(3)
    ticks = np.full((n, 3), 2048)
    big = np.full(3, 1e9)
    args = (joints, ticks, -big, big, np.zeros(3, int), np.full(3, 4095), (big, big, big),
            100.0, 1.0)
    assert validate._fine(*args) and _columns(*args)
