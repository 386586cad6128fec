"""Shared helpers for the HTTP service tests: a server in a thread, one-shot requests and
raw-socket exchanges; fixtures (``arm_server``, ``abused_server``, ``planner_server``) for
``pytest_plugins = ["http_helpers"]``."""

from __future__ import annotations

import contextlib
import http.client
import json
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from robodcn.config import load_arm
from robodcn.http import make_server

ROOT = Path(__file__).resolve().parent.parent
ARM = load_arm(ROOT / "configs" / "arm3r.toml")
HOME = list(ARM.home)
TARGET = [0.18, 0.12, 0.6]
BODY = {"waypoints": [HOME, TARGET], "duration": 0.6, "rate_hz": 100}
#: The simulator shares the process with the tests: a stall of the streaming thread past the
#: default 100 ms Bus Watchdog would stop a move for reasons these tests are not about.
LOADED_MACHINE = {"watchdog_ms": 1000}


@contextlib.contextmanager
def running(server: Any) -> Iterator[Any]:
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05},
                              daemon=True)
    thread.start()
    try:
        yield server
    finally:
        server.shutdown()
        server.server_close()
        thread.join(5)


@contextlib.contextmanager
def serving_arm(arm: Any = ARM, request_timeout: float = 2.0, *, check_sim: bool = True,
                **limits: Any) -> Iterator[tuple[Any, Any]]:
    """A service on a simulated ``arm`` (fast timing) with its controller: (server, the
    simulated arm); ``limits`` go to ``make_server`` (``max_per_client``, …). Unless
    ``check_sim`` is false, the simulator must end without protocol errors."""
    from robodcn.controller import ArmController
    from robodcn.simulated import simulated_arm

    with simulated_arm(arm, timing="fast") as sa:
        controller = ArmController(arm, sa.bus, execute_options=LOADED_MACHINE)
        try:
            with running(make_server(arm, controller, request_timeout=request_timeout,
                                     **limits)) as server:
                yield server, sa
        finally:
            controller.close()
    if check_sim:
        assert not sa.sim.errors, sa.sim.errors


@contextlib.contextmanager
def serving_abused() -> Iterator[tuple[Any, Any]]:
    """:func:`serving_arm` as the abuse tests (test_http_abuse, test_http_races) want it:
    3 s request timeout, 8 connections an address, 16 in all; the simulator's protocol
    errors are not checked (some of those tests lose devices on purpose)."""
    with serving_arm(request_timeout=3.0, check_sim=False, max_per_client=8,
                     max_connections=16) as pair:
        yield pair


@contextlib.contextmanager
def serving_planner(request_timeout: float = 2.0) -> Iterator[Any]:
    """A planner-only service (no arm) in a thread."""
    with running(make_server(ARM, None, request_timeout=request_timeout)) as server:
        yield server


#: :func:`serving_arm` on the example arm as a fixture. Test modules import it to use it.
@pytest.fixture
def arm_server() -> Iterator[tuple[Any, Any]]:
    with serving_arm() as pair:
        yield pair


#: :func:`serving_abused` as a fixture (test_http_abuse, test_http_races).
@pytest.fixture
def abused_server() -> Iterator[tuple[Any, Any]]:
    with serving_abused() as pair:
        yield pair


#: :func:`serving_planner` as a fixture, one server a module.
@pytest.fixture(scope="module")
def planner_server() -> Iterator[Any]:
    with serving_planner() as server:
        yield server


def address(server: Any) -> tuple[str, int]:
    host, port = server.server_address[:2]
    return ("127.0.0.1" if host == "0.0.0.0" else host), port


def host_line(server: Any) -> bytes:
    """The ``Host`` header line a client of ``server`` sends (``Host: 127.0.0.1:PORT``), for
    requests written as raw bytes: the service answers no other (robodcn.http.gate)."""
    return f"Host: {address(server)[0]}:{address(server)[1]}\r\n".encode()


def call(server: Any, method: str, path: str, body: Any = None, *,
         headers: dict[str, str] | None = None, raw: bytes | None = None,
         timeout: float = 10.0, require_body: bool = False) -> tuple[int, dict[str, str], Any]:
    """One request on a fresh connection; the JSON body decoded (None for HEAD, unless
    ``require_body``: then every answer must carry one). A POST/PUT/DELETE without ``body``
    or ``raw`` sends ``{}`` (the service reads no empty body as {})."""
    if body is None and raw is None and method in ("POST", "PUT", "DELETE"):
        body = {}
    conn = http.client.HTTPConnection(*address(server), timeout=timeout)
    try:
        data = raw if raw is not None else (None if body is None else json.dumps(body).encode())
        hdrs = {"Content-Type": "application/json"} if data is not None else {}
        hdrs.update(headers or {})
        conn.request(method, path, body=data, headers=hdrs)
        resp = conn.getresponse()
        payload = resp.read()
        assert resp.getheader("Content-Type") == "application/json"
        assert payload or not require_body, (method, path, resp.status)
        return resp.status, dict(resp.getheaders()), json.loads(payload) if payload else None
    finally:
        conn.close()


def error_of(body: Any) -> dict[str, Any]:
    assert set(body) == {"error"}
    assert {"code", "message", "field"} <= set(body["error"])
    assert body["error"]["message"]
    return body["error"]


def read_all(sock: socket.socket) -> bytes:
    chunks = []
    while True:
        try:
            chunk = sock.recv(65536)
        except (ConnectionResetError, TimeoutError):
            break
        if not chunk:
            break
        chunks.append(chunk)
    return b"".join(chunks)


def exchange(server: Any, data: bytes, timeout: float = 5.0) -> tuple[bytes, Any]:
    """Send raw bytes, read until the server closes: (status line, JSON body)."""
    with socket.create_connection(address(server), timeout=timeout) as sock:
        sock.sendall(data)
        reply = read_all(sock)
    head, _, payload = reply.partition(b"\r\n\r\n")
    return head.split(b"\r\n", 1)[0], json.loads(payload) if payload else None


def poll_move(server: Any, move_id: str, until: Any, timeout: float = 10.0) -> dict[str, Any]:
    """``GET /v1/moves/{move_id}`` until ``until(body)``: that body. A move that failed before
    (its status stays "failed", its progress where it was) fails the test at once, with its
    error, rather than at ``timeout``."""
    deadline = time.monotonic() + timeout
    while True:
        status, _, body = call(server, "GET", f"/v1/moves/{move_id}")
        assert status == 200, body
        if until(body):
            return body
        assert body["status"] != "failed", body["error"]
        assert time.monotonic() < deadline, body
        time.sleep(0.01)


def start_move(server: Any, body: dict[str, Any], progress: float,
               timeout: float = 10.0) -> dict[str, Any]:
    """``POST /v1/moves`` ``body`` (202), then :func:`poll_move` until its progress is past
    ``progress``: the move's body then, a move under way to act on."""
    status, _, reply = call(server, "POST", "/v1/moves", body)
    assert status == 202, reply
    return poll_move(server, reply["id"], lambda b: b["progress"] > progress, timeout)


def run_move(server: Any, body: dict[str, Any], timeout: float = 10.0) -> dict[str, Any]:
    """``POST /v1/moves`` ``body`` (202), then :func:`poll_move` until it has
    :func:`finished`, done or degraded (what a loaded machine may make of a move): the
    move's final body."""
    status, _, reply = call(server, "POST", "/v1/moves", body)
    assert status == 202, reply
    done = poll_move(server, reply["id"], finished, timeout)
    assert done["status"] in ("done", "degraded"), done
    return done


def finished(body: dict[str, Any]) -> bool:
    return body["status"] not in ("queued", "running")
