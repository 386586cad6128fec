"""The HTTP trajectory service: stdlib ``ThreadingHTTPServer``, JSON in and out, SI units.

Endpoints (one route table, :data:`ROUTES`, drives both dispatch and ``/openapi.json``)::

    GET  /healthz            liveness, arm name, whether a move runs
    GET  /v1/arm             the arm configuration (SI units)
    POST /v1/trajectories    plan only → 200 Trajectory JSON
    POST /v1/moves           plan and execute → 202 {"id", ...}; 409 while a move runs
    GET  /v1/moves/{id}      status, progress, report
    POST /v1/stop            stop and hold
    GET  /v1/state           present joints, pose, torque, alerts
    GET  /openapi.json       OpenAPI 3.1 document of all of the above

Errors are ``{"error": {"code", "message", "field", ...}}`` with the status of the
:mod:`robodcn.errors` class (``http_status``: 422 input/plan, 409 busy, 503 bus fault) or of
the transport check that failed: 400 malformed JSON, 401 missing/wrong bearer token,
404 unknown path or move, 405 wrong method, 411 no Content-Length, 413 body over 1 MiB
(checked from Content-Length before reading) or a plan over 10⁶ samples, 415 not JSON.

Each connection gets a thread and a socket timeout, so a slow or silent client frees its
thread; beyond 64 open connections new ones get 503 at once, without a thread. Binding a
non-loopback address needs a token; then every POST must carry ``Authorization: Bearer
<token>`` (compared in constant time). Per-request logging goes to the ``robodcn.http``
logger at DEBUG level, never straight to stderr.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hmac
import ipaddress
import json
import logging
import math
import os
import re
import signal
import socket
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import robodcn
from robodcn.config import Arm
from robodcn.errors import BusError, InputError, RobodcnError
from robodcn.interpolate import METHODS
from robodcn.planner import PROFILES, TURNS, PlanRequest, plan_request

log = logging.getLogger("robodcn.http")

#: Largest request body accepted (bytes), checked from Content-Length before reading.
MAX_BODY = 1 << 20
#: Seconds a connection may stay silent (mid-request or idle keep-alive) before it is closed.
REQUEST_TIMEOUT = 10.0
#: Open connections served at once (one thread each); more get 503 at once.
MAX_CONNECTIONS = 64
TOKEN_ENV = "ROBODCN_TOKEN"


# -- request bodies -----------------------------------------------------------------------------

#: Fields of a plan body: name → (JSON schema, description). The body parser accepts exactly
#: these names and the OpenAPI schema is generated from them.
PLAN_FIELDS: dict[str, tuple[dict[str, Any], str]] = {
    "waypoints": ({"type": "array", "minItems": 2,
                   "items": {"type": "array", "minItems": 3, "maxItems": 3,
                             "items": {"type": "number"}}},
                  "Poses [x, y, θ] in metres and radians; at least two."),
    "method": ({"oneOf": [{"enum": list(METHODS)},
                          {"type": "array", "items": {"enum": list(METHODS)}}]},
               "Interpolation method, or one per segment. Default sclerp."),
    "beta": ({"type": "number"}, "KenLERP bias β. Default 1."),
    "turn": ({"oneOf": [{"enum": list(TURNS)},
                        {"type": "array", "items": {"enum": list(TURNS)}}]},
             "Turn direction, or one per segment. Default shortest."),
    "duration": ({"oneOf": [{"type": "number", "exclusiveMinimum": 0}, {"const": "auto"}]},
                 "Total seconds, or \"auto\" (shortest within the joint limits). Default auto."),
    "profile": ({"enum": list(PROFILES)}, "Timing profile. Default quintic."),
    "rate_hz": ({"type": "number", "minimum": 1, "maximum": 1000},
                "Sample rate (Hz). Default: the arm's bus rate."),
    "blend": ({"type": "boolean"},
              "Pass through via points with continuous velocity. Default false."),
    "start_joints": ({"type": ["array", "null"], "items": {"type": "number"}},
                     "Joint angles (rad) to start from; an approach is prepended when they "
                     "differ from the first waypoint's IK. Default: none."),
}
#: A move always starts from the arm's present joints: the streamer supplies start_joints.
MOVE_FIELDS = {k: v for k, v in PLAN_FIELDS.items() if k != "start_joints"}


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _check_waypoints(value: Any) -> None:
    """Name the first malformed waypoint (``waypoints[2]``) before the planner sees it."""
    if not isinstance(value, list):
        raise InputError(f"waypoints must be a list of [x, y, θ] poses, got {value!r}",
                         field="waypoints", value=value)
    if len(value) < 2:
        raise InputError(f"waypoints needs at least 2 poses, got {len(value)}",
                         field="waypoints", value=value)
    for i, pose in enumerate(value):
        if not isinstance(pose, list) or len(pose) != 3:
            raise InputError(f"waypoints[{i}] must be [x, y, θ] (metres, radians), got "
                             f"{pose!r}", field=f"waypoints[{i}]", value=pose)
        for k, v in enumerate(pose):
            if not _is_number(v) or not math.isfinite(v):
                raise InputError(f"waypoints[{i}][{k}] must be a finite number, got {v!r}",
                                 field=f"waypoints[{i}]", value=pose)


def parse_plan_body(arm: Arm, body: Any, fields: dict[str, Any] = PLAN_FIELDS) -> PlanRequest:
    """A JSON body → a validated :class:`PlanRequest` for ``arm``.

    Unknown fields raise InputError naming the field; rate_hz defaults to the arm's bus rate.
    """
    if not isinstance(body, dict):
        raise InputError(f"the body must be a JSON object, got {type(body).__name__}",
                         field="body", value=None)
    for name in body:
        if name not in fields:
            hint = (" (a move starts from the arm's present joints)"
                    if name == "start_joints" else "")
            raise InputError(f"unknown field {name!r}{hint}; allowed: "
                             f"{', '.join(fields)}", field=name, value=body[name])
    if "waypoints" not in body:
        raise InputError("waypoints is required", field="waypoints", value=None)
    _check_waypoints(body["waypoints"])
    args = dict(body)
    args.setdefault("rate_hz", arm.bus.rate_hz)
    for key in ("method", "turn"):
        if isinstance(args.get(key), list):
            args[key] = tuple(args[key])
    return PlanRequest(arm=arm, **args)


# -- the route table ----------------------------------------------------------------------------

@dataclass(frozen=True)
class Route:
    """One endpoint: dispatch key, handler name and what the OpenAPI document says of it."""

    method: str
    path: str                   # OpenAPI template, "{name}" for a path parameter
    name: str                   # operationId and handler ``_op_<name>``
    summary: str
    ok: int                     # success status
    response: str               # component schema of the success body
    body: str | None = None     # component schema of the request body
    errors: tuple[int, ...] = ()

    @property
    def regex(self) -> re.Pattern[str]:
        return re.compile("^" + re.sub(r"\\\{(\w+)\\\}", r"(?P<\1>[^/]+)", re.escape(self.path))
                          + "$")

    @property
    def params(self) -> list[str]:
        return re.findall(r"\{(\w+)\}", self.path)


_BODY_ERRORS = (400, 411, 413, 415, 422)
ROUTES: tuple[Route, ...] = (
    Route("GET", "/healthz", "health", "Liveness: arm name, whether a move runs", 200,
          "Health"),
    Route("GET", "/v1/arm", "arm", "The arm configuration (metres, radians, SI)", 200, "Arm"),
    Route("POST", "/v1/trajectories", "plan", "Plan a trajectory (no motion)", 200,
          "Trajectory", "PlanBody", _BODY_ERRORS),
    Route("POST", "/v1/moves", "start_move", "Plan and execute a move on the arm", 202,
          "Move", "MoveBody", (*_BODY_ERRORS, 409, 503)),
    Route("GET", "/v1/moves/{id}", "get_move", "Status, progress and report of a move", 200,
          "Move", None, (404, 503)),
    Route("POST", "/v1/stop", "stop", "Stop the running move and hold position", 200,
          "Stop", None, (400, 413, 415, 422, 503)),
    Route("GET", "/v1/state", "state", "Present joints, pose, torque and hardware alerts",
          200, "State", None, (503,)),
    Route("GET", "/openapi.json", "openapi", "This OpenAPI 3.1 document", 200, "OpenAPI"),
)
_COMPILED = tuple((route, route.regex) for route in ROUTES)


def _error_schema() -> dict[str, Any]:
    return {"type": "object", "required": ["error"], "properties": {"error": {
        "type": "object", "required": ["code", "message", "field"],
        "properties": {"code": {"type": "string"}, "message": {"type": "string"},
                       "field": {"type": ["string", "null"]},
                       "sample": {"type": "integer", "description": "first failing sample"},
                       "t": {"type": "number", "description": "its time (s)"},
                       "joint": {"type": "string"}}}}}


def _number_array(depth: int = 1) -> dict[str, Any]:
    schema: dict[str, Any] = {"type": "number"}
    for _ in range(depth):
        schema = {"type": "array", "items": schema}
    return schema


_MOVE_STATUSES = ["queued", "running", "done", "stopped", "collision", "failed"]
SCHEMAS: dict[str, dict[str, Any]] = {
    "PlanBody": {"type": "object", "required": ["waypoints"], "additionalProperties": False,
                 "properties": {k: {**s, "description": d}
                                for k, (s, d) in PLAN_FIELDS.items()}},
    "MoveBody": {"type": "object", "required": ["waypoints"], "additionalProperties": False,
                 "properties": {k: {**s, "description": d}
                                for k, (s, d) in MOVE_FIELDS.items()}},
    "Trajectory": {"type": "object", "description": "Samples every 1/rate_hz s from t = 0.",
                   "required": ["t", "poses", "joints", "ticks", "joint_names", "servo_ids",
                                "rate_hz", "method"],
                   "properties": {"t": _number_array(1), "poses": _number_array(2),
                                  "joints": _number_array(2),
                                  "ticks": {"type": "array", "items": {
                                      "type": "array", "items": {"type": "integer"}}},
                                  "joint_names": {"type": "array",
                                                  "items": {"type": "string"}},
                                  "servo_ids": {"type": "array",
                                                "items": {"type": "integer"}},
                                  "rate_hz": {"type": "number"},
                                  "method": {"oneOf": [{"type": "string"}, {
                                      "type": "array", "items": {"type": "string"}}]},
                                  "request": {"type": ["object", "null"]}}},
    "Move": {"type": "object", "required": ["id", "status", "progress"],
             "properties": {"id": {"type": "string"}, "status": {"enum": _MOVE_STATUSES},
                            "progress": {"type": "number", "minimum": 0, "maximum": 1},
                            "elapsed": {"type": "number"}, "duration": {"type": "number"},
                            "samples": {"type": "integer"},
                            "tracking_error": {"type": ["number", "null"], "description":
                                               "rad; live |present − goal| while running, the "
                                               "report's maximum once finished"},
                            "created": {"type": "number"},
                            "started": {"type": ["number", "null"]},
                            "finished": {"type": ["number", "null"]},
                            "report": {"type": ["object", "null"]},
                            "error": {"type": ["object", "null"]}}},
    "Stop": {"type": "object", "required": ["stopped"],
             "properties": {"stopped": {"type": "boolean",
                                        "description": "a running move was stopped"},
                            "move": {"type": ["string", "null"]}}},
    "State": {"type": "object",
              "required": ["joints", "pose", "ticks", "torque", "alerts", "moving"],
              "properties": {"joints": _number_array(1), "pose": _number_array(1),
                             "ticks": {"type": "array", "items": {"type": "integer"}},
                             "torque": {"type": ["boolean", "null"]},
                             "alerts": {"type": "object", "additionalProperties": {
                                 "type": "string"}},
                             "moving": {"type": "boolean"},
                             "move": {"type": ["string", "null"]},
                             "source": {"enum": ["bus", "stream"]}}},
    "Health": {"type": "object", "required": ["status"],
               "properties": {"status": {"const": "ok"}, "version": {"type": "string"},
                              "arm": {"type": "string"}, "moving": {"type": "boolean"}}},
    "Arm": {"type": "object", "required": ["name", "dof", "joint_names", "servo_ids"],
            "properties": {"name": {"type": "string"}, "dof": {"type": "integer"},
                           "joint_names": {"type": "array", "items": {"type": "string"}},
                           "servo_ids": {"type": "array", "items": {"type": "integer"}},
                           "source": {"type": "string"},
                           "config": {"type": "object",
                                      "description": "robodcn.config.Arm.to_dict()"}}},
    "OpenAPI": {"type": "object"},
    "Error": _error_schema(),
}


def openapi(arm: Arm | None = None, *, token: bool = False) -> dict[str, Any]:
    """The OpenAPI 3.1 document, generated from :data:`ROUTES` and :data:`SCHEMAS`."""
    paths: dict[str, dict[str, Any]] = {}
    for route in ROUTES:
        op: dict[str, Any] = {
            "operationId": route.name, "summary": route.summary,
            "responses": {str(route.ok): {
                "description": HTTPStatus(route.ok).phrase,
                "content": {"application/json": {
                    "schema": {"$ref": f"#/components/schemas/{route.response}"}}}}}}
        if route.params:
            op["parameters"] = [{"name": p, "in": "path", "required": True,
                                 "schema": {"type": "string"}} for p in route.params]
        if route.body:
            op["requestBody"] = {"required": route.method == "POST" and route.name != "stop",
                                 "content": {"application/json": {
                                     "schema": {"$ref": f"#/components/schemas/{route.body}"}}}}
        codes = set(route.errors)
        if route.method == "POST" and token:
            codes.add(401)
        for code in sorted(codes):
            op["responses"][str(code)] = {
                "description": HTTPStatus(code).phrase,
                "content": {"application/json": {
                    "schema": {"$ref": "#/components/schemas/Error"}}}}
        if route.method == "POST" and token:
            op["security"] = [{"bearer": []}]
        paths.setdefault(route.path, {})[route.method.lower()] = op
    doc: dict[str, Any] = {
        "openapi": "3.1.0",
        "info": {"title": "robodcn trajectory service", "version": robodcn.__version__,
                 "description": "Plan planar rigid-motion trajectories (dual complex numbers) "
                                "and execute them on Dynamixel servos. SI units: metres, "
                                "radians, seconds." + (f" Arm: {arm.name}." if arm else "")},
        "paths": paths,
        "components": {"schemas": SCHEMAS},
    }
    if token:
        doc["components"] = {**doc["components"], "securitySchemes": {
            "bearer": {"type": "http", "scheme": "bearer"}}}
    return doc


# -- the handler --------------------------------------------------------------------------------

class HTTPError(Exception):
    """A transport-level refusal (status, code, message, field); never leaves the handler."""

    def __init__(self, status: int, code: str, message: str, field: str | None = None,
                 headers: dict[str, str] | None = None) -> None:
        super().__init__(message)
        self.status = status
        self.body = {"code": code, "message": message, "field": field}
        self.headers = headers or {}


def _dumps(obj: Any) -> bytes:
    return json.dumps(obj, separators=(",", ":")).encode()


def _reject_constant(name: str) -> None:
    raise ValueError(f"{name} is not valid JSON")


class Handler(BaseHTTPRequestHandler):
    """Dispatches on :data:`ROUTES`; one instance per connection (HTTP/1.1 keep-alive)."""

    protocol_version = "HTTP/1.1"
    server_version = f"robodcn/{robodcn.__version__}"
    disable_nagle_algorithm = True
    server: RobodcnHTTPServer

    def setup(self) -> None:
        self.timeout = self.server.request_timeout
        super().setup()

    def log_message(self, format: str, *args: Any) -> None:
        log.debug("%s %s", self.address_string(), format % args)

    # every method goes through the route table, so unknown methods get 405, not 501
    def do_GET(self) -> None:
        self._dispatch()

    do_POST = do_PUT = do_DELETE = do_PATCH = do_GET

    def _dispatch(self) -> None:
        length = (self.headers.get("Content-Length") or "0").strip()
        self._body_pending = length != "0" or "Transfer-Encoding" in self.headers
        try:
            route, params = self._route()
            self._authorize(route)
            status, payload = getattr(self, f"_op_{route.name}")(params)
            headers = {}
            if route.name == "start_move":
                headers["Location"] = f"/v1/moves/{payload['id']}"
        except HTTPError as exc:
            self._send(exc.status, {"error": exc.body}, exc.headers)
            return
        except RobodcnError as exc:
            status, body = exc.http_status, exc.to_dict()
            if isinstance(exc, BusError):
                log.warning("bus fault: %s", exc.message)
            self._send(status, {"error": body})
            return
        except (TimeoutError, ConnectionError):
            self.close_connection = True
            return
        except Exception as exc:  # a bug: answer 500, keep the traceback in the log
            log.exception("internal error on %s %s", self.command, self.path)
            self._send(500, {"error": {"code": "internal", "message":
                                       f"internal error: {type(exc).__name__}: {exc}",
                                       "field": None}})
            return
        self._send(status, payload, headers)

    def _route(self) -> tuple[Route, dict[str, str]]:
        path = self.path.split("?", 1)[0]
        allowed = []
        for route, regex in _COMPILED:
            match = regex.match(path)
            if match:
                if route.method == self.command:
                    return route, match.groupdict()
                allowed.append(route.method)
        if allowed:
            raise HTTPError(405, "method_not_allowed", f"{self.command} is not allowed on "
                            f"{path}; use {', '.join(allowed)}", None,
                            {"Allow": ", ".join(allowed)})
        raise HTTPError(404, "not_found", f"no endpoint {path}; see GET /openapi.json")

    def _authorize(self, route: Route) -> None:
        token = self.server.token
        if token is None or route.method != "POST":
            return
        given = self.headers.get("Authorization", "")
        scheme, _, value = given.partition(" ")
        if scheme.lower() != "bearer" or not hmac.compare_digest(
                value.strip().encode(), token.encode()):
            raise HTTPError(401, "unauthorized", "this server needs 'Authorization: Bearer "
                            "<token>' on every POST" + (" (the token given is wrong)"
                                                        if given else ""),
                            "Authorization", {"WWW-Authenticate": "Bearer"})

    def _read_json(self, *, required: bool = True) -> Any:
        """The request body as JSON, after the transport checks (411, 413, 415, 400)."""
        if "chunked" in self.headers.get("Transfer-Encoding", "").lower():
            raise HTTPError(411, "length_required", "chunked bodies are not accepted; send "
                            "Content-Length", "Content-Length")
        raw_length = self.headers.get("Content-Length")
        if raw_length is None:
            if required:
                raise HTTPError(411, "length_required", "a JSON body with Content-Length is "
                                "required", "Content-Length")
            return None
        if not raw_length.strip().isdigit():
            raise HTTPError(400, "bad_request", f"Content-Length {raw_length!r} is not a "
                            "number", "Content-Length")
        length = int(raw_length)
        if length > MAX_BODY:
            raise HTTPError(413, "too_large", f"the body is {length} bytes; the limit is "
                            f"{MAX_BODY} (1 MiB)", "body")
        if length == 0 and not required:
            return None
        ctype = self.headers.get("Content-Type", "")
        if ctype.split(";", 1)[0].strip().lower() != "application/json":
            raise HTTPError(415, "unsupported_media_type", f"Content-Type must be "
                            f"application/json, got {ctype or 'none'!r}", "Content-Type")
        data = self.rfile.read(length)
        if len(data) < length:
            raise ConnectionError("client closed before sending the whole body")
        self._body_pending = False
        try:
            return json.loads(data, parse_constant=_reject_constant)
        except (ValueError, UnicodeDecodeError) as exc:
            raise HTTPError(400, "malformed_json", f"the body is not valid JSON: {exc}",
                            "body") from None

    def _send(self, status: int, payload: Any, headers: dict[str, str] | None = None) -> None:
        body = payload if isinstance(payload, bytes) else _dumps(payload)
        if self._body_pending:
            # An unread body would be parsed as the next request: close instead.
            self.close_connection = True
        try:
            self.send_response(status)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            if self.close_connection:
                self.send_header("Connection", "close")
            for key, value in (headers or {}).items():
                self.send_header(key, value)
            self.end_headers()
            if self.command != "HEAD":  # the stdlib answers HEAD with 501 through send_error
                self.wfile.write(body)
        except (ConnectionError, TimeoutError):
            self.close_connection = True

    def handle_expect_100(self) -> bool:
        """Refuse an oversized body before the client sends it (no 100 Continue then)."""
        length = (self.headers.get("Content-Length") or "").strip()
        if length.isdigit() and int(length) > MAX_BODY:
            self._body_pending = True
            self._send(413, {"error": {"code": "too_large", "message": f"the body is {length} "
                                       f"bytes; the limit is {MAX_BODY} (1 MiB)",
                                       "field": "body"}})
            return False
        return super().handle_expect_100()

    def send_error(self, code: int, message: str | None = None,
                   explain: str | None = None) -> None:
        """The stdlib's own refusals (bad request line, oversized headers) as JSON too."""
        self._body_pending = True
        phrase = HTTPStatus(code).phrase if code in HTTPStatus._value2member_map_ else "error"
        self._send(code, {"error": {"code": phrase.lower().replace(" ", "_"),
                                    "message": message or phrase, "field": None}})

    def _controller(self) -> Any:
        controller = self.server.controller
        if controller is None:
            raise HTTPError(503, "no_arm", "this server only plans: it has no arm attached")
        return controller

    # -- operations (named after Route.name) ---------------------------------------------------

    def _op_health(self, params: dict[str, str]) -> tuple[int, Any]:
        controller = self.server.controller
        return 200, {"status": "ok", "version": robodcn.__version__,
                     "arm": self.server.arm.name,
                     "moving": bool(controller is not None and controller.busy)}

    def _op_arm(self, params: dict[str, str]) -> tuple[int, Any]:
        arm = self.server.arm
        return 200, {"name": arm.name, "dof": arm.dof, "joint_names": list(arm.joint_names),
                     "servo_ids": list(arm.servo_ids), "source": arm.source,
                     "config": arm.to_dict()}

    def _op_plan(self, params: dict[str, str]) -> tuple[int, Any]:
        req = parse_plan_body(self.server.arm, self._read_json(), PLAN_FIELDS)
        with self.server.plan_lock:
            return 200, plan_request(req).to_json().encode()

    def _op_start_move(self, params: dict[str, str]) -> tuple[int, Any]:
        controller = self._controller()
        req = parse_plan_body(self.server.arm, self._read_json(), MOVE_FIELDS)
        # Plan from where the arm is (409 at once if it is moving), so an infeasible approach
        # is a 422 now rather than a failed move later, and the record shows what will run.
        with controller.admitting():
            present = controller.present_joints()
            req = dataclasses.replace(req, start_joints=tuple(float(q) for q in present))
            with self.server.plan_lock:
                trajectory = plan_request(req)
            record = controller.start_move(trajectory)
        return 202, controller.move_info(record.id)

    def _op_get_move(self, params: dict[str, str]) -> tuple[int, Any]:
        info = self._controller().move_info(params["id"])
        if info is None:
            raise HTTPError(404, "not_found", f"no move {params['id']!r} (the service keeps "
                            "the most recent moves only)", "id")
        return 200, info

    def _op_stop(self, params: dict[str, str]) -> tuple[int, Any]:
        controller = self._controller()
        body = self._read_json(required=False)
        if body is not None and body != {}:
            if not isinstance(body, dict):
                raise InputError("the stop body must be empty or {}", field="body")
            name = next(iter(body))
            raise InputError(f"unknown field {name!r}: stop takes no fields", field=name,
                             value=body[name])
        return 200, controller.stop()

    def _op_state(self, params: dict[str, str]) -> tuple[int, Any]:
        return 200, self._controller().state()

    def _op_openapi(self, params: dict[str, str]) -> tuple[int, Any]:
        return 200, self.server.openapi_bytes


