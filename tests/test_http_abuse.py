"""The service under abuse: slow clients, malformed framing, hostile bodies, lost devices,
signals. Each test names the bug it keeps fixed (issue 9 §3)."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from typing import Any

import pytest
from http_helpers import (
    ARM,
    BODY,
    HOME,
    LOADED_MACHINE,
    ROOT,
    TARGET,
    address,
    call,
    error_of,
    exchange,
    finished,
    host_line,
    poll_move,
    read_all,
    running,
    start_move,
)

from robodcn.contract import MAX_WAYPOINTS
from robodcn.errors import InputError
from robodcn.http import ROUTES, ListenError, make_server

pytest_plugins = ["http_helpers"]     # fixtures: abused_server, planner_server


# -- slow clients -----------------------------------------------------------------------------

def test_slowloris_past_the_cap_cannot_delay_a_stop(abused_server: Any) -> None:
    """64 slow clients used to take every thread: 13 of 13 stops got 503, a move ran on."""
    server, _ = abused_server
    move = start_move(server, {**BODY, "duration": 4.0}, 0.02)
    slow = []
    try:
        for _ in range(3 * server.max_per_client):  # past the per-address and total caps
            sock = socket.create_connection(address(server), timeout=5)
            sock.sendall(b"POST /v1/moves HTTP/1.1\r\nHost: x\r\n")
            slow.append(sock)
        for _ in range(2):  # keep trickling header lines, as a slowloris does
            for sock in slow:
                try:
                    sock.sendall(b"X-Slow: 1\r\n")
                except OSError:
                    pass  # closed by the server to admit newer connections
            time.sleep(0.1)
        t0 = time.monotonic()
        status, _, stopped = call(server, "POST", "/v1/stop", timeout=5)
        elapsed = time.monotonic() - t0
        assert status == 200, stopped
        assert elapsed < 1.0, elapsed
        assert stopped["stopped"] is True and stopped["move"] == move["id"]
        final = poll_move(server, move["id"], finished)
        assert final["status"] == "stopped" and final["progress"] < 1.0
        status, _, state = call(server, "GET", "/v1/state", timeout=5)
        assert status == 200 and state["joint_names"] == list(ARM.joint_names)
    finally:
        for sock in slow:
            sock.close()


def test_stop_does_not_wait_behind_slow_state_reads(abused_server: Any) -> None:
    """State reads on a silent bus take seconds each; a stop must not queue behind them."""
    import threading

    server, sa = abused_server
    sa.sim.faults.drop(times=None)
    readers = [threading.Thread(target=call, args=(server, "GET", "/v1/state"),
                                kwargs={"timeout": 30}) for _ in range(4)]
    try:
        for t in readers:
            t.start()
        time.sleep(0.3)  # the reads hold their threads
        t0 = time.monotonic()
        status, _, stopped = call(server, "POST", "/v1/stop", timeout=5)
        assert status == 200 and stopped["stopped"] is False, stopped
        assert time.monotonic() - t0 < 1.0
    finally:
        sa.sim.faults.clear()
        for t in readers:
            t.join(30)


def test_the_request_deadline_is_absolute_not_per_byte(planner_server: Any) -> None:
    """The 10 s timeout restarted on every byte: one header line per 2 s kept a slot forever."""
    with socket.create_connection(address(planner_server), timeout=10) as sock:
        sock.sendall(b"GET /healthz HTTP/1.1\r\n")
        t0 = time.monotonic()
        reply = b""
        while time.monotonic() - t0 < 6:
            try:
                sock.sendall(b"X-Slow: 1\r\n")
            except OSError:
                break
            sock.settimeout(0.25)
            try:
                reply = sock.recv(65536)
            except TimeoutError:
                continue
            break
        elapsed = time.monotonic() - t0
    assert reply.startswith(b"HTTP/1.1 408"), reply
    assert elapsed < planner_server.request_timeout + 1.0


# -- framing ------------------------------------------------------------------------------------

@pytest.mark.parametrize(("data", "status"), [
    (b"GARBAGE\r\n\r\n", b"400"),
    (b"GET /healthz HTTP/2.0\r\nHost: x\r\n\r\n", b"505"),
    (bytes.fromhex("16030100a5010000a10303") + os.urandom(40), b"400"),
    (b"GET /healthz\r\n\r\n", b"400"),
    (b"GET /healthz HTTP/1.1\r\nBad Header\r\n\r\n", b"400"),
], ids=["garbage", "http2", "tls-hello", "http0.9", "bad-header"])
def test_malformed_requests_get_a_status_line(planner_server: Any, data: bytes,
                                               status: bytes) -> None:
    """They used to get a JSON error without a status line."""
    line, body = exchange(planner_server, data)
    assert line.startswith(b"HTTP/1.1 " + status), line
    assert error_of(body)["code"]


def test_http09_never_starts_a_move(abused_server: Any) -> None:
    """``POST /v1/moves`` as HTTP/0.9 with a body used to start a move."""
    server, _ = abused_server
    raw = json.dumps(BODY).encode()
    line, _ = exchange(server, b"POST /v1/moves\r\n" + raw + b"\r\n\r\n")
    assert line.startswith(b"HTTP/1.1 400")
    time.sleep(0.2)
    assert call(server, "GET", "/healthz")[2]["moving"] is False
    assert server.controller.moves() == []


@pytest.mark.parametrize("lengths", [[b"5", b"7"], [b"\xc2\xb9"], [b"\xb9"], [b"+5"],
                                     [b"5, 7"]], ids=["two", "superscript-utf8",
                                                      "superscript-latin1", "sign", "list"])
def test_bad_content_length_is_400(planner_server: Any, lengths: list[bytes]) -> None:
    """Two different Content-Length (first won) and ``¹`` (500) are 400."""
    head = b"POST /v1/trajectories HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
    head += b"".join(b"Content-Length: " + n + b"\r\n" for n in lengths)
    line, body = exchange(planner_server, head + b"\r\n{}")
    assert line.startswith(b"HTTP/1.1 400"), line
    assert error_of(body)["field"] == "Content-Length"


def test_pipelined_requests_are_answered_in_order(planner_server: Any) -> None:
    with socket.create_connection(address(planner_server), timeout=5) as sock:
        host = host_line(planner_server)
        sock.sendall(b"GET /healthz HTTP/1.1\r\n" + host + b"\r\n"
                     + b"GET /healthz HTTP/1.1\r\n" + host + b"\r\n"
                     + b"GET /healthz HTTP/1.1\r\n" + host + b"\r\n"
                     + b"GET /nothing HTTP/1.1\r\n" + host + b"Connection: close\r\n\r\n")
        reply = read_all(sock)
    assert reply.count(b"HTTP/1.1 200") == 3 and reply.count(b"HTTP/1.1 404") == 1


# -- bodies ---------------------------------------------------------------------------------

def test_non_utf8_json_is_refused(planner_server: Any) -> None:
    """A UTF-16 body used to be parsed: JSON over the network is UTF-8 (RFC 8259)."""
    text = json.dumps(BODY)
    for raw in (text.encode("utf-16"), text.encode("utf-16-le"), b"\xef\xbb\xbf" + text.encode()):
        status, _, data = call(planner_server, "POST", "/v1/trajectories", raw=raw)
        assert status == 400 and error_of(data)["code"] == "malformed_json", data
    status, _, data = call(planner_server, "POST", "/v1/trajectories", raw=text.encode(),
                           headers={"Content-Type": "application/json; charset=utf-16"})
    assert status == 415 and error_of(data)["field"] == "Content-Type"


_WP = json.dumps([HOME, TARGET])
_ZEROS = "0" * 400


@pytest.mark.parametrize(("raw", "status", "field"), [
    (b"[" * 1000 + b"]" * 1000, 400, "body"),
    (b'{"waypoints": ' + b"[" * 100 + b"]" * 100 + b"}", 400, "body"),
    (f'{{"waypoints": {_WP}, "beta": 1{_ZEROS}}}'.encode(), 422, "beta"),
    (f'{{"waypoints": {_WP}, "duration": -1{_ZEROS}}}'.encode(), 422, "duration"),
    (f'{{"waypoints": [[1{_ZEROS}, 0, 0], {json.dumps(TARGET)}]}}'.encode(), 422,
     "waypoints[0][0]"),
    (f'{{"waypoints": {_WP}, "start_joints": [1e308, 0, 0]}}'.encode(), 422, "start_joints[0]"),
    (f'{{"waypoints": {_WP}, "rate_hz": 1{_ZEROS}}}'.encode(), 422, "rate_hz"),
], ids=["nested-1000", "nested-waypoints", "huge-int-beta", "huge-int-duration",
        "huge-int-waypoint", "start-joints-1e308", "huge-int-rate"])
def test_hostile_numbers_and_nesting_name_the_field(planner_server: Any, raw: bytes,
                                                     status: int, field: str) -> None:
    """These used to answer 500 (RecursionError, OverflowError)."""
    got, _, data = call(planner_server, "POST", "/v1/trajectories", raw=raw)
    err = error_of(data)
    assert got == status, err
    assert err["field"] == field, err
    assert len(err["message"]) < 400


def test_errors_name_the_right_field(planner_server: Any) -> None:
    """start_joints beyond a limit was reported as waypoints; too many waypoints as duration."""
    beyond = ARM.joints[0].max_angle + 0.05
    status, _, data = call(planner_server, "POST", "/v1/trajectories",
                           {"waypoints": [HOME, TARGET], "start_joints": [beyond, 0, 0]})
    assert status == 422 and error_of(data)["field"] == "start_joints[0]", data
    t0 = time.monotonic()
    status, _, data = call(planner_server, "POST", "/v1/trajectories",
                           {"waypoints": [[0.2, 0.1, 0]] * 20_000})
    # more waypoints than the schema's maxItems: a schema violation (422), the body is
    # within the byte limit (413 is for bodies over it)
    assert status == 422 and error_of(data)["field"] == "waypoints", data
    assert time.monotonic() - t0 < 2.0  # refused before planning (it took 65 s)


def test_waypoints_over_max_items_are_422_and_over_the_byte_limit_413(
        planner_server: Any) -> None:
    """ST201: 1001 waypoints answered 413 where the schema's maxItems makes it a 422."""
    from robodcn.contract import MAX_WAYPOINTS
    from robodcn.http import MAX_BODY, openapi

    declared = openapi(ARM)["components"]["schemas"]["PlanBody"]["properties"]["waypoints"]
    assert declared["maxItems"] == MAX_WAYPOINTS
    body = {"waypoints": [[0.2, 0.1, 0]] * (MAX_WAYPOINTS + 1)}
    assert len(json.dumps(body)) < MAX_BODY
    status, _, data = call(planner_server, "POST", "/v1/trajectories", body)
    assert status == 422 and error_of(data)["field"] == "waypoints", data
    assert str(MAX_WAYPOINTS) in error_of(data)["message"]
    # the most the schema takes is read as usual (an infeasible plan is a 422 too, a plan)
    status, _, data = call(planner_server, "POST", "/v1/trajectories",
                           {"waypoints": [[0.2, 0.1, 0]] * MAX_WAYPOINTS})
    assert status != 413, data
    # over the byte limit: 413, before the body is read
    pad = {"waypoints": [[0.2, 0.1, 0]] * 2, "pad": "x" * MAX_BODY}
    status, _, data = call(planner_server, "POST", "/v1/trajectories", pad)
    assert status == 413 and error_of(data)["code"] == "too_large", data


