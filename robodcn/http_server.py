"""Compatibility: the HTTP service now lives in :mod:`robodcn.http`; these names stay here."""

from robodcn.http import (
    MAX_BODY,
    MAX_CONNECTIONS,
    MAX_PER_CLIENT,
    MOVE_FIELDS,
    PLAN_FIELDS,
    REQUEST_TIMEOUT,
    ROUTES,
    TOKEN_ENV,
    HTTPError,
    ListenError,
    RobodcnHTTPServer,
    Route,
    make_server,
    openapi,
    parse_plan_body,
    schemas,
    serve,
)

__all__ = ["MAX_BODY", "MAX_CONNECTIONS", "MAX_PER_CLIENT", "MOVE_FIELDS", "PLAN_FIELDS",
           "REQUEST_TIMEOUT", "ROUTES", "TOKEN_ENV", "HTTPError", "ListenError",
           "RobodcnHTTPServer", "Route", "make_server", "openapi", "parse_plan_body", "schemas",
           "serve"]
