"""The plan request contract, declared once: fields, JSON Schema, units, CLI names, parsing.

Every field of a plan request (the POST body of ``/v1/trajectories`` and ``/v1/moves``, the
keywords of :func:`robodcn.planner.plan`, the CLI options of ``plan``/``sim``/``move``) is a
:class:`Field` in :data:`FIELDS`: its name, its JSON Schema (types, ``minimum``/``maximum``,
``enum``), its SI unit, the CLI option and the unit the CLI user types, its default and a
description. From that one table come

* :func:`request_schema` — the JSON Schema of the request body (OpenAPI ``requestBody``);
* :func:`parse_request` — a JSON body → a validated :class:`~robodcn.planner.PlanRequest`,
  every error an :class:`~robodcn.errors.InputError` (or ``TooLargeError``) whose ``field``
  is the JSON path of the bad value (``waypoints[2][1]``, ``start_joints[0]``);
* :func:`cli_choices` — the choices of ``--method``, ``--turn``, ``--profile``, ``--elbow``;
* the range checks of :class:`~robodcn.planner.PlanRequest` itself (:func:`check_number`,
  :func:`check_choice`, which read the bounds from the same schemas).

:func:`schema_of` derives the JSON Schema of a result dataclass (Trajectory JSON,
:class:`~robodcn.errors.Violation`, ...) from its field type hints and
``metadata={"description": ..., "schema": ...}``.

Cross-field rules the schema cannot say (checked by the parser, before any planning):
``duration × rate_hz`` sample periods must cover one per segment and stay within
:data:`MAX_SAMPLES` samples (413); ``waypoints`` holds at most :data:`MAX_WAYPOINTS` poses
(413); a waypoint is (x, y, θ), or (x, y) on a 2-joint (position-only) arm;
``start_joints`` has one angle per joint, each within that joint's limits; ``start_state``
excludes ``start_joints`` and, when moving, needs profile ``optimal``; per-segment lists
of ``method``/``turn``/``beta`` have one entry per segment.

Only numpy and the standard library are imported here, so the planning core stays light.
"""

from __future__ import annotations

import dataclasses
import json
import math
import types
import typing
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from robodcn.config import ELBOWS, RATE_RANGE, Arm
from robodcn.dcn import TURNS
from robodcn.errors import BetaIgnoredWarning as BetaIgnoredWarning  # re-exported
from robodcn.errors import InputError, TooLargeError
from robodcn.interpolate import METHODS
from robodcn.timing import PROFILES

#: Largest plan (samples) the planner produces.
MAX_SAMPLES = 1_000_000
#: Most waypoints one request may give (checked before anything is planned).
MAX_WAYPOINTS = 1000
#: Longest numeric duration (s): MAX_SAMPLES periods at the lowest rate.
MAX_DURATION = MAX_SAMPLES / RATE_RANGE[0]
#: KenLERP bias range. β = 0 is SEP-LERP, β = 1 ScLERP, β > 1 extrapolates past ScLERP as
#: KenLERP defines it; a negative β (extrapolating past SEP-LERP) is not defined there and is
#: refused. The upper bound keeps extrapolated paths near the workspace.
BETA_RANGE = (0.0, 10.0)
#: Methods that read β (the others ignore it: BetaIgnoredWarning).
BETA_METHODS = ("kenlerp",)
#: Largest coordinate magnitude (m) of a waypoint: far beyond any arm, small enough that
#: every later product stays finite.
MAX_COORDINATE = 1e3
#: Largest |θ| or |joint angle| (rad) accepted on input.
MAX_ANGLE = 1e3


@dataclass(frozen=True)
class Field:
    """One request field.

    Attributes
    ----------
    name : JSON field and Python keyword (``rate_hz``)
    schema : its JSON Schema (without description/default)
    description : one or two sentences for the OpenAPI document and ``--help``
    default : the value when absent (None: see the description)
    unit : SI unit over HTTP and in Python ("Hz", "s", "m, m, rad", "rad"), or None
    cli_option : the CLI option that sets it (``--rate``), or None
    cli_unit : the unit the CLI user types, when it differs from ``unit``
    required : whether the body must give it
    """

    name: str
    schema: dict[str, Any]
    description: str
    default: Any = None
    unit: str | None = None
    cli_option: str | None = None
    cli_unit: str | None = None
    required: bool = False

    @property
    def choices(self) -> tuple[str, ...]:
        """The enum of a string field (or of each entry of a per-segment list)."""
        return _enum_of(self.schema)


