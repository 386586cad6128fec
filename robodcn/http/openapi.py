"""The OpenAPI 3.1 document, generated from :data:`~robodcn.http.routes.ROUTES`, the request
contract (:func:`robodcn.contract.request_schema`) and :func:`robodcn.contract.schema_of` of
the result dataclasses (:mod:`robodcn.results`, the Trajectory)."""

from __future__ import annotations

from http import HTTPStatus
from typing import Any

import robodcn
from robodcn.config import Arm
from robodcn.contract import schema_of
from robodcn.contract.start_at import START_AT_SCHEMA
from robodcn.controls import body_schemas
from robodcn.http import online_ops
from robodcn.http.jsonbody import CHANGING
from robodcn.http.planbody import move_body_schema, plan_body_schema, trajectory_move_schema
from robodcn.http.routes import ROUTES, TRANSPORT_ERRORS, Route
from robodcn.planner import Trajectory
from robodcn.results import EVENTS, RESULTS
from robodcn.workflow.gripper import COMMANDS as GRIPPER_COMMANDS


def schemas(arm: Arm | None = None) -> dict[str, dict[str, Any]]:
    """Component schemas: request bodies (from robodcn.contract, exact for ``arm``), the
    Trajectory and every result type (schema_of their dataclasses)."""
    online = online_ops.body_schemas(move_body_schema(arm))
    given = trajectory_move_schema(arm)
    given["properties"]["replace"] = {
        "type": "boolean", "default": False,
        "description": "A given trajectory cannot replace a running move in flight: true "
                       "while a move runs is a 422 naming replace (stop it first)."}
    given["properties"]["start_at"] = START_AT_SCHEMA
    return {
        "PlanBody": plan_body_schema(arm),
        "TorqueBody": {"type": "object", "additionalProperties": False, "required": ["on"],
                       "properties": {"on": {"type": "boolean", "description": "torque on "
                                             "(holds where the arm is) or off"},
                                      "joint": _joint(arm),
                                      "confirm": {"type": "boolean", "default": False,
                                                  "description": CONFIRM}}},
        "GripperBody": gripper_body_schema(arm),
        "RebootBody": {"type": "object", "additionalProperties": False,
                       "properties": {"joint": _joint(arm),
                                      "confirm": {"type": "boolean", "default": False,
                                                  "description": CONFIRM}},
                       "description": "{} reboots every servo. A servo comes back from a "
                                      "reboot with torque off."},
        "Events": events_schema(),
        "Page": {"type": "string"},
        "Trajectory": schema_of(Trajectory),
        "OpenAPI": {"type": "object"},
        **{name: schema_of(cls) for name, cls in RESULTS.items()},
        **online,
        **body_schemas(arm),
        # after the online bodies: waypoints (with replace) or a given trajectory
        "MoveBody": {"anyOf": [online["MoveBody"], given],
                     "description": "Waypoints to plan from the arm's present pose (or, with "
                                    "replace, from the running move's commanded state), or a "
                                    "given trajectory to play after a joint-space approach "
                                    "from the present joints."},
    }


#: What ``confirm`` of a torque off or a reboot body means.
CONFIRM = ("Torque off (or a reboot, which leaves torque off) on an arm under gravity (a "
           "chain in a vertical plane) lets it fall: without confirm true it is refused, 409 "
           "gravity_release naming the joints gravity loads and the torque each holds (a "
           "joint gravity does not load, e.g. a base yaw, or whose torque is off already, "
           "needs none). Confirmed, the arm is first lowered to its rest pose ([arm.rest]; "
           "POST /v1/stop stops that, and torque stays on); where it cannot be, the answer's "
           "hold says why and torque goes off where the arm is.")


def gripper_body_schema(arm: Arm | None = None) -> dict[str, Any]:
    """A ``POST /v1/gripper`` body: ``{"command": "open" | "close"}`` or ``{"width_m": w}``,
    ``w`` within the arm's jaw stroke (``[gripper]``)."""
    width: dict[str, Any] = {"type": "number", "description": "jaw width, m (within the "
                             "stroke between the closed and open widths)"}
    if arm is not None and arm.gripper is not None:
        low, high = sorted((arm.gripper.closed_width, arm.gripper.open_width))
        width.update(minimum=low, maximum=high)
    else:
        width["minimum"] = 0.0
    has = "" if arm is None or arm.gripper is not None else (
        f" Arm {arm.name!r} has no [gripper]: 404.")
    return {"type": "object", "additionalProperties": False,
            "properties": {"command": {"type": "string", "enum": list(GRIPPER_COMMANDS),
                                       "description": "open, or close (an object in the "
                                       "jaws is held with the grip current)"},
                           "width_m": width},
            "oneOf": [{"required": ["command"]}, {"required": ["width_m"]}],
            "description": "A command or a width, not both." + has}


