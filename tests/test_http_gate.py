"""No web page can move the arm (issue 26 §1).

The exact requests a browser sends for a foreign page — a cross-site form with no fields, a
``no-cors`` fetch (text/plain), a body-less POST, a page that re-points its own DNS name at
127.0.0.1 (``Host: evil.example:PORT``) — against the omx on firmware_sim (the service
``serve --sim --arm omx`` runs, in this process), each refused with its status while nothing
moves: the servos' present positions, goals and torque, the gripper, and the moves (a move
under way is neither stopped nor paused, a paused one not resumed). The console's own
requests (same origin, JSON) still act, and ``--token`` guards PUT as it guards POST.
"""

from __future__ import annotations

import http.client
import json
import shutil
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from http_helpers import (
    ARM,
    BODY,
    ROOT,
    address,
    call,
    error_of,
    finished,
    poll_move,
    serving_arm,
    start_move,
)

import robodcn.web
from robodcn.config import load_arm
from robodcn.errors import InputError
from robodcn.http import make_server

OMX = load_arm(ROOT / "configs" / "omx.toml")
STATIC = Path(robodcn.web.__file__).resolve().parent / "static"
GOAL = [0.16, 0.06, 0.20, -0.2]
EVIL = "http://evil.example"
#: What Chromium adds to every request (its user agent and languages).
CHROME = ["User-Agent: Mozilla/5.0 (X11; Linux x86_64) AppleWebKit/537.36 (KHTML, like "
          "Gecko) Chrome/131.0.0.0 Safari/537.36", "Accept-Language: en-US,en;q=0.9",
          "Accept-Encoding: gzip, deflate, br, zstd"]


def form_post(path: str, host: str, origin: str | None = EVIL) -> tuple[list[str], bytes]:
    """``<form method=post action=http://HOST/PATH>`` with no fields, submitted from a page
    of ``origin`` (None: a browser that sends no Origin)."""
    lines = [f"POST {path} HTTP/1.1", f"Host: {host}", "Connection: keep-alive",
             "Content-Length: 0", "Cache-Control: max-age=0"]
    lines += [f"Origin: {origin}"] if origin else []
    lines += ["Content-Type: application/x-www-form-urlencoded",
              "Upgrade-Insecure-Requests: 1", *CHROME[:1],
              "Accept: text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8",
              "Sec-Fetch-Site: cross-site", "Sec-Fetch-Mode: navigate",
              "Sec-Fetch-Dest: document", f"Referer: {origin or EVIL}/", *CHROME[1:]]
    return lines, b""


def no_cors_fetch(method: str, path: str, host: str, body: Any,
                  origin: str | None = EVIL) -> tuple[list[str], bytes]:
    """``fetch(url, {method, mode: "no-cors", body: JSON.stringify(body)})`` from a page of
    ``origin``: a string body goes as text/plain, the only type no-cors allows with it."""
    data = json.dumps(body).encode()
    lines = [f"{method} {path} HTTP/1.1", f"Host: {host}", "Connection: keep-alive",
             f"Content-Length: {len(data)}", *CHROME[:1],
             "Content-Type: text/plain;charset=UTF-8", "Accept: */*"]
    lines += [f"Origin: {origin}"] if origin else []
    lines += ["Sec-Fetch-Site: cross-site", "Sec-Fetch-Mode: no-cors",
              "Sec-Fetch-Dest: empty", f"Referer: {origin or EVIL}/", *CHROME[1:]]
    return lines, data


def same_origin_fetch(method: str, path: str, host: str, body: Any = None,
                      origin: str | None = None) -> tuple[list[str], bytes]:
    """A page's own ``fetch`` (its script's origin is ``http://HOST``): GET without Origin,
    POST/PUT with JSON and Origin, as the console sends them — and as a page whose DNS name
    was rebound to 127.0.0.1 sends them, believing itself same-origin."""
    data = b"" if body is None else json.dumps(body).encode()
    lines = [f"{method} {path} HTTP/1.1", f"Host: {host}", "Connection: keep-alive",
             *CHROME[:1], "Accept: */*"]
    if method != "GET":
        lines += [f"Content-Length: {len(data)}", "Content-Type: application/json",
                  f"Origin: {origin or 'http://' + host}"]
    lines += ["Sec-Fetch-Site: same-origin", "Sec-Fetch-Mode: cors", "Sec-Fetch-Dest: empty",
              f"Referer: http://{host}/", *CHROME[1:]]
    return lines, data


