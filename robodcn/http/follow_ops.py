"""Follow a stream of targets over HTTP: open a session, send targets, end it.

* ``POST /v1/follow`` ``{"space": "joints" | "pose", "timeout_s"?, "rate_hz"?,
  "payload_kg"?}`` → 201 with the session's move (status ``following``; 409 while another
  move runs): :meth:`robodcn.controller.ArmController.start_follow` on the present joints.
* ``PUT /v1/follow/target`` ``{"joints": [rad…]}`` or ``{"pose": [the arm's pose axes]}``,
  optional ``"velocity"`` (rad/s per joint) → 200 ``{"seq": n}``. Nothing is planned here:
  the target is checked (422 naming ``joints``, ``pose`` or ``velocity``; the arm goes on to
  the previous target) and handed to the session's generator, whose next sample heads for it
  (:class:`robodcn.stream.Follower`); 409 without a session.
* ``DELETE /v1/follow`` ``{}`` → 200 with the move: the arm comes to rest at the last target
  and the move ends ``done``. ``POST /v1/stop`` ends it smoothly (``stopped``).

The routes are in :data:`robodcn.http.routes.ROUTES`, the bodies in :func:`body_schemas`
(in the OpenAPI document) and the operations in :data:`OPERATIONS` (merged into
:data:`robodcn.http.ops.OPERATIONS`).
"""

from __future__ import annotations

from typing import Any

from robodcn._checks import is_finite_real, show
from robodcn.config import Arm
from robodcn.errors import InputError
from robodcn.http.context import Service, controller_of
from robodcn.http.framing import Request
from robodcn.http.jsonbody import read_json
from robodcn.results import FollowTargetAnswer
from robodcn.stream.following import SPACES, rest_trajectory

#: seconds ``POST /v1/follow`` waits for the session's stream to start before it answers
OPEN_WAIT_S = 1.0


def _numbers(n: int | None, what: str) -> dict[str, Any]:
    schema: dict[str, Any] = {"type": "array", "items": {"type": "number"},
                              "description": what}
    if n is not None:
        schema["minItems"] = schema["maxItems"] = n
    return schema


def body_schemas(arm: Arm | None = None) -> dict[str, dict[str, Any]]:
    """Component schemas of the follow bodies (exact for ``arm``)."""
    dof = None if arm is None else arm.dof
    axes = None if arm is None else len(arm.pose_keys)
    names = "" if arm is None else f" ({', '.join(arm.pose_keys)})"
    velocity = _numbers(dof, "joint velocity (rad/s) to pass the target with; default: "
                             "estimated from the stream of targets")
    return {
        "FollowBody": {
            "type": "object", "additionalProperties": False, "properties": {
                "space": {"enum": list(SPACES), "default": "joints",
                          "description": "targets are joint angles (rad) or poses"},
                "timeout_s": {"type": "number", "exclusiveMinimum": 0, "description":
                              "deadman: no target for this long while the arm moves → a "
                              "smooth stop (the move ends stopped)"},
                "rate_hz": {"type": "number", "exclusiveMinimum": 0,
                            "description": "bus rate (default: the arm's)"},
                "payload_kg": {"type": "number", "minimum": 0,
                               "description": "payload the torque limits carry (default: "
                                              "the arm's)"}},
            "description": "{} follows joint targets at the arm's rate."},
        "FollowTargetBody": {"oneOf": [
            {"type": "object", "additionalProperties": False, "required": ["joints"],
             "properties": {"joints": _numbers(dof, "joint angles (rad), bus order"),
                            "velocity": velocity}},
            {"type": "object", "additionalProperties": False, "required": ["pose"],
             "properties": {"pose": _numbers(axes, f"a pose in the arm's axes{names} "
                                                   "(m, rad)"),
                            "velocity": velocity}}]},
    }


def _fields(body: Any, allowed: tuple[str, ...], what: str) -> dict[str, Any]:
    if not isinstance(body, dict):
        raise InputError(f"the {what} body must be a JSON object", field="body", value=None)
    for name in body:
        if name not in allowed:
            raise InputError(f"unknown field {name!r} (known: {', '.join(allowed)})",
                             field=name, value=None)
    return body


def _positive(body: dict[str, Any], name: str, *, zero: bool = False) -> float | None:
    if name not in body:
        return None
    value = body[name]
    if not is_finite_real(value) or value < 0 or (value == 0 and not zero):
        bound = "≥ 0" if zero else "> 0"
        raise InputError(f"{name} must be a number {bound}, got {show(value)}", field=name,
                         value=value)
    return float(value)


def op_follow_open(server: Service, request: Request, params: dict[str, str]
                   ) -> tuple[int, Any]:
    controller = controller_of(server)
    body = _fields(read_json(request), ("space", "timeout_s", "rate_hz", "payload_kg"),
                   "follow")
    space = body.get("space", "joints")
    timeout_s = _positive(body, "timeout_s")
    rate_hz = _positive(body, "rate_hz")
    payload_kg = _positive(body, "payload_kg", zero=True)
    with controller.admitting():
        controller.check_follow(space, timeout_s)
        ticks = controller.present_ticks()
        rest = rest_trajectory(server.arm, ticks, rate_hz, payload_kg)
        record = controller.start_follow(rest, space=space, timeout_s=timeout_s,
                                         payload_kg=payload_kg,
                                         present_ticks=tuple(int(t) for t in ticks))
    record.prepared.wait(OPEN_WAIT_S)     # answered as it streams: status "following"
    return 201, controller.move_info(record.id)


def op_follow_target(server: Service, request: Request, params: dict[str, str]
                     ) -> tuple[int, Any]:
    controller = controller_of(server)
    body = _fields(read_json(request), ("joints", "pose", "velocity"), "target")
    seq = controller.follow_target(joints=body.get("joints"), pose=body.get("pose"),
                                   velocity=body.get("velocity"))
    return 200, FollowTargetAnswer(seq=seq)


def op_follow_end(server: Service, request: Request, params: dict[str, str]
                  ) -> tuple[int, Any]:
    controller = controller_of(server)
    _fields(read_json(request), (), "follow end")
    return 200, controller.follow_end()


OPERATIONS = {"follow_open": op_follow_open, "follow_target": op_follow_target,
              "follow_end": op_follow_end}
