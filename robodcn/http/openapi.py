"""The OpenAPI 3.1 document, generated from :data:`~robodcn.http.routes.ROUTES`, the request
contract (:func:`robodcn.contract.request_schema`) and :func:`robodcn.contract.schema_of` of
the result dataclasses (:mod:`robodcn.http.results`, the Trajectory)."""

from __future__ import annotations

from http import HTTPStatus
from typing import Any

import robodcn
from robodcn.config import Arm
from robodcn.contract import schema_of
from robodcn.http import online_ops
from robodcn.http.planbody import move_body_schema, plan_body_schema
from robodcn.http.results import RESULTS
from robodcn.http.routes import ROUTES, TRANSPORT_ERRORS, Route
from robodcn.planner import Trajectory


def schemas(arm: Arm | None = None) -> dict[str, dict[str, Any]]:
    """Component schemas: request bodies (from robodcn.contract, exact for ``arm``), the
    Trajectory and every result type (schema_of their dataclasses)."""
    return {
        "PlanBody": plan_body_schema(arm),
        "MoveBody": move_body_schema(arm),
        "StopBody": {"type": "object", "additionalProperties": False, "properties": {},
                     "description": "Empty: stop takes no fields (the body may be omitted)."},
        "Trajectory": schema_of(Trajectory),
        "OpenAPI": {"type": "object"},
        **{name: schema_of(cls) for name, cls in RESULTS.items()},
        **online_ops.body_schemas(move_body_schema(arm)),
    }


def openapi(arm: Arm | None = None, *, token: bool = False,
            routes: tuple[Route, ...] = ROUTES) -> dict[str, Any]:
    """The OpenAPI 3.1 document: every operation with every status it can answer."""
    paths: dict[str, dict[str, Any]] = {}
    for route in routes:
        op: dict[str, Any] = {
            "operationId": route.name, "summary": route.summary,
            "responses": {str(route.ok): {
                "description": HTTPStatus(route.ok).phrase,
                "content": {route.media: {"schema": (
                    {"$ref": f"#/components/schemas/{route.response}"}
                    if route.media == "application/json" else {"type": "string"})}}}}}
        if route.params:
            op["parameters"] = [{"name": p, "in": "path", "required": True,
                                 "schema": {"type": "string"}} for p in route.params]
        if route.body:
            op["requestBody"] = {"required": route.name not in online_ops.OPTIONAL_BODIES,
                                 "content": {"application/json": {
                                     "schema": {"$ref": f"#/components/schemas/{route.body}"}}}}
        codes = set(route.errors) | set(TRANSPORT_ERRORS)
        if route.name in ("start_move", "get_move", "stop", "state", "pause", "resume",
                          "set_speed"):
            codes.add(503)  # no arm attached, or a bus fault
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
        "components": {"schemas": schemas(arm)},
    }
    if token:
        doc["components"]["securitySchemes"] = {"bearer": {"type": "http", "scheme": "bearer"}}
    return doc