def send(server: Any, request: tuple[list[str], bytes]) -> tuple[int, Any]:
    """Send the request's exact bytes; (status, JSON body)."""
    lines, body = request
    with socket.create_connection(address(server), timeout=10) as sock:
        sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode("latin-1") + body)
        resp = http.client.HTTPResponse(sock)
        resp.begin()
        data = resp.read()
    assert resp.getheader("Content-Type") == "application/json", (lines[0], resp.status)
    return resp.status, json.loads(data)


def own_host(server: Any) -> str:
    return f"127.0.0.1:{address(server)[1]}"


def evil_host(server: Any) -> str:
    return f"evil.example:{address(server)[1]}"


def servos(sa: Any) -> dict[int, tuple[bool, int, int]]:
    """(torque on, goal tick, present tick) of each servo: the joints' and the gripper's."""
    ids = (*OMX.servo_ids, OMX.gripper.servo.id)
    return {i: (sa.sim.servo(i).torque_enabled, sa.sim.servo(i).goal_position,
                sa.sim.servo(i).present_position) for i in ids}


def assert_unmoved(before: dict[int, tuple[bool, int, int]], sa: Any) -> None:
    """Torque and goals as they were; present positions within 3 ticks (a servo holding
    under gravity dithers by a tick; a move or a fall is hundreds)."""
    after = servos(sa)
    for i, (torque, goal, present) in before.items():
        assert after[i][:2] == (torque, goal), (i, before[i], after[i])
        assert abs(after[i][2] - present) <= 3, (i, before[i], after[i])


@pytest.fixture(scope="module")
def omx() -> Iterator[tuple[Any, Any]]:
    """The omx service with torque on (switched on the way the console does): what a
    reboot or a torque off would end."""
    with serving_arm(OMX, request_timeout=10.0) as (server, sa):
        status, _, body = call(server, "POST", "/v1/torque", {"on": True},
                               headers={"Origin": f"http://{own_host(server)}"})
        assert status == 200, body
        yield server, sa


# -- a foreign page's requests -----------------------------------------------------------------

@pytest.mark.parametrize("path", ["/v1/reboot", "/v1/stop", "/v1/pause", "/v1/resume",
                                  "/v1/torque", "/v1/moves", "/v1/gripper"])
def test_a_cross_site_form_changes_nothing(omx: Any, path: str) -> None:
    """A field-less form posted from evil.example: 403 for its Origin; the same form from a
    browser that sends no Origin is 415 (form data, no JSON body). Reboot used to answer 200
    and drop the arm."""
    server, sa = omx
    before, moves = servos(sa), server.controller.moves()
    status, body = send(server, form_post(path, own_host(server)))
    assert status == 403 and error_of(body)["code"] == "origin_not_allowed", body
    assert error_of(body)["field"] == "Origin"
    status, body = send(server, form_post(path, own_host(server), origin=None))
    assert status == 415 and error_of(body)["code"] == "unsupported_media_type", body
    assert_unmoved(before, sa)
    assert server.controller.moves() == moves


@pytest.mark.parametrize(("method", "path", "body"), [
    ("POST", "/v1/moves", {"waypoints": [GOAL]}),
    ("POST", "/v1/torque", {"on": False, "confirm": True}),
    ("POST", "/v1/gripper", {"command": "close"}),
    ("POST", "/v1/reboot", {}),
    ("PUT", "/v1/speed", {"scale": 0.1}),
])
def test_a_no_cors_fetch_changes_nothing(omx: Any, method: str, path: str, body: Any) -> None:
    """``fetch(..., {mode: "no-cors"})`` with a JSON string as text/plain: 403 for its
    Origin, 415 without one."""
    server, sa = omx
    before, moves = servos(sa), server.controller.moves()
    status, reply = send(server, no_cors_fetch(method, path, own_host(server), body))
    assert status == 403 and error_of(reply)["code"] == "origin_not_allowed", reply
    status, reply = send(server, no_cors_fetch(method, path, own_host(server), body,
                                               origin=None))
    assert status == 415 and error_of(reply)["field"] == "Content-Type", reply
    assert_unmoved(before, sa)
    assert server.controller.moves() == moves


