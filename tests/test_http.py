"""The HTTP service end to end: a real client (http.client, raw sockets) on an ephemeral port.

Plan-only endpoints run against a server without an arm attached; move, stop and state run
against :func:`robodcn.simulated.simulated_arm` in fast timing. Expected values come from the
library itself (the planner, FK, servo units), never from a previous run.
"""

from __future__ import annotations

import functools
import http.client
import json
import math
import re
import socket
import time
from collections.abc import Iterator
from typing import Any

import http_helpers
import numpy as np
import pytest
from http_helpers import (  # arm_server: a fixture
    ARM,
    BODY,
    HOME,
    TARGET,
    address,
    error_of,
    host_line,
    read_all,
    running,
)
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from robodcn import contract, kinematics
from robodcn.config import arm_from_dict
from robodcn.errors import InputError, PlanError
from robodcn.http import MAX_BODY, ROUTES, make_server
from robodcn.http.planbody import parse_plan
from robodcn.planner import MAX_SAMPLES, Trajectory, plan

pytest_plugins = ["http_helpers"]     # fixtures: arm_server


@pytest.fixture(scope="module")
def planner_server() -> Iterator[Any]:
    with running(make_server(ARM, None, request_timeout=1.0)) as server:
        yield server


#: every answer of these tests carries a JSON body
call = functools.partial(http_helpers.call, require_body=True)


# -- plan-only endpoints -----------------------------------------------------------------------

def test_healthz_and_arm(planner_server: Any) -> None:
    status, _, body = call(planner_server, "GET", "/healthz")
    assert status == 200 and body["status"] == "ok" and body["arm"] == ARM.name
    assert body["moving"] is False
    status, _, body = call(planner_server, "GET", "/v1/arm")
    assert status == 200
    assert body["dof"] == ARM.dof and body["servo_ids"] == list(ARM.servo_ids)
    # The config round-trips into the very arm the server holds.
    assert arm_from_dict(body["config"], source=ARM.source) == ARM