class RobodcnHTTPServer(ThreadingHTTPServer):
    """A ThreadingHTTPServer holding the arm, the controller and the settings of one service."""

    daemon_threads = True
    request_queue_size = 64

    def __init__(self, address: tuple[str, int], arm: Arm, controller: Any, *,
                 token: str | None, request_timeout: float,
                 max_connections: int = MAX_CONNECTIONS) -> None:
        self.arm = arm
        self.controller = controller
        self.token = token
        self.request_timeout = request_timeout
        # One thread per connection: cap them, so a flood of idle sockets cannot exhaust
        # threads (each idle one is closed after request_timeout anyway).
        self.connection_slots = threading.BoundedSemaphore(max_connections)
        # Planning is CPU-bound Python/numpy: the GIL runs one plan at a time anyway. Taking
        # turns on a lock lets waiting handlers sleep instead of contending for the GIL
        # (5 ms switch-interval convoys): measured +40 % plans/s and a 3× lower p99 with 8
        # clients (bench_http).
        self.plan_lock = threading.Lock()
        self.openapi_bytes = _dumps(openapi(arm, token=token is not None))
        super().__init__(address, Handler)

    def process_request(self, request: Any, client_address: Any) -> None:
        if not self.connection_slots.acquire(blocking=False):
            self._refuse(request)
            return
        try:
            super().process_request(request, client_address)
        except BaseException:
            self.connection_slots.release()
            raise

    def process_request_thread(self, request: Any, client_address: Any) -> None:
        try:
            super().process_request_thread(request, client_address)
        finally:
            self.connection_slots.release()

    def _refuse(self, request: socket.socket) -> None:
        """503 on the raw socket, without a thread: every connection slot is taken."""
        body = _dumps({"error": {"code": "too_many_connections", "message":
                                 "the server has too many open connections; retry later",
                                 "field": None}})
        head = (f"HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json\r\n"
                f"Content-Length: {len(body)}\r\nRetry-After: 1\r\nConnection: close\r\n"
                "\r\n").encode()
        with contextlib.suppress(OSError):
            request.settimeout(0.5)
            request.sendall(head + body)
        self.shutdown_request(request)

    def handle_error(self, request: Any, client_address: Any) -> None:
        # Dropped connections are routine for a service; keep them off stderr.
        log.debug("connection from %s failed", client_address, exc_info=True)

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        if ":" in host:
            host = f"[{host}]"
        return f"http://{host}:{port}"


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def make_server(arm: Arm, controller: Any, *, host: str = "127.0.0.1", port: int = 0,
                token: str | None = None, request_timeout: float = REQUEST_TIMEOUT,
                max_connections: int = MAX_CONNECTIONS) -> RobodcnHTTPServer:
    """A bound, not yet serving, HTTP server for ``arm`` (call ``serve_forever()``).

    Parameters
    ----------
    arm : Arm
    controller : robodcn.controller.ArmController, or None for a plan-only service (the
        move, stop and state endpoints then answer 503)
    host, port : address to bind; port 0 picks a free port (``server.server_address``)
    token : bearer token every POST must carry; required when ``host`` is not loopback
    request_timeout : seconds a connection may stay silent before it is closed
    max_connections : connections served at once (a thread each); more are answered 503

    Raises
    ------
    InputError
        A non-loopback host without a token, an empty token, a bad port or timeout.
    BusError
        The address cannot be bound (in use, not local).
    """
    if token is not None and (not isinstance(token, str) or not token.strip()):
        raise InputError("token must be a non-empty string", field="token", value=None)
    if not _is_loopback(host) and token is None:
        raise InputError(f"binding {host} exposes the arm to the network: give a token "
                         f"(--token or {TOKEN_ENV}) that every POST must carry",
                         field="token", value=None)
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise InputError(f"port must be an integer 0..65535, got {port!r}", field="port",
                         value=port)
    if isinstance(max_connections, bool) or not isinstance(max_connections, int) \
            or max_connections < 1:
        raise InputError(f"max_connections must be a positive integer, got "
                         f"{max_connections!r}", field="max_connections", value=max_connections)
    if not _is_number(request_timeout) or not request_timeout > 0:
        raise InputError(f"request_timeout must be a positive number of seconds, got "
                         f"{request_timeout!r}", field="request_timeout",
                         value=request_timeout)
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    cls = type("RobodcnHTTPServer6", (RobodcnHTTPServer,), {"address_family": family}) \
        if family == socket.AF_INET6 else RobodcnHTTPServer
    try:
        return cls((host, port), arm, controller, token=token,
                   request_timeout=float(request_timeout), max_connections=max_connections)
    except OSError as exc:
        raise BusError(f"cannot listen on {host}:{port}: {exc.strerror or exc}",
                       field="port", value=port) from exc