def events_schema() -> dict[str, Any]:
    """One event of ``GET /v1/events`` (OpenAPI 3.1: the ``text/event-stream`` schema
    describes each event, ``{event, data, id?, retry?}``): its name, and its ``data`` as
    JSON of the type :data:`robodcn.results.EVENTS` names."""
    names = {cls: name for name, cls in RESULTS.items()}
    return {"description": "Server-Sent Events: `event: state|move|alert`, `data:` one JSON "
                           "object (StateEvent; Move; AlertEvent)",
            "oneOf": [{"type": "object", "required": ["event", "data"], "properties": {
                "event": {"const": event},
                "data": {"type": "string", "contentMediaType": "application/json",
                         "contentSchema": {"$ref": f"#/components/schemas/{names[cls]}"}},
                "id": {"type": "string"}, "retry": {"type": "integer"}}}
                for event, cls in EVENTS.items()]}


def _joint(arm: Arm | None) -> dict[str, Any]:
    schema: dict[str, Any] = {"type": "string", "description": "a joint name (default: every "
                              "joint)"}
    if arm is not None:
        schema["enum"] = list(arm.joint_names)
    return schema


def _content(route: Route) -> dict[str, Any]:
    """The success answer's content: the schema as JSON, or of each event of an event
    stream (OpenAPI 3.1 reads a ``text/event-stream`` schema as one event's), a string
    otherwise."""
    out = {}
    for media in (route.media, *route.alt_media):
        out[media] = {"schema": {"$ref": f"#/components/schemas/{route.response}"}
                      if media in ("application/json", "text/event-stream")
                      else {"type": "string"}}
    return out


def openapi(arm: Arm | None = None, *, token: bool = False,
            routes: tuple[Route, ...] = ROUTES) -> dict[str, Any]:
    """The OpenAPI 3.1 document: every operation with every status it can answer."""
    paths: dict[str, dict[str, Any]] = {}
    for route in routes:
        op: dict[str, Any] = {
            "operationId": route.name, "summary": route.summary,
            "responses": {str(route.ok): {
                "description": HTTPStatus(route.ok).phrase,
                "content": _content(route)}}}
        if route.params:
            op["parameters"] = [{"name": p, "in": "path", "required": True,
                                 "schema": {"type": "string"}} for p in route.params]
        if route.body:
            op["requestBody"] = {"required": True,
                                 "content": {"application/json": {
                                     "schema": {"$ref": f"#/components/schemas/{route.body}"}}}}
        codes = set(route.errors) | set(TRANSPORT_ERRORS)
        if route.name in ("start_move", "get_move", "stop", "state", "move_trajectory",
                          "move_record", "torque", "reboot", "events", "pause", "resume",
                          "set_speed", "gripper"):
            codes.add(503)  # no arm attached, or a bus fault
        if route.method in CHANGING and token:
            codes.add(401)
        for code in sorted(codes):
            if code == 304:  # revalidated: no body
                op["responses"]["304"] = {"description": HTTPStatus(304).phrase}
                continue
            op["responses"][str(code)] = {
                "description": HTTPStatus(code).phrase,
                "content": {"application/json": {
                    "schema": {"$ref": "#/components/schemas/Error"}}}}
        if route.method in CHANGING and token:
            op["security"] = [{"bearer": []}]
        paths.setdefault(route.path, {})[route.method.lower()] = op
    doc: dict[str, Any] = {
        "openapi": "3.1.0",
        "info": {"title": "robodcn trajectory service", "version": robodcn.__version__,
                 "description": "Plan planar rigid-motion trajectories (dual complex numbers) "
                                "and execute them on Dynamixel servos. SI units: metres, "
                                "radians, seconds. Every POST, PUT and DELETE takes "
                                "Content-Type: application/json and a JSON body ({} for an "
                                "operation without fields; 415 otherwise). A Host other than "
                                "the service's (127.0.0.1, localhost, [::1] and its port), or "
                                "an Origin other than its own, is refused with 403."
                                + (f" Arm: {arm.name}." if arm else "")},
        "paths": paths,
        "components": {"schemas": schemas(arm)},
    }
    if token:
        doc["components"]["securitySchemes"] = {"bearer": {"type": "http", "scheme": "bearer"}}
    return doc