def _enum_of(schema: Mapping[str, Any]) -> tuple[str, ...]:
    if "enum" in schema:
        return tuple(v for v in schema["enum"] if isinstance(v, str))
    for key in ("oneOf", "anyOf"):
        for option in schema.get(key, ()):
            found = _enum_of(option)
            if found:
                return found
    if "items" in schema and isinstance(schema["items"], Mapping):
        return _enum_of(schema["items"])
    return ()


def _per_segment_schema(one: dict[str, Any]) -> dict[str, Any]:
    """``one`` value for every segment, or an array of one per segment."""
    return {"oneOf": [one, {"type": "array", "minItems": 1, "maxItems": MAX_WAYPOINTS - 1,
                            "items": dict(one)}]}


def _choice_schema(choices: tuple[str, ...]) -> dict[str, Any]:
    return {"type": "string", "enum": list(choices)}


_POSE_ITEM = {"type": "number", "minimum": -MAX_COORDINATE, "maximum": MAX_COORDINATE}
_ANGLE_ITEM = {"type": "number", "minimum": -MAX_ANGLE, "maximum": MAX_ANGLE}

FIELDS: tuple[Field, ...] = (
    Field("waypoints",
          {"type": "array", "minItems": 2, "maxItems": MAX_WAYPOINTS,
           "items": {"type": "array", "minItems": 2, "maxItems": 3,
                     "prefixItems": [_POSE_ITEM, _POSE_ITEM, _ANGLE_ITEM],
                     "items": _ANGLE_ITEM}},
          "Poses [x, y, θ] in metres and radians, at least two, at most "
          f"{MAX_WAYPOINTS}; on a 2-joint (position-only) arm [x, y] (θ, if given, is "
          "ignored).",
          unit="m, m, rad", cli_option="--from/--via/--to", cli_unit="m, m, deg",
          required=True),
    Field("method", _per_segment_schema(_choice_schema(METHODS)),
          "Interpolation method, or a list with one per segment.", default="sclerp",
          cli_option="--method"),
    Field("beta", _per_segment_schema({"type": "number", "minimum": BETA_RANGE[0],
                                       "maximum": BETA_RANGE[1]}),
          "KenLERP bias β, or a list with one per segment: 0 is SEP-LERP, 1 ScLERP, above 1 "
          "extrapolates past ScLERP; negative values are refused. Only kenlerp reads it.",
          default=1.0, cli_option="--beta"),
    Field("turn", _per_segment_schema(_choice_schema(TURNS)),
          "Turn direction of θ, or a list with one per segment.", default="shortest",
          cli_option="--turn"),
    Field("duration",
          {"oneOf": [{"type": "number", "exclusiveMinimum": 0, "maximum": MAX_DURATION},
                     {"type": "string", "enum": ["auto"]}]},
          "Total seconds (rounded up to whole sample periods; at least one period per "
          f"segment and at most {MAX_SAMPLES} samples), or \"auto\": the shortest within the "
          "joint limits.", default="auto", unit="s", cli_option="--duration"),
    Field("profile", {"type": "string", "enum": list(PROFILES)},
          "Time law: \"optimal\" (the default) times the whole path time-optimally within "
          "every joint's velocity, acceleration and (where configured) jerk limit; "
          "\"linear\", \"quintic\" and \"trapezoid\" stretch one uniform law over each "
          "segment (or the blended path).", default="optimal",
          cli_option="--profile"),
    Field("rate_hz", {"type": "number", "minimum": RATE_RANGE[0], "maximum": RATE_RANGE[1]},
          "Sample rate. Default: the arm's [bus] rate_hz.", default=None, unit="Hz",
          cli_option="--rate"),
    Field("blend", {"type": "boolean"},
          "Pass through via points with continuous velocity instead of stopping at each.",
          default=False, cli_option="--blend"),
    Field("start_joints",
          {"type": ["array", "null"], "minItems": 2, "maxItems": 3, "items": _ANGLE_ITEM},
          "Joint angles to start from, one per joint, each within its limits; a joint-space "
          "approach is prepended when they differ from the first waypoint's IK. Default: "
          "none (start at the first waypoint).", default=None, unit="rad", cli_unit="deg"),
    Field("elbow", {"type": ["string", "null"], "enum": [*ELBOWS, None]},
          "IK branch: \"up\" (q2 ≤ 0) or \"down\" (q2 ≥ 0); it also breaks the tie at a "
          "stretched-out (singular) start. Default: the arm's configured elbow.",
          default=None, cli_option="--elbow"),
    Field("start_state",
          {"type": ["object", "null"], "additionalProperties": False, "required": ["joints"],
           "properties": {
               "joints": {"type": "array", "minItems": 2, "maxItems": 3, "items": _ANGLE_ITEM},
               "velocities": {"type": "array", "minItems": 2, "maxItems": 3,
                              "items": {"type": "number"}},
               "accelerations": {"type": "array", "minItems": 2, "maxItems": 3,
                                 "items": {"type": "number"}}}},
          "A moving joint state to plan from (a retarget): joints (rad), velocities (rad/s) "
          "and accelerations (rad/s²), one per joint, each within its limit. The path runs "
          "from the pose at those joints through every waypoint, timed from that state "
          "(profile optimal). Default: none.", default=None, unit="rad, rad/s, rad/s²",
          cli_unit="deg, deg/s, deg/s²"),
)
_BY_NAME = {f.name: f for f in FIELDS}

