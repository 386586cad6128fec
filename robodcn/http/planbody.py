"""Plan and move bodies, from :mod:`robodcn.contract` (the one definition of the request).

The parsing is :func:`robodcn.contract.parse_request` and the schema
:func:`robodcn.contract.request_schema`; a move body omits
:data:`robodcn.contract.MOVE_OMIT` (a move starts from the arm's present joints).
:data:`PLAN_FIELDS`, :data:`MOVE_FIELDS` and :func:`parse_plan_body` (exported by
:mod:`robodcn.http`) are derived from the contract.
"""

from __future__ import annotations

from typing import Any

from robodcn import contract
from robodcn.config import Arm
from robodcn.errors import InputError, TooLargeError
from robodcn.planner import PlanRequest


def plan_body_schema(arm: Arm | None = None) -> dict[str, Any]:
    """JSON Schema of a ``POST /v1/trajectories`` body."""
    return contract.request_schema(arm)


#: What ``waypoints`` means in a move body, beyond the contract's description.
MOVE_WAYPOINTS = ("In a move, one waypoint [G] runs from the arm's present state to G; with "
                  "replace while a move runs, from the running move's commanded moving state "
                  "(a replacement never visits its first waypoint of two or more: it is the "
                  "caller's view of where the arm is, dropped at the switch).")


def move_body_schema(arm: Arm | None = None) -> dict[str, Any]:
    """JSON Schema of a ``POST /v1/moves`` body (``waypoints``: :data:`MOVE_WAYPOINTS`)."""
    schema = contract.request_schema(arm, omit=contract.MOVE_OMIT)
    waypoints = schema["properties"]["waypoints"]
    waypoints["description"] = f"{waypoints['description']} {MOVE_WAYPOINTS}"
    return schema


def _over_max_items(body: Any, schema: dict[str, Any]) -> bool:
    """``body`` has a list longer than its property's declared ``maxItems`` (than each
    array alternative's, for a property that takes one of several)."""
    if not isinstance(body, dict):
        return False
    for name, prop in schema["properties"].items():
        value = body.get(name)
        if not isinstance(value, list):
            continue
        arrays = [a for a in prop.get("oneOf", prop.get("anyOf", [prop]))
                  if a.get("type") == "array"]
        caps = [a.get("maxItems") for a in arrays]
        if caps and None not in caps and len(value) > max(caps):
            return True
    return False


def _parse(arm: Arm, body: Any, omit: tuple[str, ...],
           start_joints: tuple[float, ...] | None = None) -> PlanRequest:
    """The contract's parse; a cap the body's declared schema states (``maxItems``: more
    waypoints than it takes) is a schema violation like any other, 422 naming the field.
    413 stays for bodies over the byte limit and plans too large to answer (samples), which
    no schema of the body can say."""
    try:
        return contract.parse_request(body, arm, omit=omit, start_joints=start_joints)
    except TooLargeError as exc:
        if not _over_max_items(body, contract.request_schema(arm, omit=omit)):
            raise
        raise InputError(exc.message, field=exc.field, value=exc.value) from None


def parse_plan(arm: Arm, body: Any) -> PlanRequest:
    """A decoded ``/v1/trajectories`` body → a validated PlanRequest (InputError naming the
    JSON path of the bad value; TooLargeError for a plan too large, all before planning)."""
    return _parse(arm, body, ())


def parse_move(arm: Arm, body: Any, start_joints: tuple[float, ...] | None = None
               ) -> PlanRequest:
    """A decoded ``/v1/moves`` body → a validated PlanRequest: without start_joints, or
    starting at the present ``start_joints`` (k,) rad (then one waypoint is enough: from
    the present state to it)."""
    return _parse(arm, body, contract.MOVE_OMIT, start_joints)


def from_present(body: Any) -> bool:
    """A move body of one waypoint (``{"waypoints": [G]}``): it runs from the present state,
    so it is parsed once the present joints are read (:func:`parse_move` with them)."""
    return isinstance(body, dict) and isinstance(body.get("waypoints"), list) \
        and len(body["waypoints"]) == 1


def check_move(body: Any) -> None:
    """The rules of a move body that need no start (an object, known fields, JSON types;
    :func:`robodcn.contract.check_body`): refused now, before the arm is read."""
    contract.check_body(body, contract.MOVE_OMIT)


# -- a move of a given trajectory ---------------------------------------------------------------

#: Fields of a ``POST /v1/moves`` body that plays a trajectory instead of planning one.
TRAJECTORY_MOVE_FIELDS = ("trajectory", "rate_hz")


def joint_trajectory_schema(arm: Arm | None = None) -> dict[str, Any]:
    """JSON Schema of a ROS ``trajectory_msgs/JointTrajectory`` as JSON (robodcn.workflow.files)."""
    names: dict[str, Any] = {"type": "string"}
    if arm is not None:
        names["enum"] = list(arm.joint_names)
    stamp = {"type": "object", "additionalProperties": False, "required": ["sec"],
             "properties": {"sec": {"type": "integer", "minimum": 0},
                            "nanosec": {"type": "integer", "minimum": 0,
                                        "maximum": 999_999_999}}}
    point = {"type": "object", "additionalProperties": False,
             "required": ["positions", "time_from_start"],
             "properties": {
                 "positions": {"type": "array", "items": {"type": "number"},
                               "description": "rad, in the order of joint_names"},
                 "velocities": {"description": "rad/s per joint, on every point or none"},
                 "accelerations": {"description": "rad/s² per joint, on every point or none "
                                   "(with velocities)"},
                 "effort": {"description": "ignored"},
                 "time_from_start": stamp}}
    return {"type": "object", "required": ["joint_names", "points"],
            "description": "trajectory_msgs/JointTrajectory as JSON: resampled at rate_hz by "
                           "piecewise Hermite interpolation, checked against the arm's limits",
            "properties": {"joint_names": {"type": "array", "items": names},
                           "points": {"type": "array", "minItems": 2, "items": point}}}


def trajectory_move_schema(arm: Arm | None = None) -> dict[str, Any]:
    """JSON Schema of a ``POST /v1/moves`` body that plays a given trajectory."""
    rate = contract.field("rate_hz")
    return {"type": "object", "additionalProperties": False, "required": ["trajectory"],
            "properties": {
                "trajectory": {"anyOf": [
                    {"type": "object", "required": ["t", "ticks"],
                     "description": "a Trajectory JSON (POST /v1/trajectories, robodcn plan "
                                    "--format json; #/components/schemas/Trajectory) for this "
                                    "arm: played as planned"},
                    joint_trajectory_schema(arm)]},
                "rate_hz": {**rate.schema, "description": "Stream rate a JointTrajectory is "
                            "resampled at (a Trajectory keeps its own). Default: the arm's "
                            "[bus] rate_hz."}}}


def parse_trajectory_move(arm: Arm, body: dict[str, Any]) -> tuple[Any, float]:
    """``{"trajectory": ..., "rate_hz"?}`` → (the trajectory value, the rate), checked
    (InputError naming the field); the trajectory itself is checked by
    :func:`robodcn.workflow.files.trajectory_from_data`."""
    extra = sorted(set(body) - set(TRAJECTORY_MOVE_FIELDS))
    if extra:
        raise contract.fail(extra[0], "unknown field: a move of a given trajectory takes "
                            "trajectory and rate_hz only", body[extra[0]])
    rate = contract.check_field("rate_hz", body["rate_hz"]) if "rate_hz" in body \
        else arm.bus.rate_hz
    return body["trajectory"], float(rate)
