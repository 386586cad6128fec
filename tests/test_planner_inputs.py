"""Input errors: each names its field; caps, range checks before planning, an immutable
normalised request, β ignored by a method warns."""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

import numpy as np
import pytest
from planner_helpers import (
    ARM3R,
    WAYPOINTS_3R,
    variant,
)

import robodcn
from robodcn.errors import (
    InputError,
    PlanError,
)
from robodcn.planner import PlanRequest, plan

# -- input errors -------------------------------------------------------------------------------

@pytest.mark.parametrize(("kwargs", "field"), [
    ({"waypoints": [[0.25, 0.1, 0.0]]}, "waypoints"),
    ({"waypoints": [[0.25, 0.1], [0.2, 0.1]]}, "waypoints[0]"),
    ({"waypoints": [[0.25, 0.1, 0.0], [0.2, math.nan, 0.0]]}, "waypoints[1][1]"),
    ({"method": "cubic"}, "method"),
    ({"method": ["sclerp"]}, "method"),
    ({"turn": ["shortest", "left"]}, "turn[1]"),
    ({"beta": math.inf}, "beta"),
    ({"rate_hz": 0.5}, "rate_hz"),
    ({"rate_hz": 1001}, "rate_hz"),
    ({"duration": -1.0}, "duration"),
    ({"duration": "fast"}, "duration"),
    ({"duration": 2000.0, "rate_hz": 1000}, "duration"),
    ({"duration": 0.01, "rate_hz": 100}, "duration"),
    ({"profile": "cubic"}, "profile"),
    ({"blend": "yes"}, "blend"),
    ({"start_joints": [0.0, 0.0]}, "start_joints"),
])
def test_bad_requests_name_the_field(kwargs: dict[str, Any], field: str) -> None:
    args = {"waypoints": WAYPOINTS_3R, **kwargs}
    with pytest.raises(InputError) as info:
        plan(ARM3R, **args)
    assert info.value.field == field
    assert not isinstance(info.value, PlanError)


def test_auto_plan_over_the_sample_limit_is_an_input_error() -> None:
    crawl = variant(ARM3R, max_velocity=1e-3, max_acceleration=1e-3)
    with pytest.raises(InputError) as info:
        plan(crawl, WAYPOINTS_3R[:2], profile="quintic", rate_hz=1000)
    assert info.value.field == "duration"


def test_request_is_immutable_and_normalised() -> None:
    req = PlanRequest(arm=ARM3R, waypoints=np.array(WAYPOINTS_3R), method=["sclerp", "dlb"],
                      rate_hz=100)
    assert req.waypoints == tuple(tuple(w) for w in WAYPOINTS_3R)
    assert req.method == ("sclerp", "dlb")
    with pytest.raises(dataclasses.FrozenInstanceError):
        req.rate_hz = 5  # type: ignore[misc]
    assert PlanRequest.from_dict(json.loads(json.dumps(req.to_dict()))) == req


@pytest.mark.parametrize(("kwargs", "field", "cls"), [
    ({"duration": 1e308}, "duration", InputError),
    ({"duration": 1e5, "rate_hz": 1000}, "duration", robodcn.TooLargeError
     if hasattr(robodcn, "TooLargeError") else InputError),
    ({"start_joints": [0.0, 3.0, 0.0]}, "start_joints[1]", InputError),
    ({"start_joints": [1e308, 0.0, 0.0]}, "start_joints[0]", InputError),
    ({"beta": -0.5, "method": "kenlerp"}, "beta", InputError),
])
def test_range_checks_before_planning(kwargs: dict[str, Any], field: str, cls: type) -> None:
    with pytest.raises(cls) as info:
        plan(ARM3R, WAYPOINTS_3R, **kwargs)
    assert info.value.field == field


def test_waypoint_cap_is_checked_first_and_names_waypoints() -> None:
    import time

    from robodcn.contract import MAX_WAYPOINTS
    from robodcn.errors import TooLargeError

    wps = np.tile(WAYPOINTS_3R[:2], (30_000, 1))
    t0 = time.process_time()         # this process's CPU: a busy machine does not count
    with pytest.raises(TooLargeError) as info:
        plan(ARM3R, wps)
    assert time.process_time() - t0 < 1.0
    assert info.value.field == "waypoints" and str(MAX_WAYPOINTS) in str(info.value)


def test_beta_with_a_method_that_ignores_it_warns() -> None:
    from robodcn.errors import BetaIgnoredWarning

    with pytest.warns(BetaIgnoredWarning) as record:
        plan(ARM3R, WAYPOINTS_3R, method="sclerp", beta=0.5)
    assert record[0].message.field == "beta"
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", BetaIgnoredWarning)
        plan(ARM3R, WAYPOINTS_3R, method=["sclerp", "kenlerp"], beta=0.5)
        plan(ARM3R, WAYPOINTS_3R, method="sclerp")
        # β > 1 extrapolates past ScLERP (KenLERP's definition): allowed
        plan(ARM3R, WAYPOINTS_3R, method="kenlerp", beta=1.5)