#: The fields a move body may not give (a move starts from the arm's present joints).
MOVE_OMIT = ("start_joints", "start_state")


def field(name: str) -> Field:
    """The :class:`Field` called ``name`` (KeyError if there is none)."""
    return _BY_NAME[name]


def cli_choices(name: str) -> tuple[str, ...]:
    """The allowed values of the string field ``name``: method, turn, profile, elbow."""
    choices = _BY_NAME[name].choices
    if not choices:
        raise KeyError(f"{name} is not a choice field")
    return choices


def cli_option(path: str) -> str | None:
    """The CLI option behind a JSON field path (``rate_hz`` → ``--rate``), or None."""
    name = path.split("[", 1)[0].split(".", 1)[0]
    f = _BY_NAME.get(name)
    return None if f is None else f.cli_option


def request_schema(arm: Arm | None = None, omit: Iterable[str] = ()) -> dict[str, Any]:
    """JSON Schema (2020-12 / OpenAPI 3.1) of the plan request body.

    With ``arm`` the arm-dependent parts are exact: a waypoint has 2 or 3 entries by the
    arm's joint count, ``start_joints`` one entry per joint within that joint's limits, and
    the ``rate_hz`` default is the arm's bus rate. ``omit`` drops fields (a move body omits
    :data:`MOVE_OMIT`).
    """
    omit = set(omit)
    properties: dict[str, Any] = {}
    for f in FIELDS:
        if f.name in omit:
            continue
        schema = _copy(f.schema)
        if arm is not None:
            _specialise(f.name, schema, arm)
        schema["description"] = f.description + (f" Unit: {f.unit}." if f.unit else "")
        default = f.default
        if f.name == "rate_hz" and arm is not None:
            default = arm.bus.rate_hz
        if default is not None or f.name in ("start_joints", "elbow"):
            schema["default"] = default
        properties[f.name] = schema
    return {"type": "object", "additionalProperties": False,
            "required": [f.name for f in FIELDS if f.required and f.name not in omit],
            "properties": properties}


def _copy(schema: Any) -> Any:
    if isinstance(schema, dict):
        return {k: _copy(v) for k, v in schema.items()}
    if isinstance(schema, list):
        return [_copy(v) for v in schema]
    return schema


