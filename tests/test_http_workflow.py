"""Issue 12 over HTTP: torque and reboot, moves of a given trajectory (Trajectory JSON or
ROS JointTrajectory JSON), and what a move planned and measured — against the simulated arm
(the real controller, bus and streamer)."""

from __future__ import annotations

import csv
import io
import json
from typing import Any

import numpy as np
import pytest
from conftest import settled
from http_helpers import (
    ARM,
    HOME,
    TARGET,
    call,
    error_of,
    run_move,
)

from robodcn import servo_units
from robodcn.http import openapi

pytest_plugins = ["http_helpers"]     # fixtures: arm_server


def torque_of(sa: Any) -> list[bool]:
    return [sa.sim.servo(i).torque_enabled for i in ARM.servo_ids]


def present_joints(sa: Any) -> np.ndarray:
    ticks = np.array([[sa.sim.servo(i).present_position for i in ARM.servo_ids]])
    return servo_units.ticks_to_radians(ticks, ARM.servos)[0]


# -- torque and reboot ----------------------------------------------------------------------------

def test_torque_off_and_on_for_all_and_one_joint(arm_server: Any) -> None:
    server, sa = arm_server
    status, _, body = call(server, "POST", "/v1/torque", {"on": False})
    assert status == 200 and body == {"on": False, "joint": None, "lowered": False,
                                      "hold": None, "servo_ids": list(ARM.servo_ids)}
    assert torque_of(sa) == [False] * ARM.dof
    assert call(server, "GET", "/v1/state")[2]["torque"] is False
    joint = ARM.joint_names[1]
    status, _, body = call(server, "POST", "/v1/torque", {"on": True, "joint": joint})
    assert status == 200 and body["servo_ids"] == [ARM.servo_ids[1]]
    assert torque_of(sa) == [False, True, False]
    status, _, body = call(server, "POST", "/v1/torque", {"on": True})
    assert status == 200 and torque_of(sa) == [True] * ARM.dof
    assert call(server, "GET", "/v1/state")[2]["torque"] is True


@pytest.mark.parametrize(("body", "field"), [
    ({"on": True, "joint": "knee"}, "joint"), ({}, "on"), ({"on": "yes"}, "on"),
    ({"on": True, "speed": 1}, "speed"), ([True], "body")])
def test_bad_torque_bodies_name_their_field(arm_server: Any, body: Any, field: str) -> None:
    server, sa = arm_server
    status, _, answer = call(server, "POST", "/v1/torque", body)
    assert status == 422 and error_of(answer)["field"] == field, answer
    assert torque_of(sa) == [sa.sim.servo(i).torque_enabled for i in ARM.servo_ids]


def test_reboot_clears_hardware_errors(arm_server: Any) -> None:
    server, sa = arm_server
    servo = sa.sim.servo(ARM.servo_ids[0])
    servo.trip(0x20)  # overload
    alerts = call(server, "GET", "/v1/state")[2]["alerts"]
    assert str(ARM.servo_ids[0]) in alerts, alerts
    status, _, body = call(server, "POST", "/v1/reboot", {"joint": ARM.joint_names[0]})
    assert status == 200 and body == {"joint": ARM.joint_names[0], "lowered": False,
                                      "hold": None, "servo_ids": [ARM.servo_ids[0]]}
    assert servo.hardware_error == 0
    assert call(server, "GET", "/v1/state")[2]["alerts"] == {}
    status, _, body = call(server, "POST", "/v1/reboot", {})  # {}: every servo
    assert status == 200 and body["servo_ids"] == list(ARM.servo_ids)
    status, _, body = call(server, "POST", "/v1/reboot", {"joint": "knee"})
    assert status == 422 and error_of(body)["field"] == "joint"


def test_admin_is_refused_while_a_move_runs(arm_server: Any) -> None:
    server, _ = arm_server
    status, _, move = call(server, "POST", "/v1/moves", {"waypoints": [TARGET, HOME],
                                                         "duration": 3.0})
    assert status == 202, move
    # The arm is not at the first waypoint: the plan opens with an approach, reported.
    assert move["approach"]["samples"] > 0, move
    try:
        for path, body in (("/v1/torque", {"on": False}), ("/v1/reboot", {})):
            status, _, answer = call(server, "POST", path, body)
            assert status == 409 and error_of(answer)["code"] == "busy", answer
    finally:
        call(server, "POST", "/v1/stop")


# -- moves of a given trajectory, and what a move planned and measured ----------------------------

