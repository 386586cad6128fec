"""A move body of one waypoint means "from the present state" (issue 17 §2): ``POST /v1/moves
{"waypoints": [G]}`` (with or without ``replace``) plans from the arm's present joints (a new
move) or from the running move's commanded state (a replacement); a plan body still needs two
waypoints unless it gives a start. On the wire, against the simulated example arm."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from http_helpers import (
    ARM,
    HOME,
    call,
    error_of,
    finished,
    poll_move,
    run_move,
    serving_arm,
    start_move,
)

from robodcn import kinematics, servo_units

OTHER = [0.22, -0.05, 0.3]
LONG = {"waypoints": [HOME, [0.05, 0.25, 1.2]], "duration": 2.0, "rate_hz": 200}


@pytest.fixture
def arm_server() -> Iterator[tuple[Any, Any]]:
    with serving_arm(request_timeout=5.0) as pair:
        yield pair


def _joints_of(sa: Any) -> np.ndarray:
    ticks = [sa.sim.servo(i).present_position for i in ARM.servo_ids]
    return servo_units.ticks_to_radians(np.array([ticks]), ARM.servos)[0]


def _at(sa: Any, pose: list[float], tol: float = 2e-3, settle_s: float = 3.0) -> None:
    """The arm comes to rest at ``pose`` (position within ``tol`` m, θ within 5e-3 rad),
    given ``settle_s`` after its move ended: on a busy machine the last goals reach the
    servos a few periods after the report (the in-position check allows 3 ticks a joint)."""
    deadline = time.monotonic() + settle_s
    while True:
        end = kinematics.fk(ARM.links, _joints_of(sa)[None, :])[0]
        there = np.allclose(end[:2], pose[:2], atol=tol) and \
            math.isclose(kinematics.wrap(end[2] - pose[2]), 0, abs_tol=5e-3)
        if there or time.monotonic() > deadline:
            break
        time.sleep(0.02)
    assert np.allclose(end[:2], pose[:2], atol=tol), (end, pose)
    assert math.isclose(kinematics.wrap(end[2] - pose[2]), 0, abs_tol=5e-3), (end, pose)


def test_a_one_waypoint_move_runs_from_the_present_joints(arm_server: Any) -> None:
    server, sa = arm_server
    present = _joints_of(sa)
    done = run_move(server, {"waypoints": [OTHER], "rate_hz": 100})
    _at(sa, OTHER)
    # planned from the present joints: its first sample is where the arm was, no approach
    status, _, traj = call(server, "GET", f"/v1/moves/{done['id']}/trajectory")
    assert status == 200
    assert np.allclose(traj["joints"][0], present, atol=2e-3), (traj["joints"][0], present)
    assert traj["approach_samples"] == 0
    assert np.allclose(traj["poses"][-1][:2], OTHER[:2], atol=1e-6)
    assert traj["request"]["waypoints"] == [OTHER]
    assert np.allclose(traj["request"]["start_joints"], present, atol=2e-3)


def test_a_one_waypoint_replace_goes_from_the_moving_state_to_its_goal(arm_server: Any
                                                                       ) -> None:
    server, sa = arm_server
    old = start_move(server, LONG, 0.1)
    status, _, new = call(server, "POST", "/v1/moves",
                          {"waypoints": [OTHER], "rate_hz": 200, "replace": True})
    assert status == 202, new
    assert new["id"] != old["id"]
    status, _, before = call(server, "GET", f"/v1/moves/{old['id']}")
    assert before["status"] == "replaced", before
    done = poll_move(server, new["id"], finished)
    assert done["status"] in ("done", "degraded"), done
    _at(sa, OTHER)


def test_a_one_waypoint_replace_with_nothing_running_starts_from_the_present(
        arm_server: Any) -> None:
    server, sa = arm_server
    run_move(server, {"waypoints": [OTHER], "rate_hz": 100, "replace": True})
    _at(sa, OTHER)


@pytest.mark.parametrize(("extra", "field"), [
    ({"method": "bogus"}, "method"),              # a value: refused before the bus
    ({"beta": [1.0, 1.0]}, "beta"),               # one segment from the present, not two
    ({"start_joints": [0, 0, 0]}, "start_joints"),  # a move starts where the arm is
    ({"duration": -1}, "duration"),
    ({"payload_kg": -0.5}, "payload_kg"),
])
def test_a_bad_one_waypoint_body_is_422_naming_the_field(arm_server: Any,
                                                        extra: dict[str, Any],
                                                        field: str) -> None:
    server, _ = arm_server
    status, _, body = call(server, "POST", "/v1/moves", {"waypoints": [OTHER], **extra})
    assert status == 422, body
    assert error_of(body)["field"].split("[")[0] == field, body
    status, _, health = call(server, "GET", "/healthz")
    assert status == 200 and health["moving"] is False


def test_a_plan_of_one_waypoint_still_needs_a_start(arm_server: Any) -> None:
    server, sa = arm_server
    status, _, body = call(server, "POST", "/v1/trajectories", {"waypoints": [OTHER]})
    assert status == 422 and error_of(body)["field"] == "waypoints", body
    present = _joints_of(sa).tolist()
    status, _, traj = call(server, "POST", "/v1/trajectories",
                           {"waypoints": [OTHER], "start_joints": present})
    assert status == 200, traj
    assert np.allclose(traj["joints"][0], present, atol=1e-9)


def test_the_schema_takes_one_waypoint_in_a_move(arm_server: Any) -> None:
    server, _ = arm_server
    status, _, doc = call(server, "GET", "/openapi.json")
    assert status == 200
    schemas = doc["components"]["schemas"]
    planned = schemas["MoveBody"]["anyOf"][0]
    assert planned["properties"]["waypoints"]["minItems"] == 1
    assert "present" in planned["properties"]["waypoints"]["description"]
    # the plan body takes one too, with a start (the contract's cross-field rule)
    assert schemas["PlanBody"]["properties"]["waypoints"]["minItems"] == 1
