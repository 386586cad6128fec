"""An operation of the OpenAPI document called over Zenoh, through the HTTP layer's own
operation table: the same validation, errors and answers, no second copy of any operation.

A query on ``robodcn/<arm>/op/<operationId>`` carries the JSON body as its payload and the
path parameters as selector parameters (``robodcn/<arm>/op/get_move?id=3``); the reply is
``{"status": <HTTP status>, "body": <the answer>}`` (a non-JSON answer — the console page,
a CSV — as text). The request is framed as the HTTP route would receive it (method, path,
``Content-Type: application/json``) and run by :func:`robodcn.http.answer.run`, the part
of an HTTP answer below the bearer-token check: a Zenoh peer is authenticated by the
session (``--zenoh-config``), not by a token.
"""

from __future__ import annotations

import json
from typing import Any

from robodcn.http.answer import run
from robodcn.http.context import Service
from robodcn.http.framing import Request, error_body
from robodcn.http.limits import MAX_BODY
from robodcn.http.ops import OPERATIONS
from robodcn.http.routes import ROUTES, Route

#: Routes by operationId.
BY_NAME: dict[str, Route] = {r.name: r for r in ROUTES}


def _error(status: int, code: str, message: str, field: str) -> dict[str, Any]:
    return {"status": status, "body": json.loads(error_body(status, code, message, field))}


def call(server: Service, name: str, payload: bytes | None,
         params: dict[str, str] | None = None) -> dict[str, Any]:
    """Run operation ``name`` with the JSON ``payload`` (None or empty: no body) and path
    ``params``; ``{"status", "body"}`` as the HTTP route would answer."""
    route = BY_NAME.get(name)
    if route is None:
        return _error(404, "not_found", f"no operation {name!r}; see op/openapi "
                      f"(operations: {', '.join(sorted(BY_NAME))})", "operationId")
    if route.pool == "stream":
        return _error(400, "not_a_query", f"{name} is a stream: subscribe to "
                      "robodcn/<arm>/state instead", "operationId")
    params = dict(params or {})
    missing = [p for p in route.params if not params.get(p)]
    if missing:
        return _error(400, "missing_parameter", f"{name} needs the selector parameter "
                      f"{missing[0]} (e.g. op/{name}?{missing[0]}=1)", missing[0])
    path = route.path
    for key in route.params:
        path = path.replace("{" + key + "}", params[key])
    body = payload or b""
    if len(body) > MAX_BODY:
        return _error(413, "too_large", f"the body has {len(body)} bytes, over the "
                      f"{MAX_BODY} an operation takes", "body")
    headers = {"content-type": "application/json", "content-length": str(len(body)),
               "host": "zenoh"}
    request = Request(route.method, path, (1, 1), headers, body, client="zenoh")
    status, reply = run(server, OPERATIONS[route.name], route, request, params)
    if reply.content_type.startswith("application/json"):
        answer: Any = json.loads(reply.body) if reply.body else None
    else:
        answer = reply.body.decode("utf-8", "replace")
    return {"status": status, "body": answer}