def test_plan_matches_the_library(planner_server: Any) -> None:
    body = {"waypoints": [HOME, [0.2, 0.0, -0.4], TARGET], "method": "kenlerp", "beta": 0.5,
            "turn": ["shortest", "ccw"], "duration": "auto", "profile": "trapezoid",
            "rate_hz": 50, "blend": True}
    status, _, data = call(planner_server, "POST", "/v1/trajectories", body)
    assert status == 200
    got = Trajectory.from_json(json.dumps(data), ARM)
    want = plan(ARM, body["waypoints"], method="kenlerp", beta=0.5, turn=["shortest", "ccw"],
                profile="trapezoid", rate_hz=50, blend=True)
    for name in ("t", "poses", "joints", "ticks"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
    assert got.request == want.request


def test_plan_defaults_to_the_arm_rate_and_accepts_start_joints(planner_server: Any) -> None:
    q0 = kinematics.ik(ARM.links, [TARGET], ARM.elbow)[0].tolist()
    status, _, data = call(planner_server, "POST", "/v1/trajectories",
                           {"waypoints": [HOME, TARGET], "start_joints": q0})
    assert status == 200
    assert data["rate_hz"] == ARM.bus.rate_hz
    np.testing.assert_allclose(data["joints"][0], q0)  # the approach starts at start_joints
    want = plan(ARM, [HOME, TARGET], rate_hz=ARM.bus.rate_hz, start_joints=q0)
    assert len(data["t"]) == len(want.t)


def test_unreachable_waypoint_is_named(planner_server: Any) -> None:
    waypoints = [HOME, TARGET, [0.9, 0.0, 0.0]]
    with pytest.raises(PlanError) as local:
        plan(ARM, waypoints)
    status, _, body = call(planner_server, "POST", "/v1/trajectories", {"waypoints": waypoints})
    err = error_of(body)
    assert status == 422 and err["field"] == "waypoints[2]" == local.value.field
    assert err["code"] == local.value.code


def test_infeasible_sample_is_named(planner_server: Any) -> None:
    body = {"waypoints": [HOME, [0.1, 0.2, 2.5]], "duration": 0.05}
    with pytest.raises(PlanError) as local:
        plan(ARM, body["waypoints"], duration=0.05, rate_hz=ARM.bus.rate_hz)
    status, _, data = call(planner_server, "POST", "/v1/trajectories", body)
    err = error_of(data)
    assert status == 422
    assert err["sample"] == local.value.sample and err["joint"] == local.value.joint
    assert math.isclose(err["t"], local.value.t)
    assert f"sample {local.value.sample}" in err["message"]


@pytest.mark.parametrize(("body", "field"), [
    ({"waypoints": [HOME, TARGET], "colour": "red"}, "colour"),
    ({"waypoints": [HOME, TARGET], "method": "slerp"}, "method"),
    ({"waypoints": [HOME, TARGET], "turn": ["ccw", "cw"]}, "turn"),
    ({"waypoints": [HOME, TARGET], "duration": -1}, "duration"),
    ({"waypoints": [HOME, TARGET], "duration": "soon"}, "duration"),
    ({"waypoints": [HOME, TARGET], "rate_hz": 5000}, "rate_hz"),
    ({"waypoints": [HOME, TARGET], "blend": "yes"}, "blend"),
    ({"waypoints": [HOME, TARGET], "beta": "half"}, "beta"),
    ({"waypoints": [HOME, [0.2, 0.1]]}, "waypoints[1]"),
    ({"waypoints": [HOME, TARGET, [0.2, "x", 0]]}, "waypoints[2][1]"),
    ({"waypoints": [HOME, TARGET, [0.2, 1e400, 0]]}, "waypoints[2][1]"),
    ({"waypoints": [HOME]}, "waypoints"),
    ({"method": "sclerp"}, "waypoints"),
    ([HOME, TARGET], "body"),
])
def test_bad_fields_are_422_naming_the_field(planner_server: Any, body: Any, field: str) -> None:
    raw = json.dumps(body).encode().replace(b"Infinity", b"1e400")
    status, _, data = call(planner_server, "POST", "/v1/trajectories", raw=raw)
    err = error_of(data)
    assert status == 422, err
    assert err["field"] == field, err


@pytest.mark.parametrize("raw", [b"{", b'{"waypoints": NaN}', b"\xff\xfe", b'{"a": 1} x'])
def test_malformed_json_is_400(planner_server: Any, raw: bytes) -> None:
    status, _, data = call(planner_server, "POST", "/v1/trajectories", raw=raw)
    assert status == 400 and error_of(data)["code"] == "malformed_json"


@pytest.mark.parametrize("ctype", ["text/plain", "application/x-www-form-urlencoded", ""])
def test_wrong_content_type_is_415(planner_server: Any, ctype: str) -> None:
    status, _, data = call(planner_server, "POST", "/v1/trajectories", BODY,
                           headers={"Content-Type": ctype})
    assert status == 415 and error_of(data)["field"] == "Content-Type"
    # A charset parameter is fine.
    status, _, _ = call(planner_server, "POST", "/v1/trajectories", BODY,
                        headers={"Content-Type": "application/json; charset=utf-8"})
    assert status == 200


def test_oversized_body_is_413_before_it_is_read(planner_server: Any) -> None:
    host, port = address(planner_server)
    with socket.create_connection((host, port), timeout=5) as sock:
        # Headers only: the server must answer from Content-Length without waiting for data.
        sock.sendall(b"POST /v1/trajectories HTTP/1.1\r\nHost: x\r\n"
                     b"Content-Type: application/json\r\n"
                     + f"Content-Length: {MAX_BODY + 1}\r\n\r\n".encode())
        reply = read_all(sock)
    head, _, payload = reply.partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 413")
    assert b"connection: close" in head.lower()
    assert json.loads(payload)["error"]["code"] == "too_large"
    # A client asking first (Expect: 100-continue) is told 413 instead of "continue".
    with socket.create_connection((host, port), timeout=5) as sock:
        sock.sendall(b"POST /v1/trajectories HTTP/1.1\r\nHost: x\r\n"
                     b"Content-Type: application/json\r\nExpect: 100-continue\r\n"
                     + f"Content-Length: {MAX_BODY + 1}\r\n\r\n".encode())
        assert read_all(sock).startswith(b"HTTP/1.1 413")
    # Exactly at the limit is read (and then judged on its content).
    raw = b'{"waypoints": [[0.25, 0.1, 0], [0.18, 0.12, 0.6]]}'
    raw = raw[:-1] + b" " * (MAX_BODY - len(raw)) + b"}"
    status, _, _ = call(planner_server, "POST", "/v1/trajectories", raw=raw)
    assert status == 200


def test_plan_over_a_million_samples_is_413(planner_server: Any) -> None:
    duration = (MAX_SAMPLES + 10) / 1000.0
    with pytest.raises(InputError):
        plan(ARM, [HOME, TARGET], duration=duration, rate_hz=1000)
    status, _, data = call(planner_server, "POST", "/v1/trajectories",
                           {"waypoints": [HOME, TARGET], "duration": duration, "rate_hz": 1000})
    assert status == 413 and error_of(data)["field"] == "duration"


def test_missing_length_is_411(planner_server: Any) -> None:
    host, port = address(planner_server)
    with socket.create_connection((host, port), timeout=5) as sock:
        sock.sendall(b"POST /v1/trajectories HTTP/1.1\r\n" + host_line(planner_server)
                     + b"Content-Type: application/json\r\nConnection: close\r\n\r\n")
        head, _, payload = read_all(sock).partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 411")
    assert json.loads(payload)["error"]["field"] == "Content-Length"


def test_unknown_path_and_method(planner_server: Any) -> None:
    status, _, data = call(planner_server, "GET", "/v2/nothing")
    assert status == 404 and error_of(data)["code"] == "not_found"
    status, headers, data = call(planner_server, "DELETE", "/v1/trajectories")
    assert status == 405 and headers["Allow"] == "POST"
    status, headers, _ = call(planner_server, "POST", "/v1/arm", {})
    assert status == 405 and headers["Allow"] == "GET, HEAD"


def test_move_endpoints_without_an_arm_are_503(planner_server: Any) -> None:
    for method, path, body in (("POST", "/v1/moves", BODY), ("GET", "/v1/state", None),
                               ("GET", "/v1/moves/1", None), ("POST", "/v1/stop", None)):
        status, _, data = call(planner_server, method, path, body)
        assert status == 503 and error_of(data)["code"] == "no_arm"


def test_keep_alive_serves_many_requests_on_one_connection(planner_server: Any) -> None:
    host, port = address(planner_server)
    conn = http.client.HTTPConnection(host, port, timeout=5)
    try:
        for _ in range(3):
            conn.request("POST", "/v1/trajectories", body=json.dumps(BODY),
                         headers={"Content-Type": "application/json"})
            resp = conn.getresponse()
            assert resp.status == 200 and json.loads(resp.read())["rate_hz"] == 100
            conn.request("GET", "/healthz")
            resp = conn.getresponse()
            assert resp.status == 200 and json.loads(resp.read())["status"] == "ok"
    finally:
        conn.close()


def test_slow_client_does_not_block_others_and_times_out(planner_server: Any) -> None:
    host, port = address(planner_server)
    with socket.create_connection((host, port), timeout=5) as slow, \
            socket.create_connection((host, port), timeout=5) as silent:
        # One client stalls mid-body, another never sends a byte.
        slow.sendall(b"POST /v1/trajectories HTTP/1.1\r\nHost: x\r\n"
                     b"Content-Type: application/json\r\nContent-Length: 100\r\n\r\n{\"wa")
        t0 = time.monotonic()
        status, _, _ = call(planner_server, "POST", "/v1/trajectories", BODY)
        assert status == 200
        assert time.monotonic() - t0 < 0.9  # answered before the stalled ones time out
        # The 1 s request deadline: the stalled request gets 408, the silent one is closed.
        for sock, want in ((slow, b"HTTP/1.1 408"), (silent, b"")):
            sock.settimeout(4)
            t1 = time.monotonic()
            assert read_all(sock)[:len(want)] == want
            assert time.monotonic() - t1 < 3


def test_connections_beyond_the_cap_close_the_oldest_waiting_one() -> None:
    with running(make_server(ARM, None, request_timeout=5.0, max_connections=2)) as server:
        idle = [socket.create_connection(address(server), timeout=5) for _ in range(2)]
        try:
            time.sleep(0.2)  # both accepted
            # A newcomer is served; the oldest connection still waiting is closed with 503.
            status, _, _ = call(server, "GET", "/healthz")
            assert status == 200
            head, _, payload = read_all(idle[0]).partition(b"\r\n\r\n")
            assert head.startswith(b"HTTP/1.1 503")
            assert json.loads(payload)["error"]["code"] == "too_many_connections"
        finally:
            for sock in idle:
                sock.close()


# -- any body: a clean answer, never a crash -------------------------------------------------------

_junk = st.recursive(st.none() | st.booleans() | st.integers(-10, 10) | st.text(max_size=5)
                     | st.floats(-1.0, 1.0), lambda inner: st.lists(inner, max_size=3)
                     | st.dictionaries(st.text(max_size=4), inner, max_size=3), max_leaves=8)
# Mostly inside the 3R arm's workspace around home, so that many bodies plan.
_pose = st.tuples(st.floats(0.12, 0.3), st.floats(0.0, 0.2), st.floats(-1.0, 1.0)).map(list)
_field_values = {
    "waypoints": st.lists(_pose, min_size=2, max_size=4) | _junk,
    "method": st.sampled_from(["sclerp", "kenlerp", "seplerp", "dlb", "lerp"]) | _junk,
    "beta": st.floats(-2.0, 2.0, allow_nan=False) | _junk,
    "turn": st.sampled_from(["shortest", "ccw", "cw"]) | _junk,
    "duration": st.floats(-1.0, 3.0, allow_nan=False) | st.just("auto") | _junk,
    "profile": st.sampled_from(["quintic", "trapezoid", "linear"]) | _junk,
    "rate_hz": st.floats(-10.0, 1500.0, allow_nan=False) | _junk,
    "blend": st.booleans() | _junk,
    "start_joints": st.none() | st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3) | _junk,
    "extra": _junk,
}
_good_values = {
    "method": st.sampled_from(["sclerp", "kenlerp", "seplerp"]),
    "beta": st.floats(0.2, 2.0),
    "turn": st.sampled_from(["shortest", "ccw", "cw"]),
    "duration": st.floats(0.5, 3.0) | st.just("auto"),
    "profile": st.sampled_from(["quintic", "trapezoid", "linear"]),
    "rate_hz": st.floats(10.0, 500.0),
    "blend": st.booleans(),
}
_bodies = (st.fixed_dictionaries({"waypoints": st.lists(_pose, min_size=2, max_size=3)},
                                 optional=_good_values)
           | st.fixed_dictionaries({}, optional=_field_values) | _junk)