def test_a_move_over_max_items_is_422(abused_server: Any) -> None:
    from robodcn.contract import MAX_WAYPOINTS

    server, _ = abused_server
    for extra in ({}, {"replace": True}):
        status, _, data = call(server, "POST", "/v1/moves", {
            "waypoints": [[0.2, 0.1, 0]] * (MAX_WAYPOINTS + 1), **extra})
        assert status == 422 and error_of(data)["field"] == "waypoints", data


def test_huge_plans_are_refused_before_planning(planner_server: Any) -> None:
    """``{"duration": 9999}`` used to plan for 8 s and answer 154 MB."""
    t0 = time.monotonic()
    status, _, data = call(planner_server, "POST", "/v1/trajectories",
                           {"waypoints": [HOME, TARGET], "duration": 9999})
    assert status == 413 and error_of(data)["field"] == "duration", data
    assert time.monotonic() - t0 < 1.0


def test_small_plans_stay_fast_while_a_large_one_plans(planner_server: Any) -> None:
    """A large plan held the one planning lock: every other plan waited for it."""
    import threading

    # MAX_WAYPOINTS (1000) waypoints, "auto": about 0.7 s of planning on an idle machine (400
    # took 0.27 s once the planner got faster, and the small plan at 0.2 s came after it).
    big = {"waypoints": [HOME if i % 2 == 0 else TARGET for i in range(MAX_WAYPOINTS)],
           "rate_hz": 100}
    done = threading.Event()
    result: list[int] = []

    def plan_big() -> None:
        result.append(call(planner_server, "POST", "/v1/trajectories", big, timeout=60)[0])
        done.set()

    thread = threading.Thread(target=plan_big)
    thread.start()
    try:
        time.sleep(0.2)  # the large plan is under way
        t0 = time.monotonic()
        status, _, _ = call(planner_server, "POST", "/v1/trajectories", BODY)
        small = time.monotonic() - t0
        big_still_planning = not done.is_set()
    finally:
        thread.join(60)
    assert status == 200 and result == [200]
    assert big_still_planning, "the small plan waited for the large one"
    assert small < 1.0, small