def _specialise(name: str, schema: dict[str, Any], arm: Arm) -> None:
    if name == "waypoints":
        schema["items"]["minItems"] = 2 if arm.dof == 2 else 3
    elif name == "start_joints":
        schema["minItems"] = schema["maxItems"] = arm.dof
        schema["prefixItems"] = [{"type": "number", "minimum": j.min_angle,
                                  "maximum": j.max_angle} for j in arm.joints]
        schema["items"] = False
    elif name == "start_state":
        props = schema["properties"]
        for key, bound in (("joints", None), ("velocities", "max_velocity"),
                           ("accelerations", "max_acceleration")):
            item = props[key]
            item["minItems"] = item["maxItems"] = arm.dof
            item["prefixItems"] = [
                {"type": "number", "minimum": j.min_angle, "maximum": j.max_angle}
                if bound is None else
                {"type": "number", "minimum": -getattr(j, bound), "maximum": getattr(j, bound)}
                for j in arm.joints]
            item["items"] = False


# -- checks shared by the parser and PlanRequest ------------------------------------------------

def is_number(value: Any) -> bool:
    """A real number, not a bool (JSON ``true`` is not 1)."""
    return (isinstance(value, int | float | np.integer | np.floating)
            and not isinstance(value, bool | np.bool_))


def _show(value: Any) -> str:
    """A short form of a JSON value for messages: never a deep repr or a 400-digit number."""
    if isinstance(value, dict):
        return "an object"
    if isinstance(value, list | tuple) and any(isinstance(v, dict | list | tuple)
                                               for v in value):
        return f"an array of {len(value)} arrays/objects"
    if isinstance(value, list | tuple) and len(value) > 8:
        return f"an array of {len(value)} entries"
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**15:
        return f"an integer of {len(str(abs(value)))} digits"
    if isinstance(value, float | np.floating):
        text = f"{float(value):g}"
    elif isinstance(value, list | tuple):
        try:  # the user's own JSON, not a Python repr
            text = json.dumps(list(value), allow_nan=True)
        except (TypeError, ValueError):
            text = repr(value)
    else:
        text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def fail(path: str, reason: str, value: Any, *, too_large: bool = False) -> InputError:
    """The InputError (TooLargeError) for ``path``; message ``"<path> <reason>"``.

    ``reason`` is kept on the error (``.reason``) so that a surface can restate it under
    its own name for the field (:func:`robodcn.messages.describe`).
    """
    cls = TooLargeError if too_large else InputError
    err = cls(f"{path} {reason}", field=path, value=value)
    err.reason = reason  # type: ignore[attr-defined]
    return err


def _range_text(schema: Mapping[str, Any], unit: str | None) -> str:
    lo = schema.get("minimum")
    hi = schema.get("maximum")
    xlo = schema.get("exclusiveMinimum")
    u = f" {unit}" if unit else ""
    if xlo is not None and hi is not None:
        return f"greater than {xlo:g} and at most {hi:g}{u}"
    if lo is not None and hi is not None:
        return f"within {lo:g}..{hi:g}{u}"
    if xlo is not None:
        return f"greater than {xlo:g}{u}"
    return "a finite number"


def check_number(path: str, value: Any, schema: Mapping[str, Any],
                 unit: str | None = None) -> float:
    """``value`` as a float within ``schema``'s minimum/maximum/exclusiveMinimum.

    Refuses bools, non-numbers, integers too large for a float and non-finite values.
    """
    if not is_number(value):
        raise fail(path, f"must be a number, got {_show(value)}", value)
    try:
        x = float(value)
    except OverflowError:
        raise fail(path, f"must be {_range_text(schema, unit)}, got {_show(value)}",
                   value) from None
    if not math.isfinite(x):
        raise fail(path, f"must be a finite number, got {_show(value)}", value)
    lo = schema.get("minimum", -math.inf)
    hi = schema.get("maximum", math.inf)
    xlo = schema.get("exclusiveMinimum")
    if not lo <= x <= hi or (xlo is not None and not x > xlo):
        raise fail(path, f"must be {_range_text(schema, unit)}, got {_show(value)}", value)
    return x


def check_choice(path: str, value: Any, choices: tuple[str, ...]) -> str:
    """``value`` when it is one of ``choices``; the error lists them plainly."""
    if not isinstance(value, str) or value not in choices:
        raise fail(path, f"must be one of {', '.join(choices)}, got {_show(value)}", value)
    return value