@settings(max_examples=80, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(body=_bodies)
def test_any_body_gets_a_json_answer_not_a_crash(planner_server: Any, body: Any) -> None:
    status, _, data = call(planner_server, "POST", "/v1/trajectories",
                           raw=json.dumps(body).encode())
    assert status in (200, 413, 422), data
    event(f"status {status}")
    if status == 200:
        traj = Trajectory.from_json(json.dumps(data), ARM)
        assert traj.request is not None
        assert traj.request == parse_plan(ARM, body)
    else:
        err = error_of(data)
        if isinstance(body, dict) and err["field"] is not None:
            # The field named is the body field at fault (or an element of it).
            known = set(body) | set(contract.request_schema()["properties"]) | {"body"}
            assert err["field"] in known or err["field"].split("[")[0] in known


# -- OpenAPI --------------------------------------------------------------------------------------

def test_openapi_matches_the_routes_answered(planner_server: Any) -> None:
    status, _, doc = call(planner_server, "GET", "/openapi.json")
    assert status == 200 and doc["openapi"] == "3.1.0"
    documented = {(path, method.upper()) for path, ops in doc["paths"].items()
                  for method in ops}
    assert documented == {(r.path, r.method) for r in ROUTES}
    for path, ops in doc["paths"].items():
        concrete = path.replace("{id}", "1").replace("{name}", "app.js")
        for method in ("GET", "POST", "PUT", "DELETE", "PATCH"):
            body = {} if method in ("POST", "PUT", "PATCH") else None
            if method == "GET" and "application/json" not in ops.get("get", {}).get(
                    "responses", {}).get("200", {}).get("content", {"application/json": 0}):
                # The console's page and files are not JSON: check the route only.
                conn = http.client.HTTPConnection(*address(planner_server), timeout=10)
                conn.request("GET", concrete)
                status = conn.getresponse().status
                conn.close()
            else:
                status, _, _ = call(planner_server, method, concrete, body)
            if method.lower() in ops:
                assert status not in (404, 405), (method, path)
            else:
                assert status == 405, (method, path)
        for op in ops.values():
            # Every {param} of the path is declared, and nothing else.
            declared = {p["name"] for p in op.get("parameters", []) if p["in"] == "path"}
            assert declared == set(re.findall(r"\{(\w+)\}", path)), path
            for code, response in op["responses"].items():
                if code == "304":  # revalidated console file: no body
                    assert "content" not in response, path
                    continue
                content = response["content"]
                # JSON answers and each event of a stream name their component (OpenAPI
                # 3.1: an event-stream schema is one event's); a page or a CSV is a string.
                for media, body in content.items():
                    if media in ("application/json", "text/event-stream"):
                        ref = body["schema"]["$ref"]
                        assert ref.split("/")[-1] in doc["components"]["schemas"], (path, code)
                    else:
                        assert body["schema"] == {"type": "string"}, (path, code, media)
    ids = [op["operationId"] for ops in doc["paths"].values() for op in ops.values()]
    assert len(ids) == len(set(ids))


def test_openapi_body_schema_is_what_the_parser_accepts(planner_server: Any) -> None:
    _, _, doc = call(planner_server, "GET", "/openapi.json")
    props = doc["components"]["schemas"]["PlanBody"]["properties"]
    assert set(props) == set(contract.request_schema()["properties"])
    # Every documented field is accepted (a valid value of each, all at once).
    body = {"waypoints": [HOME, TARGET], "method": "seplerp", "beta": 1.0, "turn": "ccw",
            "duration": 1.5, "profile": "trapezoid", "rate_hz": 50, "blend": False,
            "start_joints": None, "elbow": None, "start_state": None, "payload_kg": 0.2,
            "tool_speed": 2.0, "tool_angular_speed": 20.0, "tool_acceleration": 50.0}
    assert set(body) == set(props)
    status, _, data = call(planner_server, "POST", "/v1/trajectories", body)
    assert status == 200, data
    # A move body: the plan's fields but start_joints and start_state (the move starts where
    # the arm is), replace and start_at; or a trajectory to play.
    planned, given = doc["components"]["schemas"]["MoveBody"]["anyOf"]
    assert set(planned["properties"]) - {"replace", "start_at"} == set(props) - {
        "start_joints", "start_state"}
    assert set(given["properties"]) == {"trajectory", "rate_hz", "replace", "start_at"}


# -- token ------------------------------------------------------------------------------------

def test_non_loopback_bind_needs_a_token() -> None:
    with pytest.raises(InputError) as exc:
        make_server(ARM, None, host="0.0.0.0", port=0)
    assert exc.value.field == "token"
    with pytest.raises(InputError):
        make_server(ARM, None, host="127.0.0.1", port=0, token="  ")


def test_token_guards_every_post() -> None:
    token = "s3cret-token"
    server = make_server(ARM, None, host="0.0.0.0", port=0, token=token, request_timeout=1.0)
    with running(server):
        for headers in ({}, {"Authorization": "Bearer wrong"}, {"Authorization": token},
                        {"Authorization": f"Basic {token}"}):
            status, resp_headers, data = call(server, "POST", "/v1/trajectories", BODY,
                                              headers=headers)
            assert status == 401 and error_of(data)["code"] == "unauthorized"
            assert resp_headers["WWW-Authenticate"] == "Bearer"
        status, _, _ = call(server, "POST", "/v1/trajectories", BODY,
                            headers={"Authorization": f"Bearer {token}"})
        assert status == 200
        # Stop is a POST too; reads stay open.
        status, _, _ = call(server, "POST", "/v1/stop")
        assert status == 401
        assert call(server, "GET", "/healthz")[0] == 200
        _, _, doc = call(server, "GET", "/openapi.json")
        assert "bearer" in doc["components"]["securitySchemes"]
        assert doc["paths"]["/v1/trajectories"]["post"]["security"] == [{"bearer": []}]
