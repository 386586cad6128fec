"""Plan and move bodies → :class:`robodcn.planner.PlanRequest` (until robodcn.contract)."""

from __future__ import annotations

import math
from typing import Any

from robodcn.config import Arm
from robodcn.errors import InputError, TooLargeError
from robodcn.interpolate import METHODS
from robodcn.planner import MAX_SAMPLES, PROFILES, TURNS, PlanRequest

#: Fields of a plan body: name → (JSON schema, description). The body parser accepts exactly
#: these names and the OpenAPI schema is generated from them.
PLAN_FIELDS: dict[str, tuple[dict[str, Any], str]] = {
    "waypoints": ({"type": "array", "minItems": 2,
                   "items": {"type": "array", "minItems": 3, "maxItems": 3,
                             "items": {"type": "number"}}},
                  "Poses [x, y, θ] in metres and radians; at least two."),
    "method": ({"oneOf": [{"enum": list(METHODS)},
                          {"type": "array", "items": {"enum": list(METHODS)}}]},
               "Interpolation method, or one per segment. Default sclerp."),
    "beta": ({"type": "number"}, "KenLERP bias β. Default 1."),
    "turn": ({"oneOf": [{"enum": list(TURNS)},
                        {"type": "array", "items": {"enum": list(TURNS)}}]},
             "Turn direction, or one per segment. Default shortest."),
    "duration": ({"oneOf": [{"type": "number", "exclusiveMinimum": 0}, {"const": "auto"}]},
                 "Total seconds, or \"auto\" (shortest within the joint limits). Default auto."),
    "profile": ({"enum": list(PROFILES)}, "Timing profile. Default quintic."),
    "rate_hz": ({"type": "number", "minimum": 1, "maximum": 1000},
                "Sample rate (Hz). Default: the arm's bus rate."),
    "blend": ({"type": "boolean"},
              "Pass through via points with continuous velocity. Default false."),
    "start_joints": ({"type": ["array", "null"], "items": {"type": "number"}},
                     "Joint angles (rad) to start from; an approach is prepended when they "
                     "differ from the first waypoint's IK. Default: none."),
}
#: A move always starts from the arm's present joints: the streamer supplies start_joints.
MOVE_FIELDS = {k: v for k, v in PLAN_FIELDS.items() if k != "start_joints"}


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _check_waypoints(value: Any) -> None:
    """Name the first malformed waypoint (``waypoints[2]``) before the planner sees it."""
    if not isinstance(value, list):
        raise InputError(f"waypoints must be a list of [x, y, θ] poses, got {value!r}"[:200],
                         field="waypoints", value=value)
    if len(value) < 2:
        raise InputError(f"waypoints needs at least 2 poses, got {len(value)}",
                         field="waypoints", value=value)
    for i, pose in enumerate(value):
        if not isinstance(pose, list) or len(pose) != 3:
            raise InputError(f"waypoints[{i}] must be [x, y, θ] (metres, radians), got "
                             f"{pose!r}"[:200], field=f"waypoints[{i}]", value=pose)
        for k, v in enumerate(pose):
            if not _is_number(v) or not math.isfinite(v):
                raise InputError(f"waypoints[{i}][{k}] must be a finite number, got {v!r}",
                                 field=f"waypoints[{i}]", value=pose)


def _check_start_joints(arm: Arm, value: Any) -> None:
    if value is None:
        return
    if not isinstance(value, list) or len(value) != arm.dof:
        raise InputError(f"start_joints must be {arm.dof} joint angles (rad), got "
                         f"{value!r}"[:200], field="start_joints", value=value)
    for k, v in enumerate(value):
        if not _is_number(v) or not math.isfinite(v) or abs(v) > 4 * math.pi:
            raise InputError(f"start_joints[{k}] must be a finite angle within ±4π rad, got "
                             f"{v!r}", field="start_joints", value=value)


def _check_samples(duration: Any, rate_hz: Any) -> None:
    """TooLargeError (413) naming duration when duration × rate is over MAX_SAMPLES, before
    the product can overflow anywhere."""
    if _is_number(duration) and _is_number(rate_hz) and math.isfinite(duration) \
            and duration > 0 and 0 < rate_hz <= 1000 and duration * rate_hz > MAX_SAMPLES:
        raise TooLargeError(f"duration {duration:g} s at {rate_hz:g} Hz needs more than "
                            f"{MAX_SAMPLES} samples: shorten the duration or lower rate_hz",
                            field="duration", value=duration)


def parse_plan_body(arm: Arm, body: Any, fields: dict[str, Any] = PLAN_FIELDS) -> PlanRequest:
    """A JSON body → a validated :class:`PlanRequest` for ``arm``.

    Unknown fields raise InputError naming the field; rate_hz defaults to the arm's bus rate.
    """
    if not isinstance(body, dict):
        raise InputError(f"the body must be a JSON object, got {type(body).__name__}",
                         field="body", value=None)
    for name in body:
        if name not in fields:
            hint = (" (a move starts from the arm's present joints)"
                    if name == "start_joints" else "")
            raise InputError(f"unknown field {name!r}{hint}; allowed: "
                             f"{', '.join(fields)}"[:300], field=name, value=body[name])
    if "waypoints" not in body:
        raise InputError("waypoints is required", field="waypoints", value=None)
    _check_waypoints(body["waypoints"])
    _check_start_joints(arm, body.get("start_joints"))
    args = dict(body)
    args.setdefault("rate_hz", arm.bus.rate_hz)
    _check_samples(args["duration"] if "duration" in args else "auto", args["rate_hz"])
    for key in ("method", "turn"):
        if isinstance(args.get(key), list):
            args[key] = tuple(args[key])
    return PlanRequest(arm=arm, **args)