def check_per_segment(name: str, value: Any, segments: int) -> Any:
    """One value for every segment, or a list/tuple of one per segment (a tuple).

    ``method``/``turn`` take choices, ``beta`` numbers within :data:`BETA_RANGE`; an entry's
    error names it (``beta[1]``), a list of the wrong length names the field.
    """
    f = _BY_NAME[name]
    one = f.schema["oneOf"][0]

    def check(path: str, v: Any) -> Any:
        if one["type"] == "number":
            return check_number(path, v, one, f.unit)
        return check_choice(path, v, f.choices)

    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, list | tuple):
        if len(value) != segments:
            raise fail(name, f"as a list needs one entry per segment ({segments}), got "
                       f"{len(value)}", value)
        return tuple(check(f"{name}[{i}]", v) for i, v in enumerate(value))
    if one["type"] == "number" or isinstance(value, str):
        return check(name, value)
    raise fail(name, f"must be one of {', '.join(f.choices)} or a list of them, got "
               f"{_show(value)}", value)


def check_waypoints(value: Any, arm: Arm) -> tuple[tuple[float, float, float], ...]:
    """(m, 3) or, on a 2-joint arm, (m, 2) poses → m (x, y, θ) tuples (θ = 0 when absent).

    The count is checked first (at most :data:`MAX_WAYPOINTS`: TooLargeError), so a huge
    list is refused without being read.
    """
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, list | tuple):
        raise fail("waypoints", f"must be a list of poses [x, y, θ], got {_show(value)}", value)
    f = _BY_NAME["waypoints"]
    if len(value) > MAX_WAYPOINTS:
        raise fail("waypoints", f"has {len(value)} poses, at most {MAX_WAYPOINTS} are "
                   "accepted", len(value), too_large=True)
    if len(value) < 2:
        raise fail("waypoints", f"needs at least 2 poses, got {len(value)}", value)
    sizes = (2, 3) if arm.dof == 2 else (3,)
    shape = "[x, y] or [x, y, θ]" if arm.dof == 2 else "[x, y, θ]"
    items = f.schema["items"]["prefixItems"]
    out = []
    for i, pose in enumerate(value):
        if isinstance(pose, np.ndarray):
            pose = pose.tolist()
        if not isinstance(pose, list | tuple) or len(pose) not in sizes:
            raise fail(f"waypoints[{i}]", f"must be {shape} (metres, radians), got "
                       f"{_show(pose)}", pose)
        xs = [check_number(f"waypoints[{i}][{k}]", v, items[k], "rad" if k == 2 else "m")
              for k, v in enumerate(pose)]
        out.append((xs[0], xs[1], xs[2] if len(xs) == 3 else 0.0))
    return tuple(out)


def check_start_joints(value: Any, arm: Arm) -> tuple[float, ...] | None:
    """None, or one finite angle per joint within that joint's limits (``start_joints[i]``)."""
    if value is None:
        return None
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, list | tuple):
        raise fail("start_joints", f"must be a list of {arm.dof} joint angles (rad), got "
                   f"{_show(value)}", value)
    if len(value) != arm.dof:
        raise fail("start_joints", f"must have {arm.dof} entries (one per joint of arm "
                   f"{arm.name!r}), got {len(value)}", value)
    out = []
    for i, (v, joint) in enumerate(zip(value, arm.joints, strict=True)):
        path = f"start_joints[{i}]"
        x = check_number(path, v, _ANGLE_ITEM, "rad")
        # Same slack as the planner's position check: float rounding only.
        if not joint.min_angle - 1e-9 <= x <= joint.max_angle + 1e-9:
            raise fail(path, f"= {x:.4f} rad is outside joint {joint.name!r}'s limits "
                       f"{joint.min_angle:.4f}..{joint.max_angle:.4f} rad", v)
        out.append(x)
    return tuple(out)


