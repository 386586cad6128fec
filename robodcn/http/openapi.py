"""The OpenAPI 3.1 document, generated from :data:`~robodcn.http.routes.ROUTES`, the request
fields and :func:`~robodcn.http.results.schema_of` of the result types."""

from __future__ import annotations

from http import HTTPStatus
from typing import Any

import robodcn
from robodcn.config import Arm
from robodcn.http.planbody import MOVE_FIELDS, PLAN_FIELDS
from robodcn.http.results import RESULTS, schema_of
from robodcn.http.routes import ROUTES, TRANSPORT_ERRORS


def _number_array(depth: int = 1) -> dict[str, Any]:
    schema: dict[str, Any] = {"type": "number"}
    for _ in range(depth):
        schema = {"type": "array", "items": schema}
    return schema


def _body_schema(fields: dict[str, tuple[dict[str, Any], str]]) -> dict[str, Any]:
    return {"type": "object", "required": ["waypoints"], "additionalProperties": False,
            "properties": {k: {**s, "description": d} for k, (s, d) in fields.items()}}


def schemas() -> dict[str, dict[str, Any]]:
    """Component schemas: request bodies, the Trajectory and every result type."""
    return {
        "PlanBody": _body_schema(PLAN_FIELDS),
        "MoveBody": _body_schema(MOVE_FIELDS),
        "StopBody": {"type": "object", "additionalProperties": False, "properties": {},
                     "description": "Empty: stop takes no fields (the body may be omitted)."},
        "Trajectory": {
            "type": "object", "description": "Samples every 1/rate_hz s from t = 0.",
            "required": ["t", "poses", "joints", "ticks", "joint_names", "servo_ids",
                         "rate_hz", "method"],
            "properties": {"t": _number_array(1), "poses": _number_array(2),
                           "joints": _number_array(2),
                           "ticks": {"type": "array", "items": {
                               "type": "array", "items": {"type": "integer"}}},
                           "joint_names": {"type": "array", "items": {"type": "string"}},
                           "servo_ids": {"type": "array", "items": {"type": "integer"}},
                           "rate_hz": {"type": "number"},
                           "method": {"oneOf": [{"type": "string"}, {
                               "type": "array", "items": {"type": "string"}}]},
                           "request": {"type": ["object", "null"]}}},
        "OpenAPI": {"type": "object"},
        **{name: schema_of(cls) for name, cls in RESULTS.items()},
    }


def openapi(arm: Arm | None = None, *, token: bool = False) -> dict[str, Any]:
    """The OpenAPI 3.1 document: every operation with every status it can answer."""
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
            op["requestBody"] = {"required": route.name != "stop",
                                 "content": {"application/json": {
                                     "schema": {"$ref": f"#/components/schemas/{route.body}"}}}}
        codes = set(route.errors) | set(TRANSPORT_ERRORS)
        if route.name in ("start_move", "get_move", "stop", "state"):
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
        "components": {"schemas": schemas()},
    }
    if token:
        doc["components"]["securitySchemes"] = {"bearer": {"type": "http", "scheme": "bearer"}}
    return doc
