"""The HTTP edge: an operation's typed result, or its failure, as the reply sent.

An operation returns ``(status, payload)``: a result dataclass of :mod:`robodcn.results`
(turned into JSON here, :func:`robodcn.results.to_json`), a JSON-ready object, ready bytes
or a :class:`~robodcn.http.framing.Reply`. It raises :class:`~robodcn.http.framing.HTTPError`
or a :class:`~robodcn.errors.RobodcnError`: either becomes its JSON error with its status,
anything else a 500 without a traceback (which goes to the log).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from typing import Any

from robodcn.errors import BusError, RobodcnError
from robodcn.http.auth import authorize
from robodcn.http.context import Service
from robodcn.http.framing import HTTPError, Reply, Request, dumps, error_body
from robodcn.http.jsonbody import require_json
from robodcn.http.routes import Route
from robodcn.results import to_json

log = logging.getLogger("robodcn.http")

Operation = Callable[[Service, Request, dict[str, str]], tuple[int, Any]]


def reply_of(route: Route, payload: Any) -> Reply:
    """The reply of an operation's ``payload`` (``POST /v1/moves`` adds ``Location``)."""
    if isinstance(payload, Reply):
        return payload
    if isinstance(payload, bytes):
        return Reply(payload)
    if dataclasses.is_dataclass(payload):
        payload = to_json(payload)
    headers = {}
    if route.name == "start_move":
        headers["Location"] = f"/v1/moves/{payload['id']}"
    return Reply(dumps(payload), headers=headers)


def answer(server: Service, operation: Operation, route: Route, request: Request,
           params: dict[str, str]) -> tuple[int, Reply]:
    """Authorize (the token, :mod:`robodcn.http.auth`), require a JSON body of a changing
    method (:func:`~robodcn.http.jsonbody.require_json`) and run ``operation``
    (:func:`run`); every failure becomes its JSON error, never a traceback."""

    def checked(server: Service, request: Request, params: dict[str, str]
                ) -> tuple[int, Any]:
        authorize(server.token, request)
        require_json(request)
        return operation(server, request, params)

    return run(server, checked, route, request, params)


def run(server: Service, operation: Operation, route: Route, request: Request,
        params: dict[str, str]) -> tuple[int, Reply]:
    """Run ``operation``; every failure becomes its JSON error, never a traceback. The
    surface-neutral part of :func:`answer`: a surface with its own authentication (the
    Zenoh face, :mod:`robodcn.zenoh`) calls this with a request it framed itself."""
    try:
        status, payload = operation(server, request, params)
        return status, reply_of(route, payload)
    except HTTPError as exc:
        return exc.status, Reply(dumps({"error": exc.body}), headers=exc.headers)
    except RobodcnError as exc:
        if isinstance(exc, BusError):
            log.warning("bus fault: %s", exc.message)
        return exc.http_status, Reply(dumps({"error": exc.to_dict()}))
    except Exception as exc:  # a bug: answer 500, keep the traceback in the log
        log.exception("internal error on %s %s", request.method, request.path)
        return 500, Reply(error_body(500, "internal", f"internal error: {type(exc).__name__}"))