def check_start_state(value: Any, arm: Arm
                      ) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]] | None:
    """None, or (joints, velocities, accelerations) of a start state, each within the arm's
    limits (``start_state.joints[i]``, ``start_state.velocities[i]``, …); velocities and
    accelerations default to zeros. Accepts a StartState or a dict with those keys."""
    if value is None:
        return None
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = {"joints": value.joints, "velocities": value.velocities,
                 "accelerations": value.accelerations}
    if not isinstance(value, Mapping):
        raise fail("start_state", "must be an object {joints, velocities, accelerations}, got "
                   f"{_show(value)}", value)
    unknown = set(value) - {"joints", "velocities", "accelerations"}
    if unknown:
        name = sorted(unknown)[0]
        raise fail(f"start_state.{name}", "is not a field; allowed: joints, velocities, "
                   "accelerations", value[name])
    if value.get("joints") is None:
        raise fail("start_state.joints", "is required", None)
    try:
        joints = check_start_joints(value["joints"], arm)
    except InputError as exc:
        field = str(exc.field or "start_joints").replace("start_joints", "start_state.joints")
        raise fail(field, getattr(exc, "reason", str(exc)), exc.value) from None
    assert joints is not None
    joints = tuple(joints)
    out: list[tuple[float, ...]] = [joints]
    for name, limit_of, unit in (("velocities", "max_velocity", "rad/s"),
                                 ("accelerations", "max_acceleration", "rad/s²")):
        given = value.get(name)
        if given is None:
            out.append((0.0,) * arm.dof)
            continue
        if isinstance(given, np.ndarray):
            given = given.tolist()
        if not isinstance(given, list | tuple) or len(given) != arm.dof:
            raise fail(f"start_state.{name}", f"must be a list of {arm.dof} numbers ({unit}), "
                       f"got {_show(given)}", given)
        row = []
        for i, (v, joint) in enumerate(zip(given, arm.joints, strict=True)):
            path = f"start_state.{name}[{i}]"
            if not is_number(v) or not math.isfinite(float(v)):
                raise fail(path, f"must be a finite number ({unit}), got {_show(v)}", v)
            limit = getattr(joint, limit_of)
            if abs(float(v)) > limit * (1 + 1e-9):
                raise fail(path, f"= {float(v):.4g} {unit} is beyond joint {joint.name!r}'s "
                           f"limit {limit:.4g} {unit}", v)
            row.append(float(v))
        out.append(tuple(row))
    return out[0], out[1], out[2]


def check_duration(value: Any, rate_hz: float, segments: int) -> float | str:
    """"auto", or seconds whose sample count fits (TooLargeError) and covers every segment."""
    if isinstance(value, str):
        return check_choice("duration", value, ("auto",))
    f = _BY_NAME["duration"]
    x = check_number("duration", value, f.schema["oneOf"][0], "s")
    n = intervals(x, rate_hz)
    if n + 1 > MAX_SAMPLES:
        raise fail("duration", f"{x:g} s at {rate_hz:g} Hz needs {n + 1} samples, more than "
                   f"{MAX_SAMPLES}: shorten the duration or lower rate_hz", value,
                   too_large=True)
    if n < segments:
        raise fail("duration", f"{x:g} s at {rate_hz:g} Hz gives {n} sample periods for "
                   f"{segments} segments: each needs at least one", value)
    return x


def intervals(duration: float, rate: float) -> int:
    """Whole sample periods covering ``duration`` (rounded up; 1e-9 absorbs float noise).

    Callers bound ``duration`` first (:data:`MAX_DURATION`), so the product is finite.
    """
    return max(1, math.ceil(duration * rate - 1e-9))


def check_field(name: str, value: Any) -> Any:
    """The arm-independent single-value fields: profile, rate_hz, blend, elbow."""
    f = _BY_NAME[name]
    if name == "rate_hz":
        return check_number(name, value, f.schema, f.unit)
    if name == "profile":
        return check_choice(name, value, f.choices)
    if name == "elbow":
        return None if value is None else check_choice(name, value, f.choices)
    if name == "blend":
        if not isinstance(value, bool | np.bool_):
            raise fail(name, f"must be true or false, got {_show(value)}", value)
        return bool(value)
    raise KeyError(name)


# -- the JSON body ----------------------------------------------------------------------------