def test_a_saved_trajectory_plays_and_is_recorded(arm_server: Any) -> None:
    server, sa = arm_server
    start = present_joints(sa).tolist()
    status, _, planned = call(server, "POST", "/v1/trajectories", {
        "waypoints": [HOME, TARGET], "duration": 0.6, "rate_hz": 100, "start_joints": start})
    assert status == 200, planned
    done = run_move(server, {"trajectory": planned})
    status, _, played = call(server, "GET", f"/v1/moves/{done['id']}/trajectory")
    assert status == 200
    # Played as saved: its samples at the end of what ran (an approach may come first).
    n = len(planned["t"])
    assert played["ticks"][-n:] == planned["ticks"]
    status, _, rec = call(server, "GET", f"/v1/moves/{done['id']}/record")
    assert status == 200 and rec["move"] == done["id"]
    assert rec["joint_names"] == list(ARM.joint_names) and len(rec["t"]) >= 2
    assert len(rec["t"]) == len(rec["ticks"]) == len(rec["joints"]) == len(rec["poses"])
    # The last row is the move's final read, and the servos come to rest within a tick or
    # two of the last goal. (Not "where they are now": on a loaded host the last samples
    # go out late and the final read catches the arm a few ticks short, still closing in.)
    assert rec["ticks"][-1] == list(done["report"]["final_positions"])
    final = settled(lambda: [sa.sim.servo(i).present_position for i in ARM.servo_ids])
    assert np.abs(np.subtract(final, planned["ticks"][-1])).max() <= 2
    # CSV on request, with the same rows.
    conn_status, headers, text = csv_get(server, f"/v1/moves/{done['id']}/record")
    assert conn_status == 200 and headers["Content-Type"].startswith("text/csv")
    rows = list(csv.reader(io.StringIO(text)))
    # every header names its unit, in plan --format csv's order: t, the pose, joints, ticks
    assert rows[0] == ["t_s", "x_m", "y_m", "theta_rad", *(f"q_{n}_rad" for n in ARM.joint_names),
                       *(f"tick_{i}" for i in ARM.servo_ids)]
    assert len(rows) - 1 == len(rec["t"])
    assert [float(r[0]) for r in rows[1:]] == rec["t"]
    assert [int(v) for v in rows[-1][4 + ARM.dof:4 + 2 * ARM.dof]] == rec["ticks"][-1]


def csv_get(server: Any, path: str) -> tuple[int, dict[str, str], str]:
    import http.client

    conn = http.client.HTTPConnection(*server.server_address[:2], timeout=10)
    try:
        conn.request("GET", path, headers={"Accept": "text/csv"})
        resp = conn.getresponse()
        return resp.status, dict(resp.getheaders()), resp.read().decode()
    finally:
        conn.close()


def joint_trajectory(points: list[list[float]], seconds: list[float],
                     names: list[str] | None = None) -> dict[str, Any]:
    return {"joint_names": names or list(ARM.joint_names), "points": [
        {"positions": p, "time_from_start": {"sec": int(t), "nanosec": int(t % 1 * 1e9)}}
        for p, t in zip(points, seconds, strict=True)]}


def test_a_joint_trajectory_plays_after_an_approach(arm_server: Any) -> None:
    server, sa = arm_server
    here = present_joints(sa)
    goal = (here + np.array([0.3, -0.2, 0.1])).tolist()
    middle = (here + np.array([0.15, -0.1, 0.05])).tolist()
    body = {"trajectory": joint_trajectory([middle, goal], [0.0, 1.0]), "rate_hz": 100}
    done = run_move(server, body)
    _, _, played = call(server, "GET", f"/v1/moves/{done['id']}/trajectory")
    assert played["rate_hz"] == 100
    assert np.allclose(played["joints"][0], here, atol=1e-9)  # approach from the present
    assert np.allclose(played["joints"][-1], goal, atol=1e-9)
    # The approach is reported with its duration, and is the start of what was played.
    approach = done["approach"]
    assert approach["samples"] > 0 and approach["duration_s"] == approach["samples"] / 100
    assert played["approach_samples"] == approach["samples"]
    assert np.allclose(played["joints"][approach["samples"]], middle, atol=1e-9)
    assert np.allclose(present_joints(sa), goal, atol=0.01)


@pytest.mark.parametrize(("trajectory", "field"), [
    ({"joint_names": ["a", "b", "c"], "points": []}, "trajectory.joint_names"),
    ({"nothing": 1}, "trajectory"),
    ({"joint_names": list(ARM.joint_names), "points": [
        {"positions": [0, 0, 0], "time_from_start": {"sec": 0}},
        {"positions": [9.0, 0, 0], "time_from_start": {"sec": 1}}]},
     "trajectory.points[1].positions")])
def test_bad_trajectories_are_refused_before_moving(arm_server: Any, trajectory: Any,
                                                    field: str) -> None:
    server, _ = arm_server
    status, _, body = call(server, "POST", "/v1/moves", {"trajectory": trajectory})
    assert status == 422 and error_of(body)["field"] == field, body
    status, _, body = call(server, "POST", "/v1/moves", {"trajectory": trajectory,
                                                         "waypoints": [HOME, TARGET]})
    assert status == 422 and error_of(body)["field"] in ("waypoints", field), body
    assert call(server, "GET", "/v1/moves/1")[0] == 404  # nothing was started


def test_unknown_moves_have_no_trajectory_or_record(arm_server: Any) -> None:
    server, _ = arm_server
    for path in ("/v1/moves/7/trajectory", "/v1/moves/7/record"):
        status, _, body = call(server, "GET", path)
        assert status == 404 and error_of(body)["field"] == "id"


def test_openapi_documents_the_workflow_routes() -> None:
    doc = json.loads(json.dumps(openapi(ARM)))
    paths = doc["paths"]
    assert {"/v1/torque", "/v1/reboot", "/v1/moves/{id}/trajectory",
            "/v1/moves/{id}/record"} <= set(paths)
    torque = doc["components"]["schemas"]["TorqueBody"]
    assert torque["properties"]["on"]["type"] == "boolean"  # the console detects it
    assert torque["properties"]["joint"]["enum"] == list(ARM.joint_names)
    assert {"409", "422", "503"} <= set(paths["/v1/torque"]["post"]["responses"])
    record = paths["/v1/moves/{id}/record"]["get"]["responses"]
    assert {"application/json", "text/csv"} <= set(record["200"]["content"]) and "404" in record
    move_body = doc["components"]["schemas"]["MoveBody"]["anyOf"]
    assert any("trajectory" in b.get("properties", {}) for b in move_body)
