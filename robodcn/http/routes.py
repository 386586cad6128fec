"""The route table: one :class:`Route` per operation drives dispatch, the worker pool a
request runs in, and ``/openapi.json``.

``pool`` says where a request runs once framed:

- ``"work"``: the ordinary worker pool (planning, starting moves) — bounded, 503 when full;
- ``"read"``: threads for the quick reads (state, health, move status), so a load of plans
  cannot delay them;
- ``"control"``: threads reserved for ``POST /v1/stop`` (and the other controls of the running
  move: pause, resume, speed), which nothing else may use, so no
  load of plans, reads (a state read waits up to 5 s on a faulty bus) or slow clients can
  delay a stop;
- ``"stream"``: a long-lived response (e.g. Server-Sent Events): its own bounded pool of
  threads, exempt from the request deadline once its headers are in; the operation gets
  the socket and writes until the client leaves or the server shuts down.

A streaming endpoint (``GET /v1/events``, Server-Sent Events) is a ``pool="stream"`` route
with ``media="text/event-stream"`` whose operation writes ``framing.stream_head()`` then its
events to ``request.socket`` until the client leaves (OSError) or ``server.stopping`` is set,
and returns ``(200, b"")``. A non-JSON answer (the console page, a CSV) is an operation
returning ``(status, framing.Reply(body, content_type, headers))``; ``media`` and
``alt_media`` document its content types.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Literal

from robodcn.controls import CONTROLS
from robodcn.http.framing import HTTPError

Pool = Literal["work", "read", "control", "stream"]


@dataclass(frozen=True)
class Route:
    """One operation: dispatch key, handler name and what the OpenAPI document says of it."""

    method: str
    path: str                   # OpenAPI template, "{name}" for a path parameter
    name: str                   # operationId and the operation in robodcn.http.ops
    summary: str
    ok: int                     # success status
    response: str               # component schema of the success body
    body: str | None = None     # component schema of the request body
    errors: tuple[int, ...] = ()
    pool: Pool = "work"
    media: str = "application/json"   # content type of the success answer
    alt_media: tuple[str, ...] = ()    # other content types it may have (Accept, file kind)
    #: GET/HEAD are served whatever the request's Origin (the console's files, which a page
    #: may link); every other route refuses a foreign Origin (robodcn.http.gate).
    public: bool = False
    regex: re.Pattern[str] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        pattern = "^" + re.sub(r"\\\{(\w+)\\\}", r"(?P<\1>[^/]+)", re.escape(self.path)) + "$"
        object.__setattr__(self, "regex", re.compile(pattern))

    @property
    def params(self) -> list[str]:
        return re.findall(r"\{(\w+)\}", self.path)


#: Statuses any operation can answer before it runs: a malformed or oversized request
#: (400, 414, 431), a Host or Origin not the service's (403, robodcn.http.gate), a stalled
#: one (408), a full server (503).
TRANSPORT_ERRORS = (400, 403, 405, 408, 414, 431, 503)
#: Statuses of reading a JSON body (every POST/PUT/DELETE has one: 411 without a length,
#: 415 without application/json or with an empty body).
BODY_ERRORS = (400, 411, 413, 415, 422)

ROUTES: tuple[Route, ...] = (
    Route("GET", "/healthz", "health", "Health: arm name, whether a move runs; 503 with the "
          "reason while the servo bus is lost or faulted or a servo reports a hardware "
          "error", 200, "Health", pool="read"),
    Route("GET", "/v1/arm", "arm", "The arm configuration (metres, radians, SI)", 200, "Arm"),
    Route("POST", "/v1/trajectories", "plan", "Plan a trajectory (no motion)", 200,
          "Trajectory", "PlanBody", BODY_ERRORS),
    Route("POST", "/v1/moves", "start_move", "Plan and execute a move on the arm", 202,
          "Move", "MoveBody", (*BODY_ERRORS, 409)),
    Route("GET", "/v1/moves/{id}", "get_move", "Status, progress and report of a move", 200,
          "Move", None, (404,), pool="read"),
    # the controls of the running motion, declared once (robodcn.controls)
    *(Route(c.method, c.path, c.name, c.summary, c.ok, c.response, c.body,
            (*BODY_ERRORS, *c.errors), pool=c.pool) for c in CONTROLS),
    Route("GET", "/v1/state", "state", "Present joints, pose, torque and hardware alerts",
          200, "State", pool="read"),
    Route("GET", "/openapi.json", "openapi", "This OpenAPI 3.1 document", 200, "OpenAPI"),
    Route("GET", "/v1/moves/{id}/trajectory", "move_trajectory", "What a move planned: its "
          "Trajectory (the approach included)", 200, "Trajectory", None, (404,)),
    Route("GET", "/v1/moves/{id}/record", "move_record", "What a move measured: time, "
          "joints, ticks and pose per feedback read (CSV with Accept: text/csv)", 200,
          "Record", None, (404,), pool="read", alt_media=("text/csv",)),
    Route("POST", "/v1/torque", "torque", "Switch torque on (holding where the arm is) or "
          "off, for one joint or all (off on an arm under gravity needs \"confirm\": true, "
          "409 otherwise, and lowers the arm to its rest pose first)", 200, "Torque",
          "TorqueBody", (*BODY_ERRORS, 409)),
    Route("POST", "/v1/gripper", "gripper", "Open or close the gripper, or set its jaw "
          "width (current-based position mode: an object is held with the grip current)",
          200, "Gripper", "GripperBody", (*BODY_ERRORS, 404, 409)),
    Route("POST", "/v1/reboot", "reboot", "Reboot one servo or all (clears hardware "
          "errors; torque is off afterwards: on an arm under gravity it needs \"confirm\": "
          "true, 409 otherwise, and lowers the arm to its rest pose first)", 200, "Reboot",
          "RebootBody", (*BODY_ERRORS, 409)),
    Route("GET", "/v1/events", "events", "Server-Sent Events: state (≥ 20 Hz while moving, "
          "≥ 1 Hz at rest), move status changes, alerts", 200, "Events", None, (503,),
          pool="stream", media="text/event-stream"),
    Route("GET", "/", "console", "The web console (HTML page)", 200, "Page", None, (304,),
          pool="read", media="text/html", public=True),
    Route("GET", "/static/{name}", "static", "A file of the web console (JS, CSS)", 200,
          "Page", None, (304, 404), pool="read", media="text/javascript",
          alt_media=("text/css", "text/html", "image/png", "image/svg+xml"), public=True),
)


def allowed_methods(path: str, routes: tuple[Route, ...] = ROUTES) -> list[str]:
    """The methods served on ``path`` (HEAD wherever GET is), in table order."""
    methods = [r.method for r in routes if r.regex.match(path)]
    if "GET" in methods:
        methods.append("HEAD")
    return methods


def match(method: str, path: str, routes: tuple[Route, ...] = ROUTES
          ) -> tuple[Route, dict[str, str]]:
    """The route for ``method path`` and its path parameters.

    HEAD is answered as GET without the body. Raises HTTPError 404 for an unknown path and
    405 (with ``Allow``) for a method the path does not serve — any method: TRACE, OPTIONS,
    lower-case or unknown.
    """
    lookup = "GET" if method == "HEAD" else method
    for route in routes:
        found = route.regex.match(path)
        if found and route.method == lookup:
            return route, found.groupdict()
    allowed = allowed_methods(path, routes)
    if allowed:
        raise HTTPError(405, "method_not_allowed", f"{method} is not allowed on {path}; use "
                        f"{', '.join(allowed)}", None, {"Allow": ", ".join(allowed)})
    raise HTTPError(404, "not_found", f"no endpoint {path}; see GET /openapi.json")