def parse_request(body: object, arm: Arm, *, omit: Iterable[str] = ()) -> Any:
    """A decoded JSON body → a validated :class:`~robodcn.planner.PlanRequest` for ``arm``.

    Every error is an InputError (TooLargeError for the caps) whose ``field`` is the JSON
    path of the bad value, raised before anything is planned: unknown fields (and those in
    ``omit``), wrong JSON types (a bool is not a number, an object is not a list), integers
    too large for a float, non-finite or out-of-range numbers, too many waypoints, a
    duration × rate over the sample cap. ``rate_hz`` defaults to the arm's bus rate.
    """
    from robodcn.planner import PlanRequest  # the planner imports this module

    if not isinstance(body, dict):
        raise fail("body", f"must be a JSON object, got {type(body).__name__}", None)
    omit = set(omit)
    for name in body:
        if name not in _BY_NAME or name in omit:
            hint = (" (a move starts from the arm's present joints)"
                    if name == "start_joints" else "")
            allowed = ", ".join(f.name for f in FIELDS if f.name not in omit)
            raise fail(str(name), f"is not a field{hint}; allowed: {allowed}", body[name])
    if "waypoints" not in body:
        raise fail("waypoints", "is required", None)
    # JSON types first (lists, not tuples or arrays, reach here from json.loads).
    for name in ("waypoints", "start_joints"):
        value = body.get(name)
        if value is not None and not isinstance(value, list):
            raise fail(name, f"must be an array, got {_show(value)}", value)
    args = dict(body)
    args.setdefault("rate_hz", arm.bus.rate_hz)
    return PlanRequest(arm=arm, **args)


# -- schemas of result dataclasses ------------------------------------------------------------

_SCALARS: dict[Any, dict[str, Any]] = {
    float: {"type": "number"}, int: {"type": "integer"}, str: {"type": "string"},
    bool: {"type": "boolean"}, type(None): {"type": "null"},
}


def _schema_of_type(hint: Any) -> dict[str, Any]:
    if hint in _SCALARS:
        return dict(_SCALARS[hint])
    if dataclasses.is_dataclass(hint) and isinstance(hint, type):
        return schema_of(hint)
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin is typing.Annotated:
        return _schema_of_type(args[0])
    if origin is typing.Literal:
        values = list(args)
        kinds = {type(v) for v in values}
        out: dict[str, Any] = {"enum": values}
        if kinds == {str}:
            out["type"] = "string"
        return out
    if origin in (typing.Union, types.UnionType):
        options = [_schema_of_type(a) for a in args]
        simple = [o.get("type") for o in options]
        if all(isinstance(t, str) for t in simple) and all(len(o) == 1 for o in options):
            return {"type": simple}
        return {"anyOf": options}
    if origin in (tuple,):
        if len(args) == 2 and args[1] is Ellipsis:
            return {"type": "array", "items": _schema_of_type(args[0])}
        return {"type": "array", "prefixItems": [_schema_of_type(a) for a in args],
                "minItems": len(args), "maxItems": len(args), "items": False}
    if origin in (list, typing.Sequence, Iterable) or (origin is not None and \
            getattr(origin, "__name__", "") in ("Sequence", "list")):
        return {"type": "array", "items": _schema_of_type(args[0]) if args else {}}
    if origin is dict:
        return {"type": "object",
                "additionalProperties": _schema_of_type(args[1]) if len(args) == 2 else {}}
    if hint is Any:
        return {}
    raise TypeError(f"no JSON Schema for type {hint!r}: give metadata={{'schema': ...}}")


def schema_of(cls: type) -> dict[str, Any]:
    """JSON Schema of the dataclass ``cls`` from its type hints and field metadata.

    A field's ``metadata`` may carry ``"description"`` and ``"schema"`` (a schema that
    replaces the one derived from the hint, e.g. for numpy arrays); ``"json": False`` leaves
    the field out. Fields without a default are required.
    """
    hints = typing.get_type_hints(cls, include_extras=False)
    properties: dict[str, Any] = {}
    required = []
    for f in dataclasses.fields(cls):
        if not f.metadata.get("json", True):
            continue
        schema = dict(f.metadata["schema"]) if "schema" in f.metadata \
            else _schema_of_type(hints[f.name])
        if "description" in f.metadata:
            schema["description"] = f.metadata["description"]
        properties[f.name] = schema
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            required.append(f.name)
    out: dict[str, Any] = {"type": "object", "properties": properties, "required": required}
    doc = (cls.__doc__ or "").strip().split("\n", 1)[0]
    if doc:
        out["description"] = doc
    return out
