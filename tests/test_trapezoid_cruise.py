"""A trapezoid given time to spare cruises; given none it is the limits' own trapezoid."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robodcn.planner import plan
from robodcn.workflow import resolve_arm

ARM = resolve_arm("arm3r")
HOME = ARM.home
TARGET = (0.20, 0.15, math.radians(30))


def _path_speed(duration: float | str, rate: float = 200.0) -> tuple[np.ndarray, float]:
    """|dθ/dt| of the tool: a screw motion turns θ in proportion to the path parameter s,
    so this is the time law's ṡ to scale."""
    traj = plan(ARM, [HOME, TARGET], duration=duration, profile="trapezoid", rate_hz=rate)
    theta = np.asarray(traj.poses)[:, 2]
    return np.abs(np.diff(theta)) * rate, float(traj.duration)


def test_a_fixed_duration_with_time_to_spare_has_a_cruise_phase() -> None:
    speed, total = _path_speed(2.0)
    assert total == pytest.approx(2.0)
    peak = speed.max()
    cruising = speed >= 0.98 * peak
    # ρ = ¼: accelerate for a quarter, cruise for half, decelerate for a quarter (a triangle
    # has its peak at one instant only)
    assert cruising.mean() == pytest.approx(0.5, abs=0.05)
    assert np.all(np.diff(speed[: len(speed) // 5]) >= -1e-9 * peak)   # ramps up first


def test_duration_auto_is_still_the_fastest_trapezoid() -> None:
    _, fastest = _path_speed("auto")
    _, spare = _path_speed(2.0)
    assert fastest < spare