@pytest.mark.parametrize("path", ["/v1/reboot", "/v1/stop", "/v1/pause", "/v1/resume"])
def test_a_body_less_post_is_415(omx: Any, path: str) -> None:
    """``curl -X POST URL`` (no body, no type, no length) and a POST with Content-Type:
    application/json but an empty body: an empty body is no longer read as {}."""
    server, sa = omx
    before = servos(sa)
    curl = [f"POST {path} HTTP/1.1", f"Host: {own_host(server)}", "User-Agent: curl/8.5.0",
            "Accept: */*"]
    status, reply = send(server, (curl, b""))
    assert status == 415 and error_of(reply)["field"] == "Content-Type", reply
    status, _, reply = call(server, "POST", path, raw=b"")
    assert status == 415 and error_of(reply)["field"] == "body", reply
    assert "{}" in error_of(reply)["message"]
    assert_unmoved(before, sa)


@pytest.mark.parametrize(("method", "path", "body"), [
    ("GET", "/v1/state", None),
    ("GET", "/v1/arm", None),
    ("GET", "/", None),
    ("POST", "/v1/moves", {"waypoints": [GOAL]}),
    ("POST", "/v1/gripper", {"command": "close"}),
    ("POST", "/v1/torque", {"on": False, "confirm": True}),
])
def test_dns_rebinding_is_refused(omx: Any, method: str, path: str, body: Any) -> None:
    """evil.example re-pointed at 127.0.0.1: its page's requests look same-origin (JSON
    allowed) but name its host. 403 for every one, the state read's answer carries no state,
    and nothing moves."""
    server, sa = omx
    before, moves = servos(sa), server.controller.moves()
    status, reply = send(server, same_origin_fetch(method, path, evil_host(server), body))
    assert status == 403, reply
    error = error_of(reply)
    assert error["code"] == "host_not_allowed" and error["field"] == "Host"
    assert evil_host(server) in error["message"]
    assert_unmoved(before, sa)
    assert server.controller.moves() == moves


def test_a_move_under_way_is_neither_stopped_nor_paused(omx: Any) -> None:
    """The empty POSTs that used to pause or stop the user's move, from a foreign page and
    by rebinding, while it runs; then the user's own pause, which the foreign resume does
    not undo."""
    server, sa = omx
    move = start_move(server, {"waypoints": [GOAL], "duration": 3.0}, 0.05)
    for path in ("/v1/stop", "/v1/pause"):
        assert send(server, form_post(path, own_host(server)))[0] == 403
        assert send(server, form_post(path, own_host(server), origin=None))[0] == 415
        assert send(server, same_origin_fetch("POST", path, evil_host(server), {}))[0] == 403
    status, _, now = call(server, "GET", f"/v1/moves/{move['id']}")
    assert now["status"] == "running" and not now["paused"], now
    own = f"http://{own_host(server)}"
    status, _, paused = call(server, "POST", "/v1/pause", {}, headers={"Origin": own})
    assert status == 200 and paused["paused"], paused
    goals: list[Any] = [None]

    def braked() -> bool:  # the pause brakes along the path, then repeats its last goal
        now = [sa.sim.servo(i).goal_position for i in OMX.servo_ids]
        same, goals[0] = now == goals[0], now
        return same

    deadline = time.monotonic() + 5.0
    while not braked():
        assert time.monotonic() < deadline, "the pause never came to rest"
        time.sleep(0.1)
    assert send(server, form_post("/v1/resume", own_host(server)))[0] == 403
    assert send(server, form_post("/v1/resume", own_host(server), origin=None))[0] == 415
    time.sleep(0.3)
    status, _, still = call(server, "GET", f"/v1/moves/{move['id']}")
    assert still["status"] == "running" and still["paused"], still
    assert [sa.sim.servo(i).goal_position for i in OMX.servo_ids] == goals[0]
    status, _, stopped = call(server, "POST", "/v1/stop", {"mode": "hold"},
                              headers={"Origin": own})
    assert status == 200 and stopped["stopped"], stopped
    poll_move(server, move["id"], finished)


