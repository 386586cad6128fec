"""The web console's server side: its assets and the ``GET /v1/events`` stream (no browser).

The event stream runs against :func:`robodcn.simulated.simulated_arm` (the real controller,
bus and streamer) or, for failures that the simulator cannot produce on demand, against a
stand-in controller. The browser itself is tested in tests_browser/ (``make test-browser``).
"""

from __future__ import annotations

import http.client
import json
import re
import socket
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from http_helpers import host_line, running

from robodcn.config import load_arm
from robodcn.errors import CommError
from robodcn.http import make_server
from robodcn.web import assets, events

ROOT = Path(__file__).resolve().parent.parent
ARM = load_arm(ROOT / "configs" / "arm3r.toml")
HOME = list(ARM.home)
TARGET = [0.18, 0.12, 0.6]


@pytest.fixture
def arm_server() -> Iterator[tuple[Any, Any]]:
    from robodcn.controller import ArmController
    from robodcn.simulated import simulated_arm

    with simulated_arm(ARM, timing="fast") as sa:
        # A loaded test machine can stall the streamer past the default 100 ms watchdog.
        controller = ArmController(ARM, sa.bus, execute_options={"watchdog_ms": 1000})
        try:
            with running(make_server(ARM, controller, request_timeout=2.0)) as server:
                yield server, sa
        finally:
            controller.close()


def request(server: Any, method: str, path: str, body: Any = None,
            headers: dict[str, str] | None = None) -> tuple[int, dict[str, str], bytes]:
    conn = http.client.HTTPConnection(*server.server_address[:2], timeout=10)
    try:
        data = None if body is None else json.dumps(body).encode()
        hdrs = {"Content-Type": "application/json"} if data is not None else {}
        conn.request(method, path, body=data, headers={**hdrs, **(headers or {})})
        resp = conn.getresponse()
        return resp.status, dict(resp.getheaders()), resp.read()
    finally:
        conn.close()


class Stream:
    """A plain-socket SSE client: the status, the headers, then parsed events as they come."""

    def __init__(self, server: Any, path: str = "/v1/events") -> None:
        self.sock = socket.create_connection(server.server_address[:2], timeout=5)
        self.sock.sendall(f"GET {path} HTTP/1.1\r\n".encode() + host_line(server) + b"\r\n")
        self.buffer = b""
        self.eof = False
        head = b""
        while b"\r\n\r\n" not in head:
            chunk = self.sock.recv(4096)
            assert chunk, head
            head += chunk
        head, self.buffer = head.split(b"\r\n\r\n", 1)
        lines = head.decode().split("\r\n")
        self.status = int(lines[0].split()[1])
        self.headers = {k.strip().lower(): v.strip()
                        for k, _, v in (line.partition(":") for line in lines[1:])}
        self.comments = 0
        #: every event as received: {"event": name, "data": the data line as sent}
        self.raw: list[dict[str, str]] = []

    def body(self) -> bytes:
        length = int(self.headers["content-length"])
        while len(self.buffer) < length:
            self.buffer += self.sock.recv(4096)
        return self.buffer[:length]

    def _line(self, end: float) -> str | None:
        while b"\n" not in self.buffer:
            remaining = end - time.monotonic()
            if remaining <= 0 or self.eof:
                return None
            self.sock.settimeout(remaining)
            try:
                chunk = self.sock.recv(65536)
            except TimeoutError:
                return None
            if not chunk:
                self.eof = True
                return None
            self.buffer += chunk
        line, self.buffer = self.buffer.split(b"\n", 1)
        return line.decode()

    def events(self, seconds: float) -> Iterator[tuple[str, Any, float]]:
        """(name, data, arrival time) for ``seconds``, or until the server closes."""
        end = time.monotonic() + seconds
        name, data = None, None
        while (line := self._line(end)) is not None:
            if line.startswith(":"):
                self.comments += 1
            elif line.startswith("event: "):
                name = line[7:]
            elif line.startswith("data: "):
                data = json.loads(line[6:])
                self.raw.append({"event": name or "message", "data": line[6:]})
            elif line == "" and name is not None:
                yield name, data, time.monotonic()
                name, data = None, None

    def close(self) -> None:
        self.sock.close()


