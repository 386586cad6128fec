"""Checks of request values against the contract's schemas (:mod:`.fields`).

Every failure is an :class:`~robodcn.errors.InputError` (``TooLargeError`` for the caps) from
:func:`fail`, whose ``field`` is the JSON path of the bad value (``waypoints[2][1]``,
``start_state.velocities[0]``) and whose ``reason`` restates it without the path. Ranges and
choices are read from the fields' schemas, so the checks and the OpenAPI document agree.

Cross-field rules the schema cannot say: ``duration × rate_hz`` sample periods must cover
one per segment and stay within :data:`MAX_SAMPLES` samples (413); ``waypoints`` holds at
most :data:`MAX_WAYPOINTS` poses (413); a waypoint is (x, y, θ), or (x, y) on a 2-joint
(position-only) arm, or (x, y, z, pitch) on an arm with a base yaw (:func:`waypoint_shape`);
``start_joints`` has one angle per joint, each within that joint's limits; per-segment
lists of ``method``/``turn``/``beta`` have one entry per segment.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from robodcn._checks import is_finite_real, is_real
from robodcn.config import Arm
from robodcn.contract.fields import (
    ANGLE_ITEM,
    FIELDS,
    MAX_SAMPLES,
    MAX_WAYPOINTS,
    TOOL_FIELDS,
    field,
    waypoints_field,
)
from robodcn.errors import InputError, TooLargeError


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


def fail(path: str, reason: str, value: Any, *, too_large: bool = False,
         number: float | None = None, bounds: tuple[float, float] | None = None,
         unit: str | None = None, joint: str | None = None) -> InputError:
    """The InputError (TooLargeError) for ``path``; message ``"<path> <reason>"``.

    ``reason`` is kept on the error (``.reason``) so that a surface can restate it under
    its own name for the field (:func:`robodcn.messages.describe`). A number out of its
    range also carries it as data: ``.number`` (the value given, SI), ``.bounds`` (the
    range, SI), ``.unit`` (its SI unit) and ``.joint`` (the joint whose limits they are), so
    that the command line can say it in degrees.
    """
    cls = TooLargeError if too_large else InputError
    err = cls(f"{path} {reason}", field=path, value=value)
    err.reason = reason  # type: ignore[attr-defined]
    err.number = number  # type: ignore[attr-defined]
    err.bounds = bounds  # type: ignore[attr-defined]
    err.unit = unit  # type: ignore[attr-defined]
    err.joint = joint  # type: ignore[attr-defined]
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
    if type(value) is float:  # the common case (JSON, Python): no type checks needed
        x = value
    else:
        if not is_real(value):
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
        raise fail(path, f"must be {_range_text(schema, unit)}, got {_show(value)}", value,
                   number=x, unit=unit,
                   bounds=(lo, hi) if xlo is None and math.isfinite(lo + hi) else None)
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
    f = field(name)
    # the common case, one valid choice for every segment: what check_choice returns
    if type(value) is str and value in f.choices:
        return value
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


def waypoint_shape(arm: Arm) -> tuple[tuple[int, ...], str]:
    """The numbers a waypoint of ``arm`` may have and their names: (x, y, θ), or (x, y) on
    a 2-joint arm; an arm with a base yaw (x, y, z, pitch), or (x, y, z) when its chain has
    two links (pitch free)."""
    if arm.yawed:
        if len(arm.chain_joints) == 2:
            return (3, 4), "[x, y, z] or [x, y, z, pitch]"
        return (4,), "[x, y, z, pitch]"
    if arm.dof == 2:
        return (2, 3), "[x, y] or [x, y, θ]"
    return (3,), "[x, y, θ]"


def check_waypoints(value: Any, arm: Arm, *, start: bool = False
                    ) -> tuple[tuple[float, ...], ...]:
    """(m, 3) poses (x, y, θ) → m tuples; on a 2-joint arm (m, 2) too (θ = 0 when absent);
    an arm with a base yaw (m, 4) (x, y, z, pitch), metres and radians (pitch = 0 when a
    2-link chain's waypoint omits it).

    The count is checked first (at most :data:`MAX_WAYPOINTS`: TooLargeError), so a huge
    list is refused without being read. Each error names the waypoint and the number
    (``waypoints[2]``, ``waypoints[2][3]``). At least two, or one when the request says
    where it starts (``start``: start_joints or start_state; the plan then runs from there).
    """
    if isinstance(value, np.ndarray):
        value = value.tolist()
    sizes, shape = waypoint_shape(arm)
    if not isinstance(value, list | tuple):
        raise fail("waypoints", f"must be a list of poses {shape}, got {_show(value)}", value)
    f = waypoints_field(arm)
    if len(value) > MAX_WAYPOINTS:
        raise fail("waypoints", f"has {len(value)} poses, at most {MAX_WAYPOINTS} are "
                   "accepted", len(value), too_large=True)
    check_waypoint_count(value, start)
    items = f.schema["items"]["prefixItems"]
    width = max(sizes)
    bounds = _item_bounds(items)
    out = []
    for i, pose in enumerate(value):
        if isinstance(pose, np.ndarray):
            pose = pose.tolist()
        if not isinstance(pose, list | tuple) or len(pose) not in sizes:
            raise fail(f"waypoints[{i}]", f"must be {shape} (metres, radians), got "
                       f"{_show(pose)}", pose)
        # a float within its item's range is check_number's own answer (inf and NaN fail
        # the comparisons); anything else is checked there, which names what is wrong
        xs = [v if type(v) is float and bounds[k][0] <= v <= bounds[k][1] else
              check_number(f"waypoints[{i}][{k}]", v, items[k],
                           "rad" if k == width - 1 else "m")
              for k, v in enumerate(pose)]
        out.append((*xs, *(0.0,) * (width - len(xs))))
    return tuple(out)


#: id(prefixItems list) → (that list, per item (minimum, maximum)); the list is held, so
#: its id is never another's
_BOUNDS: dict[int, tuple[list, tuple[tuple[float, float], ...]]] = {}


def _item_bounds(items: list[Mapping[str, Any]]) -> tuple[tuple[float, float], ...]:
    """Each pose item's closed range, read once per schema (an item with an exclusive
    bound gets an empty range: check_number decides it)."""
    found = _BOUNDS.get(id(items))
    if found is None or found[0] is not items:
        found = _BOUNDS[id(items)] = (items, tuple(
            (math.inf, -math.inf) if "exclusiveMinimum" in it else
            (float(it.get("minimum", -math.inf)), float(it.get("maximum", math.inf)))
            for it in items))
    return found[1]


def check_waypoint_count(value: list | tuple, start: bool) -> None:
    """At least two waypoints, or one when the request says where it starts (``start``:
    start_joints or start_state)."""
    if len(value) < (1 if start else 2):
        raise fail("waypoints", f"needs at least {1 if start else 2} pose"
                   f"{'' if start else 's'}, got {len(value)}"
                   + ("" if start else " (one is enough with start_joints or start_state: "
                      "the plan then runs from there)"), list(value))


def check_start_joints(value: Any, arm: Arm, name: str = "start_joints"
                       ) -> tuple[float, ...] | None:
    """None, or one finite angle per joint within that joint's limits (``start_joints[i]``;
    ``name`` is the field's JSON path: ``start_state.joints`` for a start state's)."""
    if value is None:
        return None
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, list | tuple):
        raise fail(name, f"must be a list of {arm.dof} joint angles (rad), got "
                   f"{_show(value)}", value)
    if len(value) != arm.dof:
        raise fail(name, f"must have {arm.dof} entries (one per joint of arm "
                   f"{arm.name!r}), got {len(value)}", value)
    out = []
    for i, (v, joint) in enumerate(zip(value, arm.joints, strict=True)):
        path = f"{name}[{i}]"
        x = check_number(path, v, ANGLE_ITEM, "rad")
        # Same slack as the planner's position check: float rounding only.
        if not joint.min_angle - 1e-9 <= x <= joint.max_angle + 1e-9:
            raise fail(path, f"= {x:.4f} rad is outside the limits of joint "
                       f"{joint.name!r}, {joint.min_angle:.4f}..{joint.max_angle:.4f} rad", v,
                       number=x, bounds=(joint.min_angle, joint.max_angle), unit="rad",
                       joint=joint.name)
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
    joints = check_start_joints(value["joints"], arm, "start_state.joints")
    assert joints is not None
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
            if not is_finite_real(v):
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
    f = field("duration")
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
    """The arm-independent single-value fields: profile, rate_hz, blend, elbow, payload_kg."""
    f = field(name)
    if name in ("rate_hz", "payload_kg"):
        return check_number(name, value, f.schema, f.unit)
    if name in TOOL_FIELDS:
        return None if value is None else check_number(name, value, f.schema, f.unit)
    if name == "profile":
        return check_choice(name, value, f.choices)
    if name == "elbow":
        return None if value is None else check_choice(name, value, f.choices)
    if name == "blend":
        if not isinstance(value, bool | np.bool_):
            raise fail(name, f"must be true or false, got {_show(value)}", value)
        return bool(value)
    raise KeyError(name)


#: The ``[tool]`` ceiling of each tool field, and its key in the arm file.
_TOOL_CEILINGS = {"tool_speed": "max_speed", "tool_angular_speed": "max_angular_speed",
                  "tool_acceleration": "max_acceleration"}


def check_tool_ceiling(name: str, value: float | None, arm: Arm) -> float | None:
    """``value`` (a checked tool field, SI) when within the arm's ``[tool]`` ceiling (none
    there: any); the error names the field, the value and the ceiling."""
    key = _TOOL_CEILINGS[name]
    top = getattr(arm.tool, key)
    if value is not None and top is not None and value > top * (1 + 1e-12):
        unit = field(name).unit
        raise fail(name, f"must be at most the arm's [tool] {key} {top:.6g} {unit}, got "
                   f"{value:.6g} {unit}", value)
    return value


def check_body(body: object, omit: Iterable[str] = ()) -> dict[str, Any]:
    """A decoded JSON body's own rules, before its values are checked: an object, no unknown
    fields (nor those in ``omit``), ``waypoints`` given, JSON arrays where lists belong (lists,
    not tuples or arrays, reach here from json.loads). Returns the body's fields as keywords
    of :class:`~robodcn.contract.PlanRequest`."""
    if not isinstance(body, dict):
        raise fail("body", f"must be a JSON object, got {type(body).__name__}", None)
    omit = set(omit)
    names = {f.name for f in FIELDS}
    for name in body:
        if name not in names or name in omit:
            hint = (" (a move starts from the arm's present joints)"
                    if name == "start_joints" else "")
            allowed = ", ".join(f.name for f in FIELDS if f.name not in omit)
            raise fail(str(name), f"is not a field{hint}; allowed: {allowed}", body[name])
    if "waypoints" not in body:
        raise fail("waypoints", "is required", None)
    for name in ("waypoints", "start_joints"):
        value = body.get(name)
        if value is not None and not isinstance(value, list):
            raise fail(name, f"must be an array, got {_show(value)}", value)
    return dict(body)