# -- what is still served ----------------------------------------------------------------------

@pytest.mark.parametrize("name", ["127.0.0.1", "localhost", "LocalHost"])
def test_the_console_is_served_by_its_own_names(omx: Any, name: str) -> None:
    """The console page and its calls, as the browser sends them from
    http://NAME:PORT/: GETs without Origin, POSTs with JSON and the page's own Origin."""
    server, _ = omx
    host = f"{name}:{address(server)[1]}"
    lines, _ = same_origin_fetch("GET", "/", host)
    with socket.create_connection(address(server), timeout=10) as sock:
        sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
        resp = http.client.HTTPResponse(sock)
        resp.begin()
        page = resp.read()
    assert resp.status == 200 and b"<html" in page.lower()
    status, state = send(server, same_origin_fetch("GET", "/v1/state", host))
    assert status == 200 and state["torque"] is True, state
    status, stop = send(server, same_origin_fetch("POST", "/v1/stop", host, {}))
    assert status == 200 and stop["stopped"] is False, stop


def test_the_console_files_are_served_to_any_origin(omx: Any) -> None:
    """GET of the console's files is the one thing a foreign Origin may have (a page may
    link them); its API reads are not (the event stream, the state)."""
    server, _ = omx
    conn = http.client.HTTPConnection(*address(server), timeout=10)
    try:
        conn.request("GET", "/static/api.js", headers={"Origin": EVIL})
        resp = conn.getresponse()
        assert resp.status == 200 and b"export" in resp.read()
    finally:
        conn.close()
    for path in ("/v1/state", "/v1/events", "/healthz"):
        status, _, reply = call(server, "GET", path, headers={"Origin": EVIL})
        assert status == 403 and error_of(reply)["code"] == "origin_not_allowed", path


#: Runs the console's own control calls (robodcn/web/static/control.js) in node against the
#: service: the page's fetch on absolute URLs, every request and its answer recorded.
CONSOLE_SCRIPT = """
const [base, dir] = process.argv.slice(2);
const calls = [];
const realFetch = globalThis.fetch;
globalThis.fetch = async (path, opts = {}) => {
  const r = await realFetch(base + path, opts);
  calls.push({ method: opts.method, path, headers: opts.headers || {},
               body: opts.body === undefined ? null : opts.body, status: r.status });
  return r;
};
const element = () => new Proxy({ dataset: {}, style: {}, value: "30",
  classList: { add() {}, remove() {}, toggle() {} } },
  { get: (t, k) => (k in t ? t[k] : () => {}), set: (t, k, v) => { t[k] = v; return true; } });
globalThis.document = { getElementById: element, querySelector: element,
                        querySelectorAll: () => [] };
globalThis.window = { confirm: () => true };
globalThis.sessionStorage = { getItem: () => null, setItem() {}, removeItem() {} };
const { S } = await import(dir + "/state.js");
const control = await import(dir + "/control.js");
S.features = { smoothStop: "smooth", holdStop: "hold", speed: "scale", torque: "on",
               torqueConfirm: "confirm" };
await control.stop("smooth");
await control.stop("hold");
S.features.smoothStop = null;          // a service without stop modes: a body-less stop
await control.stop("smooth");
await control.post("/v1/pause", {});
await control.post("/v1/resume", {});
control.setSpeed(0.5);
await new Promise((done) => setTimeout(done, 300));
await control.torque(true);
await control.gripper("open");
process.stdout.write(JSON.stringify(calls));
"""