def wait_for(predicate: Any, timeout: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


# -- assets ---------------------------------------------------------------------------------

def test_assets_are_the_shipped_files() -> None:
    static = ROOT / "robodcn" / "web" / "static"
    for name in ("index.html", "app.js", "style.css"):
        data, ctype = assets.asset(name)
        assert data == (static / name).read_bytes()
        assert ctype.startswith({"html": "text/html", "js": "text/javascript",
                                 "css": "text/css"}[name.rsplit(".", 1)[1]])
    assert assets.asset("/") == assets.asset("index.html")
    for bad in ("../__init__.py", "..", "nope.js", "static/app.js", "%2e%2e"):
        assert assets.asset(bad) is None, bad


def test_every_asset_is_package_data() -> None:
    import fnmatch
    import tomllib

    patterns = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"]["robodcn.web"]
    for path in (ROOT / "robodcn" / "web" / "static").iterdir():
        rel = f"static/{path.name}"
        assert any(fnmatch.fnmatch(rel, p) for p in patterns), rel


def test_page_loads_nothing_from_elsewhere() -> None:
    page = assets.asset("index.html")[0].decode()
    script = assets.asset("app.js")[0].decode()
    urls = re.findall(r'(?:src|href)="([^"]+)"', page)
    assert urls and all(u.startswith("/static/") or u.startswith("data:") for u in urls), urls
    assert not re.search(r"https?://", page + script)
    for testid in ("target-x", "target-y", "target-theta", "method", "preview", "move", "stop",
                   "hold", "pause", "resume", "speed", "arm-canvas", "joints", "move-status",
                   "error"):
        assert f'data-testid="{testid}"' in page, testid


def test_page_and_files_over_http_with_etags() -> None:
    with running(make_server(ARM, None, request_timeout=1.0)) as server:
        status, headers, body = request(server, "GET", "/")
        assert status == 200 and body == assets.asset("index.html")[0]
        assert headers["Content-Type"].startswith("text/html")
        assert "default-src 'self'" in headers["Content-Security-Policy"]
        status, again, body = request(server, "GET", "/", headers={
            "If-None-Match": headers["ETag"]})
        assert status == 304 and body == b"" and again["ETag"] == headers["ETag"]
        status, headers, body = request(server, "GET", "/static/app.js")
        assert status == 200 and headers["Content-Type"].startswith("text/javascript")
        assert body == assets.asset("app.js")[0]
        status, headers, body = request(server, "GET", "/static/missing.js")
        assert status == 404 and json.loads(body)["error"]["field"] == "name"
        # A plan-only server has no arm to stream.
        stream = Stream(server)
        assert stream.status == 503 and json.loads(stream.body())["error"]["code"] == "no_arm"
        stream.close()
        _, _, doc = request(server, "GET", "/openapi.json")
        paths = json.loads(doc)["paths"]
        assert "text/event-stream" in paths["/v1/events"]["get"]["responses"]["200"]["content"]
        assert "text/html" in paths["/"]["get"]["responses"]["200"]["content"]


# -- the event stream -------------------------------------------------------------------------

def test_stream_rates_and_move_status(arm_server: Any) -> None:
    server, _ = arm_server
    stream = Stream(server)
    try:
        assert stream.status == 200
        assert stream.headers["content-type"].startswith("text/event-stream")
        rest = [t for name, _, t in stream.events(2.6) if name == "state"]
        assert len(rest) >= 2, rest  # ≥ 1 Hz at rest
        status, _, body = request(server, "POST", "/v1/moves",
                                  {"waypoints": [HOME, TARGET], "duration": 2.0})
        assert status == 202, body
        move_id = json.loads(body)["id"]
        moving, statuses = [], []
        for name, data, t in stream.events(6.0):
            if name == "move" and data["id"] == move_id:
                statuses.append(data["status"])
                if data["status"] not in ("queued", "running"):
                    break
            if name == "state" and data["moving"]:
                assert data["move_info"]["id"] == move_id
                moving.append(t)
        # done, or degraded: a loaded machine made the stream skip samples (it says so)
        assert statuses[-1] in ("done", "degraded"), statuses
        assert "running" in statuses
        # ≥ 20 state events a second while the move runs (its middle second).
        mid = moving[len(moving) // 2]
        window = [t for t in moving if mid - 0.5 <= t < mid + 0.5]
        assert len(window) >= 20, (len(window), len(moving))
    finally:
        stream.close()


def test_stream_does_not_block_other_requests(arm_server: Any) -> None:
    server, _ = arm_server
    streams = [Stream(server) for _ in range(3)]
    try:
        start = time.monotonic()
        status, _, _ = request(server, "GET", "/healthz")
        assert status == 200 and time.monotonic() - start < 2.0
        # One sampler for all three clients: state reads at the idle rate, not three times it.
        hub = server.events
        before, t0 = hub.samples, time.monotonic()
        time.sleep(1.5)
        reads = hub.samples - before
        assert reads <= (time.monotonic() - t0) * events.IDLE_HZ + 2, reads
    finally:
        for s in streams:
            s.close()


def test_client_cap_is_a_clear_503(arm_server: Any) -> None:
    server, _ = arm_server
    server.events.max_clients = 2
    streams = [Stream(server) for _ in range(2)]
    try:
        assert all(s.status == 200 for s in streams)
        extra = Stream(server)
        assert extra.status == 503
        err = json.loads(extra.body())["error"]
        assert err["code"] == "too_many_clients" and "2" in err["message"]
        extra.close()
    finally:
        for s in streams:
            s.close()
    # Once they have gone, a client is admitted again.
    assert wait_for(lambda: server.events.clients == 0)
    again = Stream(server)
    assert again.status == 200
    again.close()


def test_stream_ends_when_the_client_goes(arm_server: Any) -> None:
    server, _ = arm_server
    hub = server.events
    stream = Stream(server)
    assert next(stream.events(3.0))[0] == "state"
    assert hub.clients == 1 and hub.sampling
    stream.close()
    # Its thread notices the closed socket, leaves, and the sampler stops with the last client.
    assert wait_for(lambda: hub.clients == 0, 3.0)
    assert wait_for(lambda: not hub.sampling, 3.0)


def test_server_close_ends_open_streams(arm_server: Any) -> None:
    server, _ = arm_server
    stream = Stream(server)
    next(stream.events(3.0))
    start = time.monotonic()
    server.events.close()
    for _ in stream.events(3.0):  # what was queued, then the server closes the stream
        pass
    assert stream.eof and time.monotonic() - start < 2.0
    stream.close()


class _FailingController:
    """A controller whose state read is slow, then fails: what a dead bus looks like."""

    def __init__(self, delay: float) -> None:
        self.delay = delay

    def moves(self) -> list[Any]:
        return []

    def move_info(self, move_id: str) -> None:
        return None

    def state(self) -> dict[str, Any]:
        time.sleep(self.delay)
        raise CommError("servo 2 did not answer", field="bus", value=None)


def test_alerts_and_keep_alives_when_the_bus_fails() -> None:
    with running(make_server(ARM, _FailingController(0.8), request_timeout=1.0)) as server:
        server.events.keepalive_s = 0.3
        stream = Stream(server)
        try:
            got = list(stream.events(2.5))
            alerts = [d for name, d, _ in got if name == "alert"]
            assert alerts and alerts[0]["error"]["code"] == CommError.code
            assert "servo 2" in alerts[0]["error"]["message"]
            assert not [1 for name, _, _ in got if name == "state"]
            assert stream.comments >= 2  # keep-alives while the reads hang
        finally:
            stream.close()


# -- every event matches the schema /openapi.json declares for it ------------------------------

def check_against_schema(raw: list[dict[str, str]]) -> set[str]:
    """Validate each event as received against the ``text/event-stream`` schema of
    ``GET /v1/events`` (OpenAPI 3.1: it describes one event, ``{event, data}``) and its
    ``data`` against the ``contentSchema`` of its branch; the event names seen."""
    import jsonschema_rs

    from robodcn.http import openapi

    doc = openapi(ARM)
    content = doc["paths"]["/v1/events"]["get"]["responses"]["200"]["content"]
    declared = content["text/event-stream"]["schema"]
    components = {"components": doc["components"]}
    whole = jsonschema_rs.Draft202012Validator({**declared, **components})
    events_schema = doc["components"]["schemas"]["Events"]
    branches = {b["properties"]["event"]["const"]: b["properties"]["data"]["contentSchema"]
                for b in events_schema["oneOf"]}
    for event in raw:
        whole.validate(event)
        data = jsonschema_rs.Draft202012Validator({**branches[event["event"]], **components})
        data.validate(json.loads(event["data"]))
    return {e["event"] for e in raw}


def test_every_event_matches_its_declared_schema(arm_server: Any) -> None:
    """ST108: the events violated their declared schema (a string, where each SSE event is
    an object {event, data})."""
    server, _ = arm_server
    stream = Stream(server)
    try:
        list(stream.events(0.8))
        status, _, body = request(server, "POST", "/v1/moves",
                                  {"waypoints": [HOME, TARGET], "duration": 1.0})
        assert status == 202, body
        move_id = json.loads(body)["id"]
        for name, data, _ in stream.events(6.0):
            if name == "move" and data["id"] == move_id and data["status"] == "running":
                request(server, "POST", "/v1/stop", {"mode": "hold"})
            if name == "move" and data["status"] not in ("queued", "running"):
                break
        list(stream.events(0.7))
    finally:
        stream.close()
    assert check_against_schema(stream.raw) == {"state", "move"}
    with running(make_server(ARM, _FailingController(0.1), request_timeout=1.0)) as failing:
        stream = Stream(failing)
        try:
            list(stream.events(1.0))
        finally:
            stream.close()
    assert check_against_schema(stream.raw) == {"alert"}


def test_the_schema_check_refuses_an_event_off_its_schema() -> None:
    import jsonschema_rs

    good = {"alerts": {"1": "overload"}, "error": None}
    assert check_against_schema([{"event": "alert", "data": json.dumps(good)}]) == {"alert"}
    for bad in ({"event": "alert", "data": json.dumps({"alerts": {}})},
                {"event": "state", "data": json.dumps(good)},
                {"event": "alert"}):
        with pytest.raises((jsonschema_rs.ValidationError, KeyError)):
            check_against_schema([bad])