@contextlib.contextmanager
def _signals_stop(server: RobodcnHTTPServer) -> Iterator[None]:
    """SIGINT/SIGTERM shut the server down (main thread only; others cannot set handlers)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: Any) -> None:
        # shutdown() waits for serve_forever(), which runs in this very thread: hand it off.
        threading.Thread(target=server.shutdown, name="robodcn-http-shutdown").start()

    previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


def serve(arm: Arm, *, host: str = "127.0.0.1", port: int = 8080, token: str | None = None,
          sim: bool = False, device: str | None = None, baud: int | None = None,
          ready: Callable[[str], None] | None = None) -> None:
    """Run the service until SIGINT/SIGTERM or ``server.shutdown()``, then clean up.

    With ``sim=True`` the arm is :func:`robodcn.simulated.simulated_arm` in realistic
    timing; otherwise ``device`` (default: the arm's bus port) is opened at ``baud`` (default:
    the arm's) and verified against the arm's servos (BusError when they do not answer).
    ``token`` defaults to ``$ROBODCN_TOKEN``; ``ready(url)`` is called once the socket
    listens.
    """
    from robodcn.controller import ArmController  # the bus stack only when serving

    if token is None:
        token = os.environ.get(TOKEN_ENV) or None
    with contextlib.ExitStack() as stack:
        if sim:
            from robodcn.simulated import simulated_arm

            bus = stack.enter_context(simulated_arm(arm, timing="realistic")).bus
        else:
            from robodcn.bus import ServoBus

            bus = ServoBus(device or arm.bus.port, baud or arm.bus.baud, servos=arm.servos)
            stack.callback(bus.close)
            bus.open()
            # Torque stays as it is until the first move (the streamer configures then).
            bus.verify()
        controller = ArmController(arm, bus)
        stack.callback(controller.close)
        server = make_server(arm, controller, host=host, port=port, token=token)
        stack.callback(server.server_close)
        stack.enter_context(_signals_stop(server))
        if ready is not None:
            ready(server.url)
        server.serve_forever(poll_interval=0.2)