@pytest.mark.skipif(shutil.which("node") is None, reason="needs node to run the page's module")
def test_the_console_sends_json_on_every_control_call(omx: Any, tmp_path: Any) -> None:
    """The console's control calls, run by node from the page's own modules against the
    service: each carries Content-Type application/json and a JSON object body ({} for a
    stop without a mode), and none is refused by the gate (no 403, 411 or 415)."""
    server, _ = omx
    script = tmp_path / "console_calls.mjs"
    script.write_text(CONSOLE_SCRIPT)
    out = subprocess.run(["node", str(script), f"http://{own_host(server)}",
                          STATIC.as_uri()], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    calls = json.loads(out.stdout)
    assert [(c["method"], c["path"]) for c in calls] == [
        ("POST", "/v1/stop"), ("POST", "/v1/stop"), ("POST", "/v1/stop"),
        ("POST", "/v1/pause"), ("POST", "/v1/resume"), ("PUT", "/v1/speed"),
        ("POST", "/v1/torque"), ("POST", "/v1/gripper")], calls
    for call_ in calls:
        assert call_["headers"].get("Content-Type") == "application/json", call_
        assert isinstance(json.loads(call_["body"]), dict), call_
        assert call_["status"] not in (403, 411, 415), call_
    assert json.loads(calls[2]["body"]) == {}
    # nothing ran: the stops answer 200, pause/resume/speed 409; torque and gripper act
    assert [c["status"] for c in calls] == [200, 200, 200, 409, 409, 409, 200, 200], calls


def test_allow_host_serves_another_name() -> None:
    """``--allow-host robot.local``: Host robot.local:PORT and Origin http://robot.local:PORT
    are served, evil.example still is not; an IPv6 loopback Host is served too."""
    with serving_arm(ARM, allow_hosts=("robot.local",)) as (server, _):
        port = address(server)[1]
        status, _ = send(server, same_origin_fetch("GET", "/healthz", f"robot.local:{port}"))
        assert status == 200
        status, stop = send(server, same_origin_fetch("POST", "/v1/stop",
                                                      f"robot.local:{port}", {}))
        assert status == 200 and stop["stopped"] is False
        assert send(server, same_origin_fetch("GET", "/healthz", f"[::1]:{port}"))[0] == 200
        assert send(server, same_origin_fetch("GET", "/healthz", evil_host(server)))[0] == 403
        # The right name on another port is another origin.
        assert send(server, same_origin_fetch("GET", "/healthz", f"robot.local:{port + 1}")
                    )[0] == 403
        assert send(server, same_origin_fetch("POST", "/v1/stop", f"robot.local:{port}", {},
                                              origin=f"http://robot.local:{port + 1}")
                    )[0] == 403


@pytest.mark.parametrize("name", ["robot.local:8080", "http://robot.local", "*", "", "a b"])
def test_a_malformed_allow_host_is_refused_before_binding(name: str) -> None:
    with pytest.raises(InputError) as refused:
        make_server(ARM, None, allow_hosts=(name,))
    assert refused.value.field == "allow_host" and repr(name) in refused.value.message


def test_serve_refuses_a_malformed_allow_host_with_exit_2() -> None:
    out = subprocess.run([sys.executable, "-m", "robodcn", "serve", "--plan-only", "--port",
                          "0", "--allow-host", "robot.local:8080"], capture_output=True,
                         text=True, cwd=ROOT, timeout=60)
    assert out.returncode == 2, out.stderr
    assert "allow_host" in out.stderr or "allow-host" in out.stderr, out.stderr


def test_serve_sim_omx_as_the_attacker_finds_it() -> None:
    """``robodcn serve --sim --arm omx --allow-host robot.local``, as a user starts it: the
    cross-site form that dropped the arm (POST /v1/reboot), the no-cors move and the
    rebinding torque off change nothing (the state read before and after is the same, torque
    on); the console's own call and one from the allowed name are served."""
    import re
    import signal
    import types
    import urllib.parse

    proc = subprocess.Popen([sys.executable, "-m", "robodcn", "serve", "--sim", "--arm",
                             "omx", "--port", "0", "--allow-host", "robot.local"],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                            cwd=ROOT)
    try:
        line = proc.stdout.readline()  # type: ignore[union-attr]
        url = re.search(r"http://[\d.]+:\d+", line)
        assert url, line
        port = int(urllib.parse.urlsplit(url.group(0)).port or 0)
        server = types.SimpleNamespace(server_address=("127.0.0.1", port))
        host = own_host(server)
        status, on = send(server, same_origin_fetch("POST", "/v1/torque", host, {"on": True}))
        assert status == 200, on
        status, before = send(server, same_origin_fetch("GET", "/v1/state", host))
        assert status == 200 and before["torque"] is True, before
        assert send(server, form_post("/v1/reboot", host))[0] == 403
        assert send(server, form_post("/v1/reboot", host, origin=None))[0] == 415
        assert send(server, no_cors_fetch("POST", "/v1/moves", host,
                                          {"waypoints": [GOAL]}))[0] == 403
        assert send(server, same_origin_fetch("POST", "/v1/torque", evil_host(server),
                                              {"on": False, "confirm": True}))[0] == 403
        time.sleep(0.5)  # what a fall or a move would have taken by now
        status, after = send(server, same_origin_fetch("GET", "/v1/state", host))
        assert status == 200 and after["torque"] is True and not after["moving"], after
        assert max(abs(a - b) for a, b in zip(after["ticks"], before["ticks"],
                                              strict=True)) <= 3, (before, after)
        status, stop = send(server, same_origin_fetch("POST", "/v1/stop",
                                                      f"robot.local:{port}", {}))
        assert status == 200 and stop["stopped"] is False, stop
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 0


# -- the token ---------------------------------------------------------------------------------

def test_the_token_guards_put_as_it_guards_post() -> None:
    """With a token, ``PUT /v1/speed`` without it used to change the running move."""
    with serving_arm(ARM, token="s3cret") as (server, _):
        bearer = {"Authorization": "Bearer s3cret"}
        status, _, reply = call(server, "POST", "/v1/moves", {**BODY, "duration": 3.0},
                                headers=bearer)
        assert status == 202, reply
        move = poll_move(server, reply["id"], lambda b: b["progress"] > 0.05)
        status, headers, reply = call(server, "PUT", "/v1/speed", {"scale": 0.2})
        assert status == 401 and error_of(reply)["field"] == "Authorization", reply
        assert headers["WWW-Authenticate"] == "Bearer"
        status, _, now = call(server, "GET", f"/v1/moves/{move['id']}")
        assert now["speed_scale"] == 1.0, now
        status, _, reply = call(server, "PUT", "/v1/speed", {"scale": 0.5}, headers=bearer)
        assert status == 200 and reply["speed_scale"] == 0.5, reply
        status, _, stop = call(server, "POST", "/v1/stop", {"mode": "hold"}, headers=bearer)
        assert status == 200 and stop["stopped"], stop
        # The document says so: every changing operation needs the token.
        status, _, doc = call(server, "GET", "/openapi.json")
        assert doc["paths"]["/v1/speed"]["put"]["security"] == [{"bearer": []}]
        assert "401" in doc["paths"]["/v1/speed"]["put"]["responses"]


def test_every_body_is_required_in_the_document(omx: Any) -> None:
    """``/openapi.json`` marks the body of every POST and PUT required."""
    server, _ = omx
    _, _, doc = call(server, "GET", "/openapi.json")
    bodies = {(path, method): op.get("requestBody") for path, ops in doc["paths"].items()
              for method, op in ops.items() if method in ("post", "put", "delete")}
    assert ("/v1/reboot", "post") in bodies and ("/v1/speed", "put") in bodies
    for key, body in bodies.items():
        assert body is not None and body["required"] is True, key
        assert list(body["content"]) == ["application/json"], key
    assert all("403" in op["responses"] for ops in doc["paths"].values()
               for op in ops.values())


def test_a_wildcard_bind_without_allow_host_says_how_to_be_reached(caplog: Any) -> None:
    """``serve --host 0.0.0.0 --token …`` answers only its loopback names: it says so, and
    what to add, when it starts."""
    import logging

    with caplog.at_level(logging.WARNING, logger="robodcn.http"):
        server = make_server(ARM, None, host="0.0.0.0", token="s3cret")
        server.server_close()
    assert any("--allow-host" in r.getMessage() for r in caplog.records), caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="robodcn.http"):
        server = make_server(ARM, None, host="0.0.0.0", token="s3cret",
                             allow_hosts=("robot.local",))
        server.server_close()
    assert not caplog.records, caplog.text
