"""Online control of the running move over HTTP: replace, stop modes, pause, resume, speed.

* ``POST /v1/moves`` with ``"replace": true`` while a move runs: the new request is planned
  from the running move's commanded state (:meth:`robodcn.stream.Execution.retarget`,
  through :func:`robodcn.admission.admit`); 202 with the new move, and the old one ends
  ``replaced``. Without ``replace`` a running move still answers 409; with it and nothing
  running, the move starts as usual. :func:`take_replace` reads the flag.
* ``POST /v1/stop`` ``{"mode": "smooth" | "hold"}`` (default smooth: decelerate along the
  path within the limits, then hold; hold: at once).
* ``POST /v1/pause {}``, ``POST /v1/resume {}``, ``PUT /v1/speed {"scale": k}``,
  0 < k ≤ 1 (422 naming ``scale`` otherwise); 409 when no move runs.

The routes are in :data:`robodcn.http.routes.ROUTES`, the body schemas in
:func:`body_schemas` (in the OpenAPI document) and the operations in :data:`OPERATIONS`
(merged into :data:`robodcn.http.ops.OPERATIONS`).
"""

from __future__ import annotations

import copy
from typing import Any

from robodcn._checks import is_finite_real, show
from robodcn.contract.start_at import START_AT_SCHEMA
from robodcn.errors import InputError
from robodcn.http.context import Service, controller_of
from robodcn.http.framing import Request
from robodcn.http.jsonbody import read_json
from robodcn.stream import STOP_MODES


def body_schemas(move_body: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Component schemas of the online bodies; ``move_body`` gains ``replace``."""
    move = copy.deepcopy(move_body)
    move.setdefault("properties", {})["replace"] = {
        "type": "boolean", "default": False,
        "description": "Replace the running move in flight (202, the old one ends "
                       "'replaced'); without it a running move answers 409. A replace "
                       "while another is being planned, or one that would miss its "
                       "switch, answers 409 busy with nothing changed: try again."}
    move["properties"]["start_at"] = START_AT_SCHEMA
    return {
        "MoveBody": move,
        "StopBody": {"type": "object", "additionalProperties": False, "properties": {
            "mode": {"enum": list(STOP_MODES), "default": "smooth",
                     "description": "smooth: decelerate along the path within the limits, "
                                    "then hold; hold: hold where the arm is at once"}},
            "description": "{} is a smooth stop."},
        "EmptyBody": {"type": "object", "additionalProperties": False, "properties": {},
                      "description": "No fields: send {}."},
        "SpeedBody": {"type": "object", "additionalProperties": False, "required": ["scale"],
                      "properties": {"scale": {
                          "type": "number", "exclusiveMinimum": 0, "maximum": 1,
                          "description": "speed scale k: velocity limits × k, acceleration "
                                         "× k², jerk × k³"}}},
    }


def take_replace(body: Any) -> tuple[Any, bool]:
    """The move body without ``replace``, and its value (InputError naming it if not a
    boolean)."""
    if not isinstance(body, dict) or "replace" not in body:
        return body, False
    body = dict(body)
    replace = body.pop("replace")
    if not isinstance(replace, bool):
        raise InputError(f"replace must be true or false, got {replace!r}", field="replace",
                         value=replace)
    return body, replace


def _fields(body: Any, allowed: tuple[str, ...], what: str) -> dict[str, Any]:
    if not isinstance(body, dict):
        raise InputError(f"the {what} body must be a JSON object", field="body", value=None)
    for name in body:
        if name not in allowed:
            known = f"known: {', '.join(allowed)}" if allowed else f"{what} takes no fields"
            raise InputError(f"unknown field {name!r} ({known})", field=name, value=None)
    return body


def stop_mode(body: Any) -> str:
    """``mode`` of a stop body (default "smooth"), InputError naming it when unknown."""
    mode = _fields(body, ("mode",), "stop").get("mode", "smooth")
    if mode not in STOP_MODES:
        raise InputError(f"mode must be one of {', '.join(STOP_MODES)}, got {mode!r}",
                         field="mode", value=mode)
    return mode


def speed_scale(body: Any) -> float:
    """``scale`` of a speed body: a number in (0, 1] (InputError naming ``scale``)."""
    fields = _fields(body, ("scale",), "speed")
    if "scale" not in fields:
        raise InputError("scale is required: a number in (0, 1]", field="scale", value=None)
    k = fields["scale"]
    if not is_finite_real(k) or not 0.0 < k <= 1.0:
        raise InputError(f"scale must be a number in (0, 1], got {show(k)}", field="scale",
                         value=k)
    return float(k)


def op_pause(server: Service, request: Request, params: dict[str, str]
             ) -> tuple[int, Any]:
    controller = controller_of(server)
    _fields(read_json(request), (), "pause")
    return 200, controller.pause()


def op_resume(server: Service, request: Request, params: dict[str, str]
              ) -> tuple[int, Any]:
    controller = controller_of(server)
    _fields(read_json(request), (), "resume")
    return 200, controller.resume()


def op_set_speed(server: Service, request: Request, params: dict[str, str]
                 ) -> tuple[int, Any]:
    controller = controller_of(server)
    return 200, controller.set_speed(speed_scale(read_json(request)))


OPERATIONS = {"pause": op_pause, "resume": op_resume, "set_speed": op_set_speed}
