"""The controls of the running motion, declared once: what each is called, where a surface
addresses it, the body it takes and what it does to the arm's controller.

A :class:`Control` is data (Ruckig's shape: an operation is an input, not a recipe per
surface): its name (the OpenAPI operationId, Zenoh's ``op/<name>``), its HTTP method and
path, its body schema (a component of the OpenAPI document) and ``run(controller, body)``,
which checks the JSON body (InputError naming the field and value) and hands the
:class:`~robodcn.controller.ArmController` the input it becomes — a stop mode, a pause or
a resume, a speed scale, a follow session's target. The HTTP layer builds its routes and
operations from :data:`CONTROLS` (:mod:`robodcn.http.routes`, :mod:`robodcn.http.ops`), and
every surface that runs the HTTP operations by name (the Zenoh face,
:mod:`robodcn.zenoh.dispatch`) serves them with no code of its own.

The controls: ``stop`` (smooth | hold), ``pause``, ``resume``, ``set_speed`` (the running
move, planned or a follow session), ``follow_open``, ``follow_target``, ``follow_end`` (a
follow session: :class:`robodcn.stream.Follower`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from robodcn._checks import is_finite_real, show
from robodcn.config import Arm
from robodcn.controller import ArmController
from robodcn.errors import InputError
from robodcn.results import FollowTargetAnswer
from robodcn.stream import STOP_MODES
from robodcn.stream.following import SPACES, rest_trajectory

#: seconds ``follow_open`` waits for the session's stream to start before it answers
OPEN_WAIT_S = 1.0


@dataclass(frozen=True)
class Control:
    """One control of the running motion (module notes)."""

    name: str
    method: str
    path: str
    summary: str
    body: str
    response: str
    run: Callable[[ArmController, Any], Any]
    ok: int = 200
    #: statuses beyond a body's own (409: nothing runs that the control applies to)
    errors: tuple[int, ...] = (409,)
    #: the HTTP pool (``control``: threads no load of plans or reads can delay)
    pool: str = "control"


def fields_of(body: Any, allowed: tuple[str, ...], what: str) -> dict[str, Any]:
    """``body`` as a JSON object with only ``allowed`` fields (InputError naming the first
    other one, or ``body`` when it is not an object)."""
    if not isinstance(body, dict):
        raise InputError(f"the {what} body must be a JSON object", field="body", value=None)
    for name in body:
        if name not in allowed:
            known = f"known: {', '.join(allowed)}" if allowed else f"{what} takes no fields"
            raise InputError(f"unknown field {name!r} ({known})", field=name, value=None)
    return body


def stop_mode(body: Any) -> str:
    """``mode`` of a stop body (default "smooth"), InputError naming it when unknown."""
    mode = fields_of(body, ("mode",), "stop").get("mode", "smooth")
    if mode not in STOP_MODES:
        raise InputError(f"mode must be one of {', '.join(STOP_MODES)}, got {mode!r}",
                         field="mode", value=mode)
    return mode


def speed_scale(body: Any) -> float:
    """``scale`` of a speed body: a number in (0, 1] (InputError naming ``scale``)."""
    fields = fields_of(body, ("scale",), "speed")
    if "scale" not in fields:
        raise InputError("scale is required: a number in (0, 1]", field="scale", value=None)
    k = fields["scale"]
    if not is_finite_real(k) or not 0.0 < k <= 1.0:
        raise InputError(f"scale must be a number in (0, 1], got {show(k)}", field="scale",
                         value=k)
    return float(k)


def _positive(body: dict[str, Any], name: str, *, zero: bool = False) -> float | None:
    if name not in body:
        return None
    value = body[name]
    if not is_finite_real(value) or value < 0 or (value == 0 and not zero):
        bound = "≥ 0" if zero else "> 0"
        raise InputError(f"{name} must be a number {bound}, got {show(value)}", field=name,
                         value=value)
    return float(value)


def _follow_open(controller: ArmController, body: Any) -> Any:
    """Open a follow session on the present joints (admitted like a move: 409 beside one)."""
    body = fields_of(body, ("space", "timeout_s", "rate_hz", "payload_kg"), "follow")
    space = body.get("space", "joints")
    timeout_s = _positive(body, "timeout_s")
    rate_hz = _positive(body, "rate_hz")
    payload_kg = _positive(body, "payload_kg", zero=True)
    with controller.admitting():
        controller.check_follow(space, timeout_s)
        ticks = controller.present_ticks()
        rest = rest_trajectory(controller.arm, ticks, rate_hz, payload_kg)
        record = controller.start_follow(rest, space=space, timeout_s=timeout_s,
                                         payload_kg=payload_kg,
                                         present_ticks=tuple(int(t) for t in ticks))
    record.prepared.wait(OPEN_WAIT_S)     # answered as it streams: status "following"
    return controller.move_info(record.id)


def _follow_target(controller: ArmController, body: Any) -> FollowTargetAnswer:
    body = fields_of(body, ("joints", "pose", "velocity"), "target")
    return FollowTargetAnswer(seq=controller.follow_target(
        joints=body.get("joints"), pose=body.get("pose"), velocity=body.get("velocity")))


def _no_fields(what: str, act: Callable[[ArmController], Any]
               ) -> Callable[[ArmController, Any], Any]:
    def run(controller: ArmController, body: Any) -> Any:
        fields_of(body, (), what)
        return act(controller)
    return run


CONTROLS: tuple[Control, ...] = (
    Control("stop", "POST", "/v1/stop", "Stop the running move (smooth: decelerate along "
            "its path, then hold; hold: at once)", "StopBody", "Stop",
            lambda c, body: c.stop_move(stop_mode(body)), errors=()),
    Control("pause", "POST", "/v1/pause", "Pause the running move: a smooth stop on its "
            "path", "EmptyBody", "Move", _no_fields("pause", ArmController.pause)),
    Control("resume", "POST", "/v1/resume", "Resume the paused move along the same path",
            "EmptyBody", "Move", _no_fields("resume", ArmController.resume)),
    Control("set_speed", "PUT", "/v1/speed", "Scale the running move's speed live (limits "
            "v·k, a·k², j·k³)", "SpeedBody", "Move",
            lambda c, body: c.set_speed(speed_scale(body))),
    Control("follow_open", "POST", "/v1/follow", "Open a follow session: the arm heads for "
            "the newest of a stream of targets (one move, status following; 409 while "
            "another runs)", "FollowBody", "Move", _follow_open, ok=201, pool="work"),
    Control("follow_target", "PUT", "/v1/follow/target", "Send the follow session a target "
            "(joints or a pose; nothing is planned: checked and taken at the next bus "
            "period); 409 without a session", "FollowTargetBody", "FollowTarget",
            _follow_target),
    Control("follow_end", "DELETE", "/v1/follow", "End the follow session: rest at the last "
            "target, the move ends done", "EmptyBody", "Move",
            _no_fields("follow end", ArmController.follow_end)),
)
#: the controls by name
BY_NAME: dict[str, Control] = {c.name: c for c in CONTROLS}


def _numbers(n: int | None, what: str) -> dict[str, Any]:
    schema: dict[str, Any] = {"type": "array", "items": {"type": "number"},
                              "description": what}
    if n is not None:
        schema["minItems"] = schema["maxItems"] = n
    return schema


def body_schemas(arm: Arm | None = None) -> dict[str, dict[str, Any]]:
    """The controls' body schemas (exact for ``arm``), by component name."""
    dof = None if arm is None else arm.dof
    axes = None if arm is None else len(arm.pose_keys)
    names = "" if arm is None else f" ({', '.join(arm.pose_keys)})"
    velocity = _numbers(dof, "joint velocity (rad/s) to pass the target with; default: "
                             "estimated from the stream of targets")
    return {
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


__all__ = ["BY_NAME", "CONTROLS", "Control", "body_schemas", "fields_of", "speed_scale",
           "stop_mode"]
