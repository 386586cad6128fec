"""A blend's path depends on its waypoints, method and the arm, never on the timing: the
duration, the rate and the profile trace one tool path (issue 27 §1)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from planner_helpers import distance_to_polyline

from robodcn.contract.request import PlanRequest
from robodcn.planner import plan
from robodcn.planner.blend_choice import stops_beat_blend
from robodcn.workflow import resolve_arm

ARM = resolve_arm("arm3r")
D = math.radians
#: the issue's case (a sharp via: stopping there is faster) and a gentle one (the blend is)
CASES = {
    "sharp": [(0.30, 0.05, D(15)), (0.16, 0.12, D(-30)), (0.12, 0.26, D(60))],
    "gentle": [(0.30, 0.05, D(20)), (0.24, 0.16, D(40)), (0.12, 0.26, D(60))],
}
TIMINGS = [dict(), dict(profile="quintic"), dict(profile="quintic", duration=3.0),
           dict(profile="optimal", duration=3.0), dict(profile="trapezoid"),
           dict(rate_hz=100.0), dict(profile="trapezoid", duration=4.0, rate_hz=1000.0)]


def _tool_points(waypoints, **timing) -> np.ndarray:
    kw = {"rate_hz": 500.0, **timing}
    traj = plan(ARM, waypoints, method="dlb", blend=True, **kw)
    return np.asarray(traj.poses)[:, :2]


@pytest.mark.parametrize("case", CASES)
def test_every_timing_traces_the_same_tool_path(case: str) -> None:
    waypoints = CASES[case]
    # the reference: slow and dense (0.1 mm between samples: chord error ≪ 1e-7 m)
    reference = _tool_points(waypoints, profile="quintic", duration=8.0, rate_hz=1000.0)
    for timing in TIMINGS:
        off = distance_to_polyline(_tool_points(waypoints, **timing), reference)
        assert off.max() < 2e-6, (timing, off.max())


def test_both_geometries_occur() -> None:
    """The cases above cover a blend that keeps its curve and one that stops at the via."""
    decided = {name: stops_beat_blend(PlanRequest(arm=ARM, waypoints=w, method="dlb",
                                                  blend=True))
               for name, w in CASES.items()}
    assert decided == {"sharp": True, "gentle": False}


def test_a_blend_is_never_slower_than_stopping() -> None:
    for waypoints in CASES.values():
        blended = plan(ARM, waypoints, method="dlb", blend=True, rate_hz=500.0)
        stopped = plan(ARM, waypoints, method="dlb", blend=False, rate_hz=500.0)
        assert blended.duration <= stopped.duration + 1e-9
