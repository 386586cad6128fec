"""The route table: one :class:`Route` per operation drives dispatch, the worker pool a
request runs in, and ``/openapi.json``.

``pool`` says where a request runs once framed:

- ``"work"``: the ordinary worker pool (planning, starting moves) — bounded, 503 when full;
- ``"read"``: threads for the quick reads (state, health, move status), so a load of plans
  cannot delay them;
- ``"control"``: threads reserved for ``POST /v1/stop``, which nothing else may use, so no
  load of plans, reads (a state read waits up to 5 s on a faulty bus) or slow clients can
  delay a stop;
- ``"stream"``: a long-lived response (e.g. Server-Sent Events): its own bounded pool of
  threads, exempt from the request deadline once its headers are in; the operation gets
  the socket and writes until the client leaves or the server shuts down.

Adding a streaming endpoint (e.g. ``GET /v1/events``, Server-Sent Events)::

    Route("GET", "/v1/events", "events", "Progress and state as Server-Sent Events", 200,
          "OpenAPI", pool="stream", media="text/event-stream")

and an operation ``events(server, request, params)`` that writes
``framing.stream_head()`` then ``data: ...\n\n`` events to ``request.socket`` until the
client leaves (OSError) or ``server.stopping`` is set, and returns ``(200, b"")``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Literal

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
    regex: re.Pattern[str] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        pattern = "^" + re.sub(r"\\\{(\w+)\\\}", r"(?P<\1>[^/]+)", re.escape(self.path)) + "$"
        object.__setattr__(self, "regex", re.compile(pattern))

    @property
    def params(self) -> list[str]:
        return re.findall(r"\{(\w+)\}", self.path)


#: Statuses any operation can answer before it runs: a malformed or oversized request
#: (400, 414, 431), a stalled one (408), a full server (503).
TRANSPORT_ERRORS = (400, 405, 408, 414, 431, 503)
#: Statuses of reading a JSON body.
BODY_ERRORS = (400, 411, 413, 415, 422)

ROUTES: tuple[Route, ...] = (
    Route("GET", "/healthz", "health", "Liveness: arm name, whether a move runs", 200,
          "Health", pool="read"),
    Route("GET", "/v1/arm", "arm", "The arm configuration (metres, radians, SI)", 200, "Arm"),
    Route("POST", "/v1/trajectories", "plan", "Plan a trajectory (no motion)", 200,
          "Trajectory", "PlanBody", BODY_ERRORS),
    Route("POST", "/v1/moves", "start_move", "Plan and execute a move on the arm", 202,
          "Move", "MoveBody", (*BODY_ERRORS, 409)),
    Route("GET", "/v1/moves/{id}", "get_move", "Status, progress and report of a move", 200,
          "Move", None, (404,), pool="read"),
    Route("POST", "/v1/stop", "stop", "Stop the running move (smooth: decelerate along its "
          "path, then hold; hold: at once)", 200,
          "Stop", "StopBody", (400, 413, 415, 422), pool="control"),
    Route("POST", "/v1/pause", "pause", "Pause the running move: a smooth stop on its path",
          200, "Move", "EmptyBody", (400, 409, 413, 415, 422), pool="control"),
    Route("POST", "/v1/resume", "resume", "Resume the paused move along the same path", 200,
          "Move", "EmptyBody", (400, 409, 413, 415, 422), pool="control"),
    Route("PUT", "/v1/speed", "set_speed", "Scale the running move's speed live (limits "
          "v·k, a·k², j·k³)", 200, "Move", "SpeedBody", (*BODY_ERRORS, 409), pool="control"),
    Route("GET", "/v1/state", "state", "Present joints, pose, torque and hardware alerts",
          200, "State", pool="read"),
    Route("GET", "/openapi.json", "openapi", "This OpenAPI 3.1 document", 200, "OpenAPI"),
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
