"""The OpenMANIPULATOR-X over HTTP (issue 18 §1, §4; issue 19): waypoints rows of four numbers
(x, y, z, pitch; m, rad) in /v1/trajectories and /v1/moves, Trajectory poses the same, GET
/v1/arm's pose_axes, payload_kg in plan, move and replace bodies (the arm's by default; the
HTTP and CLI plans agree), POST /v1/gripper and torque off under gravity. Against the packaged
omx on firmware_sim (``serve --sim --arm omx``'s service) and the planar example arm."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from conftest import settled
from http_helpers import (
    ARM,
    ROOT,
    call,
    error_of,
    finished,
    poll_move,
    run_move,
    serving_arm,
    start_move,
)

from robodcn import servo_units
from robodcn.config import load_arm
from robodcn.stream.online.retarget import FIT_SAMPLES
from robodcn.workflow.poses import tool_pose
from robodcn.workflow.record import recording_csv

OMX = load_arm(ROOT / "configs" / "omx.toml")
HOME = list(OMX.home)
GOAL = [0.16, 0.06, 0.20, -0.2]
NEAR = [0.14, -0.04, 0.22, 0.1]


@pytest.fixture(scope="module")
def omx_server() -> Iterator[tuple[Any, Any]]:
    with serving_arm(OMX, request_timeout=10.0) as pair:
        yield pair


def _joints_of(sa: Any) -> np.ndarray:
    """The joints where the arm came to rest: a move is done when its last goal is sent,
    and the simulated servos (real time, gravity) reach it some cycles later."""
    ticks = settled(lambda: [sa.sim.servo(i).present_position for i in OMX.servo_ids])
    return servo_units.ticks_to_radians(np.array([ticks]), OMX.servos)[0]


def _at(sa: Any, pose: list[float], tol: float = 3e-3) -> None:
    end = tool_pose(OMX, _joints_of(sa))
    assert np.allclose(end[:3], pose[:3], atol=tol), (end, pose)
    assert abs(end[3] - pose[3]) < 1e-2, (end, pose)


# -- the arm and its plans ---------------------------------------------------------------------

def test_the_arm_says_its_pose_axes_payload_and_gripper(omx_server: Any) -> None:
    server, _ = omx_server
    status, _, arm = call(server, "GET", "/v1/arm")
    assert status == 200
    assert arm["pose_axes"] == ["x", "y", "z", "pitch"]
    assert arm["payload_kg"] == OMX.payload_kg and arm["gripper"] is True
    status, _, state = call(server, "GET", "/v1/state")
    assert status == 200 and len(state["pose"]) == 4, state
    assert np.allclose(state["pose"], tool_pose(OMX, state["joints"]), atol=1e-9)


def test_a_planar_arm_says_x_y_theta() -> None:
    with serving_arm(ARM) as (server, _):
        status, _, arm = call(server, "GET", "/v1/arm")
        assert status == 200 and arm["pose_axes"] == ["x", "y", "theta"]
        assert arm["gripper"] is False
        status, _, doc = call(server, "GET", "/openapi.json")
        axes = doc["components"]["schemas"]["Arm"]["properties"]["pose_axes"]
        assert {"const": arm["pose_axes"]} in axes["oneOf"]


def test_a_plan_takes_and_gives_four_number_poses(omx_server: Any) -> None:
    server, _ = omx_server
    status, _, traj = call(server, "POST", "/v1/trajectories",
                           {"waypoints": [HOME, GOAL], "rate_hz": 100})
    assert status == 200, traj
    assert traj["pose_keys"] == ["x", "y", "z", "pitch"]
    assert all(len(p) == 4 for p in traj["poses"])
    assert np.allclose(traj["poses"][0], HOME, atol=1e-6)
    assert np.allclose(traj["poses"][-1], GOAL, atol=1e-6)
    assert len(traj["joints"][0]) == 4 and len(traj["ticks"][0]) == 4
    # every pose is the arm's FK of its joints (x, y, z, pitch)
    for q, pose in zip(traj["joints"][::10], traj["poses"][::10], strict=True):
        assert np.allclose(tool_pose(OMX, q), pose, atol=1e-6)
    assert traj["request"]["payload_kg"] == OMX.payload_kg


@pytest.mark.parametrize("row", [[0.16, 0.06, 0.2], [0.16, 0.06, 0.2, 0.0, 1.0]])
def test_a_waypoint_of_another_width_is_422_naming_it(omx_server: Any, row: list[float]
                                                      ) -> None:
    server, _ = omx_server
    for path in ("/v1/trajectories", "/v1/moves"):
        status, _, body = call(server, "POST", path, {"waypoints": [HOME, row]})
        assert status == 422, body
        assert error_of(body)["field"].startswith("waypoints[1]"), body


def test_the_schemas_take_four_numbers_and_a_payload(omx_server: Any) -> None:
    server, _ = omx_server
    status, _, doc = call(server, "GET", "/openapi.json")
    assert status == 200
    schemas = doc["components"]["schemas"]
    for body in (schemas["PlanBody"], schemas["MoveBody"]["anyOf"][0]):
        row = body["properties"]["waypoints"]["items"]
        assert row["minItems"] == row["maxItems"] == 4
        assert body["properties"]["payload_kg"]["default"] == OMX.payload_kg
    assert schemas["MoveBody"]["anyOf"][0]["properties"]["waypoints"]["minItems"] == 1


def test_a_payload_is_planned_with_and_the_default_is_the_arms(omx_server: Any) -> None:
    server, _ = omx_server
    body = {"waypoints": [HOME, GOAL], "rate_hz": 100}
    plans = {}
    for payload in (None, 0.0, 0.5):
        sent = body if payload is None else {**body, "payload_kg": payload}
        status, _, traj = call(server, "POST", "/v1/trajectories", sent)
        assert status == 200, traj
        plans[payload] = traj
    assert plans[None]["request"]["payload_kg"] == OMX.payload_kg
    assert plans[0.5]["request"]["payload_kg"] == 0.5
    # a load is never faster (the torque limits bind sooner, never later)
    assert plans[0.5]["t"][-1] >= plans[0.0]["t"][-1] - 1e-9
    status, _, bad = call(server, "POST", "/v1/trajectories", {**body, "payload_kg": -1})
    assert status == 422 and error_of(bad)["field"] == "payload_kg"


def test_the_http_and_cli_plans_agree(omx_server: Any) -> None:
    server, _ = omx_server
    body = {"waypoints": [HOME, GOAL], "rate_hz": 100, "payload_kg": 0.5}
    status, _, http_plan = call(server, "POST", "/v1/trajectories", body)
    assert status == 200, http_plan
    pose = ",".join
    out = subprocess.run(
        [sys.executable, "-m", "robodcn", "plan", "--arm", "omx", "--format", "json", "-q",
         "--radians", "--from", pose(map(repr, HOME)), "--to", pose(map(repr, GOAL)),
         "--rate", "100", "--payload", "0.5"],
        capture_output=True, text=True, timeout=120, cwd=ROOT, check=False)
    assert out.returncode == 0, out.stderr
    cli_plan = json.loads(out.stdout)
    assert cli_plan["ticks"] == http_plan["ticks"]
    assert np.allclose(cli_plan["t"], http_plan["t"], atol=1e-12)
    assert np.allclose(cli_plan["joints"], http_plan["joints"], atol=1e-9)
    assert np.allclose(cli_plan["poses"], http_plan["poses"], atol=1e-9)
    assert cli_plan["request"]["payload_kg"] == 0.5


# -- moves ---------------------------------------------------------------------------------------

def test_a_move_of_four_number_waypoints_with_a_payload_runs(omx_server: Any) -> None:
    server, sa = omx_server
    status, _, state = call(server, "GET", "/v1/state")
    here = state["pose"]
    # the simulated arm carries nothing: a move planned for no payload reaches its goal
    done = run_move(server, {"waypoints": [here, GOAL], "payload_kg": 0.0}, timeout=20)
    _at(sa, GOAL)
    status, _, traj = call(server, "GET", f"/v1/moves/{done['id']}/trajectory")
    assert traj["request"]["payload_kg"] == 0.0 and len(traj["poses"][0]) == 4
    # a payload is planned with (and compensated for: the unloaded arm is pushed up)
    done = run_move(server, {"waypoints": [GOAL, NEAR], "payload_kg": 0.2}, timeout=20)
    status, _, traj = call(server, "GET", f"/v1/moves/{done['id']}/trajectory")
    assert status == 200 and traj["request"]["payload_kg"] == 0.2


def test_a_one_waypoint_move_on_the_omx(omx_server: Any) -> None:
    server, sa = omx_server
    done = run_move(server, {"waypoints": [HOME], "payload_kg": 0.0}, timeout=20)
    _at(sa, HOME)
    status, _, traj = call(server, "GET", f"/v1/moves/{done['id']}/trajectory")
    assert status == 200
    assert traj["request"]["waypoints"] == [HOME] and traj["approach_samples"] == 0


def test_a_one_waypoint_replace_with_a_payload_on_the_omx(omx_server: Any) -> None:
    server, sa = omx_server
    old = start_move(server, {"waypoints": [GOAL], "duration": 3.0, "payload_kg": 0.0}, 0.1,
                     timeout=20)
    status, _, new = call(server, "POST", "/v1/moves",
                          {"waypoints": [NEAR], "replace": True, "payload_kg": 0.0})
    if status != 202:
        poll_move(server, old["id"], finished, timeout=20)
    assert status == 202, new
    done = poll_move(server, new["id"], finished, timeout=20)
    assert done["status"] in ("done", "degraded"), done
    status, _, before = call(server, "GET", f"/v1/moves/{old['id']}")
    assert before["status"] == "replaced"
    _at(sa, NEAR)
    status, _, traj = call(server, "GET", f"/v1/moves/{new['id']}/trajectory")
    assert traj["request"]["payload_kg"] == 0.0



@pytest.mark.serial  # a switch placed in real time beside the stream
@pytest.mark.parametrize("at", [0.3, 0.55])
def test_a_replacement_to_a_duration_mid_move_runs_that_long(omx_server: Any, at: float
                                                            ) -> None:
    """Retargeted to the far side, high up, with ``duration: 3`` from the middle of a 6 s
    move (the console's omx example): 422 "the re-timed path keeps exceeding a joint limit"
    or 409 busy before (test_retarget_duration_omx has the planning); now accepted and 3 s
    long. A 409 busy ("nothing changed, try again") is tried once more, as a client does."""
    server, sa = omx_server
    far, left = [0.15, -0.10, 0.18, 0.0], [0.02, 0.14, 0.26, 0.349]
    old = start_move(server, {"waypoints": [far], "duration": 6.0}, at, timeout=20)
    for _ in range(2):
        status, _, new = call(server, "POST", "/v1/moves",
                              {"waypoints": [left], "duration": 3.0, "replace": True})
        if status != 409:
            break
        assert new["error"]["code"] == "busy", new
    if status != 202:
        poll_move(server, old["id"], finished, timeout=20)
    assert status == 202, new
    done = poll_move(server, new["id"], finished, timeout=20)
    assert done["status"] in ("done", "degraded"), done
    # the fit's tolerance (FIT_SAMPLES samples), and the duration counts intervals
    assert abs(new["duration"] - 3.0) <= (FIT_SAMPLES + 1) / new["samples"] * 3.0, new
    assert call(server, "GET", f"/v1/moves/{old['id']}")[2]["status"] == "replaced"
    _at(sa, left)

def test_the_record_of_an_omx_move_has_four_number_poses(omx_server: Any) -> None:
    server, _ = omx_server
    status, _, body = call(server, "POST", "/v1/moves", {"waypoints": [NEAR],
                                                          "payload_kg": 0.0})
    assert status == 202, body
    poll_move(server, body["id"], finished, timeout=20)
    status, _, rec = call(server, "GET", f"/v1/moves/{body['id']}/record")
    assert status == 200, rec
    assert rec["poses"] and all(len(p) == 4 for p in rec["poses"])
    assert np.allclose(rec["poses"][-1], tool_pose(OMX, rec["joints"][-1]), atol=1e-9)
    rows = list(zip(rec["t"], rec["ticks"], strict=True))
    header = recording_csv(OMX, rows).splitlines()[0]
    assert header.startswith("t_s,x_m,y_m,z_m,pitch_rad,") and "q_yaw_rad" in header


# -- the gripper ---------------------------------------------------------------------------------

def test_the_gripper_opens_closes_and_takes_a_width(omx_server: Any) -> None:
    server, _ = omx_server
    spec = OMX.gripper
    assert spec is not None
    for sent, width in (({"command": "open"}, spec.open_width),
                        ({"command": "close"}, spec.closed_width),
                        ({"width_m": 0.05}, 0.05)):
        status, _, result = call(server, "POST", "/v1/gripper", sent)
        assert status == 200, result
        assert result["command"] == sent.get("command", "width")
        assert result["settled"] is True and result["blocked"] is False, result
        assert abs(result["goal_width_m"] - width) < 1e-9
        assert abs(result["final_width_m"] - width) < 2e-3, result
        assert abs(result["present_current_a"]) <= result["grip_current_a"] + 0.1


@pytest.mark.parametrize(("sent", "field"), [
    ({"command": "grab"}, "command"),
    ({"command": 1}, "command"),
    ({}, "command"),                                   # neither
    ({"command": "open", "width_m": 0.05}, "command"),  # both
    ({"width_m": 0.5}, "width_m"),                     # outside the stroke
    ({"width_m": "wide"}, "width_m"),
    ({"width_m": True}, "width_m"),
    ({"force": 1}, "force"),
])
def test_a_bad_gripper_body_is_422_naming_the_field(omx_server: Any, sent: dict[str, Any],
                                                    field: str) -> None:
    server, sa = omx_server
    before = len(sa.sim.goal_history(OMX.gripper.servo.id))
    status, _, body = call(server, "POST", "/v1/gripper", sent)
    assert status == 422, body
    assert error_of(body)["field"] == field, body
    assert len(sa.sim.goal_history(OMX.gripper.servo.id)) == before  # nothing was written


def test_the_gripper_is_409_while_a_move_runs(omx_server: Any) -> None:
    server, _ = omx_server
    status, _, move = call(server, "POST", "/v1/moves",
                           {"waypoints": [NEAR], "duration": 2.0, "payload_kg": 0.0})
    assert status == 202, move
    status, _, body = call(server, "POST", "/v1/gripper", {"command": "open"})
    assert status == 409 and error_of(body)["code"] == "busy", body
    poll_move(server, move["id"], finished, timeout=20)


def test_an_arm_without_a_gripper_answers_404_and_the_route_is_documented() -> None:
    with serving_arm(ARM) as (server, _):
        status, _, body = call(server, "POST", "/v1/gripper", {"command": "open"})
        assert status == 404 and error_of(body)["field"] == "gripper", body
    with serving_arm(OMX) as (server, _):
        status, _, doc = call(server, "GET", "/openapi.json")
    op = doc["paths"]["/v1/gripper"]["post"]
    assert {"200", "404", "409", "422"} <= set(op["responses"])
    assert op["requestBody"]["content"]["application/json"]["schema"]["$ref"] == \
        "#/components/schemas/GripperBody"
    props = doc["components"]["schemas"]["GripperBody"]["properties"]
    assert props["command"] == {**props["command"], "type": "string", "enum": ["open", "close"]}
    assert props["width_m"]["type"] == "number"
    assert props["width_m"]["minimum"] == OMX.gripper.closed_width
    assert props["width_m"]["maximum"] == OMX.gripper.open_width
    result = doc["components"]["schemas"]["Gripper"]
    assert {"command", "final_width_m", "blocked", "settled"} <= set(result["required"])


# -- torque off under gravity ------------------------------------------------------------------

def _torque_on(sa: Any) -> list[bool]:
    return [sa.sim.servo(i).torque_enabled for i in OMX.servo_ids]


def test_torque_off_on_the_omx_needs_confirm() -> None:
    with serving_arm(OMX) as (server, sa):
        status, _, body = call(server, "POST", "/v1/torque", {"on": False})
        assert status == 409, body
        error = error_of(body)
        assert error["code"] == "gravity_release" and error["field"] == "confirm", error
        assert "shoulder" in error["message"]
        assert all(_torque_on(sa))                          # nothing switched
        status, _, body = call(server, "POST", "/v1/torque",
                               {"on": False, "joint": "elbow"})
        assert status == 409 and error_of(body)["field"] == "confirm", body
        status, _, body = call(server, "POST", "/v1/torque", {"on": False, "confirm": "yes"})
        assert status == 422 and error_of(body)["field"] == "confirm", body
        # the yaw holds nothing against gravity: no confirmation needed
        status, _, body = call(server, "POST", "/v1/torque", {"on": False, "joint": "yaw"})
        assert status == 200 and body["servo_ids"] == [OMX.servo_ids[0]], body
        status, _, body = call(server, "POST", "/v1/torque", {"on": False, "confirm": True})
        assert status == 200 and body == {"on": False, "joint": None, "lowered": True,
                                          "hold": None, "servo_ids": list(OMX.servo_ids)}, body
        assert not any(_torque_on(sa))
        status, _, body = call(server, "POST", "/v1/torque", {"on": True})
        assert status == 200 and all(_torque_on(sa))
        status, _, doc = call(server, "GET", "/openapi.json")
        confirm = doc["components"]["schemas"]["TorqueBody"]["properties"]["confirm"]
        assert confirm["type"] == "boolean" and "409" in confirm["description"]


def test_torque_off_on_a_horizontal_arm_needs_no_confirm() -> None:
    with serving_arm(ARM) as (server, _):
        status, _, body = call(server, "POST", "/v1/torque", {"on": False})
        assert status == 200 and body["on"] is False, body