# -- methods ----------------------------------------------------------------------------------

@pytest.mark.parametrize("method", ["TRACE", "OPTIONS", "get", "post", "BREW", "PUT",
                                    "DELETE", "PATCH", "CONNECT"])
def test_undeclared_methods_are_405_with_allow_everywhere(planner_server: Any,
                                                          method: str) -> None:
    """TRACE, OPTIONS, lower-case and unknown methods used to answer 501."""
    for route in ROUTES:
        path = route.path.replace("{id}", "1")
        allowed = [r.method for r in ROUTES if r.regex.match(path)]
        if method in allowed:
            continue
        line, body = exchange(planner_server, f"{method} {path} HTTP/1.1\r\n".encode()
                              + host_line(planner_server) + b"Connection: close\r\n\r\n")
        assert line.startswith(b"HTTP/1.1 405"), (method, path, line)
        assert error_of(body)["code"] == "method_not_allowed"
    status, headers, _ = call(planner_server, "TRACE", "/v1/stop")
    assert status == 405 and headers["Allow"] == "POST"


def test_head_mirrors_get_without_a_body(planner_server: Any) -> None:
    with socket.create_connection(address(planner_server), timeout=5) as sock:
        sock.sendall(b"HEAD /healthz HTTP/1.1\r\n" + host_line(planner_server)
                     + b"Connection: close\r\n\r\n")
        reply = read_all(sock)
    head, _, body = reply.partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 200") and body == b""
    assert b"Content-Length: " in head


