"""Radians ↔ ticks: exact round trips, half-away rounding, direction and offsets."""

from __future__ import annotations

import math
from decimal import ROUND_HALF_UP, Decimal

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from robodcn.config import ServoSpec
from robodcn.errors import InputError
from robodcn.servo_units import radians_to_ticks, round_half_away, ticks_to_radians


@st.composite
def servos(draw: st.DrawFn, k: int = 3) -> list[ServoSpec]:
    out = []
    for i in range(k):
        tpt = draw(st.sampled_from([4096, 1024, 4000, 303]))
        zero = draw(st.integers(0, tpt - 1))
        out.append(ServoSpec(i + 1, "xm430-w350", tpt, zero, draw(st.sampled_from([1, -1])),
                             0, tpt - 1))
    return out


@given(servos(), st.data())
def test_ticks_radians_ticks_is_exact(specs: list[ServoSpec], data: st.DataObject) -> None:
    ticks = np.array([[data.draw(st.integers(s.min_tick, s.max_tick)) for s in specs]
                      for _ in range(5)])
    back = radians_to_ticks(ticks_to_radians(ticks, specs), specs)
    assert back.dtype == np.int64
    np.testing.assert_array_equal(back, ticks)


@given(servos(), st.lists(st.floats(-math.pi, math.pi), min_size=3, max_size=3))
def test_radians_ticks_radians_within_half_a_tick(specs: list[ServoSpec],
                                                   angles: list[float]) -> None:
    q = np.array([angles])
    back = ticks_to_radians(radians_to_ticks(q, specs), specs)
    half = np.array([math.pi / s.ticks_per_turn for s in specs])
    assert (np.abs(back - q) <= half * (1 + 1e-9)).all()


@given(st.floats(-1e6, 1e6))
def test_round_half_away_matches_decimal(x: float) -> None:
    expected = float(Decimal(x).quantize(Decimal(1), rounding=ROUND_HALF_UP))  # away from 0
    assert round_half_away(x) == expected


def test_exact_half_ticks_round_away_from_the_offset() -> None:
    spec = [ServoSpec(1, "xm430-w350", 4096, 2048, 1, 0, 4095),
            ServoSpec(2, "xm430-w350", 4096, 2048, -1, 0, 4095)]
    half = 2 * math.pi / 4096 * 0.5  # exactly half a tick (a power-of-two fraction of 2π)
    ticks = radians_to_ticks([[half, half], [-half, -half], [3 * half, 3 * half]], spec)
    np.testing.assert_array_equal(ticks, [[2049, 2047], [2047, 2049], [2050, 2046]])


def test_direction_mirrors_about_the_zero_offset() -> None:
    plus = [ServoSpec(1, "xm430-w350", 4096, 1000, 1, 0, 4095)]
    minus = [ServoSpec(1, "xm430-w350", 4096, 1000, -1, 0, 4095)]
    q = np.linspace(-2.0, 2.0, 101)[:, None]
    np.testing.assert_array_equal(radians_to_ticks(q, plus) - 1000,
                                  -(radians_to_ticks(q, minus) - 1000))
    np.testing.assert_array_equal(radians_to_ticks([0.0], plus), [1000])


def test_one_dimensional_input_is_one_sample() -> None:
    spec = [ServoSpec(1, "xm430-w350"), ServoSpec(2, "xm430-w350")]
    q = [0.3, -0.2]
    np.testing.assert_array_equal(radians_to_ticks(q, spec), radians_to_ticks([q], spec)[0])


def test_bad_inputs_name_the_field() -> None:
    spec = [ServoSpec(1, "xm430-w350"), ServoSpec(2, "xm430-w350")]
    with pytest.raises(InputError) as info:
        radians_to_ticks(np.zeros((4, 3)), spec)
    assert info.value.field == "angles"
    with pytest.raises(InputError) as info:
        radians_to_ticks([[0.0, np.nan]], spec)
    assert info.value.field == "angles"
    with pytest.raises(InputError) as info:
        ticks_to_radians([[2048.5, 2048]], spec)
    assert info.value.field == "ticks"


@given(servos(), st.integers(1, 40), st.data())
def test_whole_array_ticks_are_the_column_path_s(specs: list[ServoSpec], n: int,
                                                 data: st.DataObject) -> None:
    """A short array is converted whole (servo_units.WHOLE_ROWS): the same ticks, bit for
    bit, as one column at a time, halves between ticks included."""
    import robodcn.servo_units as units

    angle = st.floats(-7.0, 7.0, allow_nan=False)
    q = np.array([[data.draw(angle) for _ in specs] for _ in range(n)])
    halves = np.array([2.0 * math.pi / s.ticks_per_turn for s in specs]) * (
        np.floor(q * [s.ticks_per_turn / (2.0 * math.pi) for s in specs]) + 0.5)
    for x in (q, halves):
        whole = units.ticks_unchecked(x, specs)
        keep, units.WHOLE_ROWS = units.WHOLE_ROWS, 0  # every array by columns
        try:
            columns = units.ticks_unchecked(x, specs)
        finally:
            units.WHOLE_ROWS = keep
        assert whole.dtype == columns.dtype == np.int64
        np.testing.assert_array_equal(whole, columns)
