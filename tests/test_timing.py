"""Time laws s(τ) and the shortest feasible duration under uniform time scaling."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from robodcn import timing
from robodcn.errors import InputError

TAU = np.linspace(0.0, 1.0, 20001)


@pytest.mark.parametrize("name", timing.UNIFORM_PROFILES)
def test_profiles_go_from_zero_to_one_monotonically(name: str) -> None:
    s = timing.profile(name, TAU)
    assert s[0] == 0.0 and s[-1] == pytest.approx(1.0, abs=1e-15)
    assert (np.diff(s) >= 0).all()


def test_quintic_derivatives_and_peaks() -> None:
    s = timing.quintic(TAU)
    d1, d2 = timing.quintic_derivatives(TAU)
    np.testing.assert_allclose(np.gradient(s, TAU), d1, atol=1e-6)
    np.testing.assert_allclose(np.gradient(d1, TAU, edge_order=2), d2, atol=1e-5)
    assert d1.max() == pytest.approx(timing.QUINTIC_PEAK_VELOCITY, rel=1e-8)
    assert np.abs(d2).max() == pytest.approx(timing.QUINTIC_PEAK_ACCELERATION, rel=1e-6)
    assert d1[0] == d1[-1] == d2[0] == d2[-1] == 0.0


@given(st.floats(0.02, 0.5))
def test_trapezoid_shape(rho: float) -> None:
    s = timing.trapezoid(TAU, rho)
    h = TAU[1]
    v = np.diff(s) / h
    assert v.max() == pytest.approx(1.0 / (1.0 - rho), rel=1e-3)
    acc = np.diff(s, 2) / h**2
    head = TAU[1:-1] < rho - 2 * h
    assert acc[head] == pytest.approx(1.0 / (rho * (1.0 - rho)), rel=1e-6)
    assert np.abs(acc).max() <= 1.0 / (rho * (1.0 - rho)) * (1 + 1e-6)


@given(st.floats(0.01, 10), st.floats(0.05, 5), st.floats(0.05, 50))
def test_trapezoid_min_time_meets_both_limits(distance: float, v_max: float,
                                              a_max: float) -> None:
    total, rho = timing.trapezoid_min_time(distance, v_max, a_max)
    peak_v = distance / (1.0 - rho) / total
    peak_a = distance / (rho * (1.0 - rho)) / total**2
    assert peak_v <= v_max * (1 + 1e-9) and peak_a == pytest.approx(a_max, rel=1e-9)
    if rho < 0.5:
        assert peak_v == pytest.approx(v_max, rel=1e-9)  # cruise at the limit
    # no faster rest-to-rest motion exists: bang-bang with a = a_max is the bound
    assert total >= 2.0 * math.sqrt(distance / a_max) * (1 - 1e-12)


def test_auto_duration_of_a_quintic_line_is_the_textbook_one() -> None:
    delta = np.array([1.0, -2.0, 0.5])
    v = np.array([3.0, 3.0, 1.0])
    a = np.array([20.0, 10.0, 20.0])
    d1, d2 = timing.quintic_derivatives(TAU)
    total = timing.auto_duration(np.outer(d1, delta), np.outer(d2, delta), v, a)
    expected = max(np.max(15 / 8 * np.abs(delta) / v),
                   np.max(np.sqrt(10 / math.sqrt(3) * np.abs(delta) / a)))
    assert total == pytest.approx(expected, rel=1e-6)


def test_auto_duration_with_a_jerk_limit_scales_as_its_cube_root() -> None:
    """Quintic d³s/dτ³ = 60 − 360τ + 360τ² peaks at 60 (τ = 0, 1): T ≥ ∛(60 |Δq| / j)."""
    delta = np.array([1.0, -2.0, 0.5])
    v = np.array([3.0, 3.0, 1.0])
    a = np.array([20.0, 10.0, 20.0])
    d1, d2 = timing.quintic_derivatives(TAU)
    d3 = 60.0 - 360.0 * TAU + 360.0 * TAU ** 2
    free = timing.auto_duration(np.outer(d1, delta), np.outer(d2, delta), v, a)
    j = np.array([20.0, 20.0, math.inf])
    total = timing.auto_duration(np.outer(d1, delta), np.outer(d2, delta), v, a,
                                 np.outer(d3, delta), j)
    assert total == pytest.approx(max(free, (60 * 2.0 / 20.0) ** (1 / 3)), rel=1e-9)
    assert total > free
    loose = timing.auto_duration(np.outer(d1, delta), np.outer(d2, delta), v, a,
                                 np.outer(d3, delta), np.full(3, 1e9))
    assert loose == pytest.approx(free, rel=1e-12)
    with pytest.raises(InputError) as err:
        timing.auto_duration(np.outer(d1, delta), np.outer(d2, delta), v, a, j_max=j)
    assert err.value.field == "j_max"


@given(st.integers(5, 400), st.floats(0.1, 5), st.floats(0.1, 50))
def test_fd_min_duration_is_tight(n: int, v_max: float, a_max: float) -> None:
    q = np.outer(timing.quintic(np.arange(n + 1) / n), [1.3, -0.4])
    limits_v = np.array([v_max, v_max])
    limits_a = np.array([a_max, a_max])
    total = timing.fd_min_duration(q, limits_v, limits_a)

    def worst(duration: float) -> float:
        dt = duration / n
        vel = np.abs(np.diff(q, axis=0)) / dt
        acc = np.abs(np.diff(q, 2, axis=0)) / dt**2
        return max((vel / limits_v).max(), (acc / limits_a).max())

    assert worst(total) <= 1 + 1e-9
    assert worst(0.99 * total) > 1


def test_bad_arguments_are_named() -> None:
    with pytest.raises(InputError) as info:
        timing.profile("cubic", TAU)
    assert info.value.field == "profile"
    with pytest.raises(InputError) as info:
        timing.trapezoid(TAU, 0.7)
    assert info.value.field == "accel_fraction"
    with pytest.raises(InputError) as info:
        timing.quintic([1.5])
    assert info.value.field == "tau"
    with pytest.raises(InputError) as info:
        timing.trapezoid_min_time(1.0, 0.0, 1.0)
    assert info.value.field == "v_max"