# -- token, port --------------------------------------------------------------------------------

@pytest.mark.parametrize("token", ["pässwort", "two words", "tab\there", "x" * 257, ""])
def test_tokens_must_be_visible_ascii(token: str) -> None:
    """A non-ASCII token could never match (headers read as latin-1, compared as UTF-8)."""
    with pytest.raises(InputError) as exc:
        make_server(ARM, None, host="0.0.0.0", port=0, token=token)
    assert exc.value.field == "token" and "visible ASCII" in exc.value.message


def test_serve_on_a_busy_port_exits_6_with_one_line() -> None:
    """It used to exit 4, the code of a servo or bus fault."""
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        with pytest.raises(ListenError) as exc:
            make_server(ARM, None, port=port)
        assert exc.value.exit_code == 6
        proc = subprocess.run([sys.executable, "-m", "robodcn", "serve", "--sim", "--port",
                               str(port), "--arm", str(ROOT / "configs" / "arm3r.toml")],
                              capture_output=True, text=True, timeout=60,
                              env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == 6, proc.stderr
    assert proc.stderr.strip().splitlines() == [
        f"robodcn: cannot listen on 127.0.0.1:{port}: address in use"]


# -- a lost device, a signal --------------------------------------------------------------------

def test_losing_the_device_mid_move_is_a_fault_then_recovers(tmp_path: Any) -> None:
    """firmware_sim killed mid-move: the move crashed, /v1/state and /v1/moves answered 500."""
    from firmware_sim.bus import SimBus
    from robodcn.bus import ServoBus
    from robodcn.controller import ArmController

    link = str(tmp_path / "ttyARM")
    sim = SimBus(ARM.servo_ids, timing="fast", link=link).start()
    bus = ServoBus(link, 1_000_000, servos=ARM.servos).open()
    bus.verify()
    controller = ArmController(ARM, bus, execute_options=LOADED_MACHINE)
    try:
        with running(make_server(ARM, controller, request_timeout=3.0)) as server:
            move = start_move(server, {**BODY, "duration": 3.0}, 0.05)
            sim.close()  # the device is gone
            final = poll_move(server, move["id"], finished, timeout=20)
            assert final["status"] == "fault", final
            assert final["error"]["code"] and final["report"] is not None
            assert final["report"]["samples_sent"] < final["report"]["samples_total"]
            for method, path, body in (("GET", "/v1/state", None),
                                       ("POST", "/v1/moves", BODY)):
                status, _, data = call(server, method, path, body)
                assert status == 503, data
                assert "reopen" in error_of(data)["message"] or \
                    "retries" in error_of(data)["message"]
            # The device comes back (same path): the next request reopens it.
            sim = SimBus(ARM.servo_ids, timing="fast", link=link).start()
            status, _, state = call(server, "GET", "/v1/state")
            assert status == 200 and state["source"] == "bus", state
    finally:
        controller.close()
        bus.close()
        sim.close()


def test_sigterm_mid_move_holds_before_the_server_shuts_down() -> None:
    """SIGTERM let 21 more goals (≈ 200 ms at 100 Hz) go out before the arm held."""
    from firmware_sim.bus import SimBus

    code = ("from robodcn.config import load_arm; from robodcn.http import serve; "
            f"serve(load_arm({str(ROOT / 'configs' / 'arm3r.toml')!r}), port=0, "
            "device=DEVICE, baud=1000000, ready=lambda url: print(url, flush=True))")
    with SimBus(ARM.servo_ids, timing="fast") as sim:
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        env.pop("ROBODCN_TOKEN", None)
        proc = subprocess.Popen([sys.executable, "-c",
                                 code.replace("DEVICE", repr(sim.port_path))],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                                text=True)
        try:
            url = proc.stdout.readline().strip()
            assert url.startswith("http://"), proc.stderr.read()

            class _Server:
                server_address = (url.split(":")[1][2:], int(url.rsplit(":", 1)[1]))

            start_move(_Server, {**BODY, "duration": 5.0}, 0.05)
            sent_at_signal = len(sim.goal_history(ARM.servo_ids[0]))
            proc.send_signal(signal.SIGTERM)
            assert proc.wait(15) == 0, proc.stderr.read()
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        after = len(sim.goal_history(ARM.servo_ids[0])) - sent_at_signal
    # At most a goal in flight and the hold goal, not 200 ms of motion.
    assert after <= 4, after
    assert all(sim.servo(i).torque_enabled for i in ARM.servo_ids)


# -- streaming routes ---------------------------------------------------------------------------

def test_a_streaming_route_outlives_the_deadline_in_its_own_bounded_pool() -> None:
    """The route table can mark a route streaming (the later /v1/events): its answer is not
    cut by the request deadline, and streams beyond their slots are 503, not queued."""
    from robodcn.http.framing import stream_head
    from robodcn.http.routes import Route

    def ticks(server: Any, request: Any, params: dict[str, str]) -> tuple[int, bytes]:
        request.socket.sendall(stream_head())
        for i in range(8):  # 1.6 s: past the 0.5 s request deadline
            if server.stopping:
                break
            request.socket.sendall(f"data: {i}\n\n".encode())
            time.sleep(0.2)
        return 200, b""

    routes = (*ROUTES, Route("GET", "/v1/ticks", "ticks", "test stream", 200, "OpenAPI",
                             pool="stream", media="text/event-stream"))
    server = make_server(ARM, None, request_timeout=0.5, stream_slots=1, routes=routes,
                         operations={"ticks": ticks})
    with running(server):
        with socket.create_connection(address(server), timeout=5) as first:
            first.sendall(b"GET /v1/ticks HTTP/1.1\r\n" + host_line(server) + b"\r\n")
            time.sleep(0.2)
            line, body = exchange(server, b"GET /v1/ticks HTTP/1.1\r\n" + host_line(server)
                                  + b"\r\n")
            assert line.startswith(b"HTTP/1.1 503") and error_of(body)["code"] == "busy"
            assert call(server, "GET", "/healthz")[0] == 200  # others are served meanwhile
            reply = read_all(first)
        assert reply.startswith(b"HTTP/1.1 200") and b"text/event-stream" in reply
        assert reply.count(b"data: ") == 8
        _, _, doc = call(server, "GET", "/openapi.json")
        assert "text/event-stream" in doc["paths"]["/v1/ticks"]["get"]["responses"]["200"][
            "content"]


def test_every_request_is_logged_in_one_line(planner_server: Any, caplog: Any) -> None:
    import logging

    with caplog.at_level(logging.INFO, logger="robodcn.http"):
        call(planner_server, "GET", "/healthz")
        call(planner_server, "TRACE", "/v1/arm")
        call(planner_server, "POST", "/v1/trajectories", BODY)
        time.sleep(0.1)
    lines = [r.getMessage() for r in caplog.records if r.name == "robodcn.http"]
    for method, path, status in (("GET", "/healthz", 200), ("TRACE", "/v1/arm", 405),
                                 ("POST", "/v1/trajectories", 200)):
        found = [x for x in lines if f" {method} {path} {status} " in x]
        assert len(found) == 1, lines
        assert found[0].endswith(" ms") and found[0].startswith("127.0.0.1 ")
