"""Errors and violations in the user's terms: CLI (degrees, options) or HTTP (SI, JSON fields).

:func:`describe` words a :class:`~robodcn.errors.RobodcnError` or a
:class:`~robodcn.errors.Violation` from its data, never from another message's text:

* ``units="cli"``: angles in degrees (°, deg/s, deg/s², deg/s³, the config's units), the
  option the user typed (``--rate``, ``--duration``) for request fields;
* ``units="si"``: radians, rad/s, ..., and the JSON field (``rate_hz``, ``waypoints[2]``).

A violation on a multi-segment plan names its segment (waypoint i → i + 1); a joint or tick
limit says whether the other elbow branch would pass.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, Literal

from robodcn import contract, kinematics
from robodcn.errors import PlanError, RobodcnError, Violation

Units = Literal["cli", "si"]

#: (CLI unit, factor from SI) per SI unit.
_CLI_UNITS = {"rad": ("°", 180.0 / math.pi), "rad/s": ("deg/s", 180.0 / math.pi),
              "rad/s^2": ("deg/s²", 180.0 / math.pi), "rad/s^3": ("deg/s³", 180.0 / math.pi),
              "m": ("m", 1.0), "tick": ("", 1.0), "N*m": ("N·m", 1.0),
              "m/s": ("m/s", 1.0), "m/s^2": ("m/s²", 1.0)}
_SI_UNITS = {"rad": " rad", "rad/s": " rad/s", "rad/s^2": " rad/s²", "rad/s^3": " rad/s³",
             "m": " m", "tick": "", "N*m": " N·m", "m/s": " m/s", "m/s^2": " m/s²"}
#: What a tool quantity is, in words.
_TOOL_WHAT = {"tool_speed": "the tool point moves at",
              "tool_angular_speed": "the tool turns at",
              "tool_acceleration": "the tool point accelerates along its path at"}
_WHAT = {"velocity": "velocity", "acceleration": "acceleration", "jerk": "jerk",
         "torque": "torque"}


def quantity(value: float, unit: str, units: Units) -> str:
    """``value`` (SI ``unit``) as text in the user's units: 0.5 rad → "28.6°" on the CLI."""
    if units == "cli":
        name, factor = _CLI_UNITS.get(unit, (unit, 1.0))
        x = value * factor
        if name == "°":
            return f"{round(x, 1) + 0.0:.1f}°"             # + 0.0: never "-0.0°"
        return f"{x:.4g} {name}".rstrip()
    return f"{value:.4g}{_SI_UNITS.get(unit, ' ' + unit)}"


#: Units whose value and limit always print with the same significant digits ("needs
#: 2.807 N·m, limit 2.800 N·m"): a torque limit is a round figure the value is read against.
SAME_DIGITS = frozenset({"N*m"})


def quantity_pair(value: float, limit: float, unit: str, units: Units) -> tuple[str, str]:
    """``value`` and ``limit`` as :func:`quantity` words them (both with the same
    significant digits for :data:`SAME_DIGITS`), with more digits where those would read
    alike: d significant digits (decimals of a degree) from d = ⌈−log₁₀ of the
    relative gap |value − limit| / |limit|⌉ + 1 up until the two differ, so "needs 2.800011
    N·m, limit 2.800000 N·m" tells a value 3.9e-6 above its limit from the limit."""
    a, b = quantity(value, unit, units), quantity(limit, unit, units)
    if not (math.isfinite(value) and math.isfinite(limit)) or (
            unit not in SAME_DIGITS and (a != b or value == limit)):
        return a, b
    scale = max(abs(limit), abs(value))
    gap = abs(value - limit) / scale if scale > 0 and value != limit else 1.0
    name, factor = _CLI_UNITS.get(unit, (unit, 1.0)) if units == "cli" else (None, 1.0)
    suffix = f" {name}".rstrip() if units == "cli" else _SI_UNITS.get(unit, " " + unit)
    whole = len(str(int(abs(limit * factor))))
    for digits in range(max(4, math.ceil(-math.log10(gap)) + 1), 18):
        if name == "°":
            places = max(1, digits - whole)
            a, b = (f"{round(x * factor, places) + 0.0:.{places}f}°" for x in (value, limit))
        else:
            a, b = (f"{x * factor:#.{digits}g}{suffix}" for x in (value, limit))
        if a != b or value == limit:
            break
    return a, b


def pose_text(pose: Sequence[float], units: Units) -> str:
    """x, y (and an arm with a base yaw's z) in metres; θ (pitch) in degrees on the CLI,
    radians over HTTP."""
    name = "pitch" if len(pose) == 4 else "θ"
    angle = (f"{name}={math.degrees(pose[-1]):.1f}°" if units == "cli"
             else f"{name}={pose[-1]:.4f} rad")
    z = f"z={pose[2]:.4f} m, " if len(pose) == 4 else ""
    return f"x={pose[0]:.4f} m, y={pose[1]:.4f} m, {z}{angle}"


def _reach_text(v: Violation, units: Units) -> str:
    """Why a sample is out of reach (its value, limit and unit; an arm with a base yaw's
    path may pass its yaw axis or point the tool back over the base)."""
    if len(v.pose) != 4:
        return (f"is out of reach: the wrist point is {v.value:.4f} m from the base, the arm "
                f"reaches to {v.limit:.4f} m")
    if v.unit == "rad":
        return (f"points the tool back over the base (|pitch| = "
                f"{quantity(v.value, 'rad', units)} past {quantity(v.limit, 'rad', units)}): "
                "the arm does not reach over the top")
    if v.limit <= kinematics.AXIS_TOLERANCE:
        return (f"passes the yaw axis (r = {v.value:.4f} m in the arm's plane): the arm does "
                "not reach over the top; turn the yaw instead")
    return (f"is out of reach: the wrist point is {v.value:.4f} m from the shoulder, the arm "
            f"reaches to {v.limit:.4f} m")


def depth_text(depth: float, units: Units) -> str:
    """How deep (m) a point lies inside a zone: millimetres on the CLI ("100.0 mm"),
    metres with the millimetres over HTTP ("0.1000 m (100.0 mm)")."""
    mm = f"{depth * 1e3:.1f} mm"
    return mm if units == "cli" else f"{depth:.4f} m ({mm})"


def point_name(point: str | None, is_joint: bool) -> str:
    """A tested point of the arm in words: "tool point", "'elbow' joint" (a joint centre),
    or the link's own name ("wrist–tool link")."""
    if point == "tool":
        return "tool point"
    return f"{point!r} joint" if is_joint else f"{point}"


def keepout_text(v: Violation, units: Units) -> str:
    """Which point of the arm is inside which keep-out zone, how deep and where."""
    where = ""
    if v.position is not None:
        x, y, z = v.position
        where = f" at x={x:.4f} m, y={y:.4f} m, z={z:.4f} m"
    point = point_name(v.point, v.joint is not None)
    return (f"the {point}{where} is {depth_text(v.value, units)} inside the arm's keep-out "
            f"zone {v.zone!r} ([workspace]): choose a pose or path clear of it")


def field_name(path: str | None, units: Units,
               waypoint_names: Sequence[str] | None = None,
               field_names: Mapping[str, str] | None = None) -> str | None:
    """The name the user knows a request field by: the CLI option or the JSON path.

    On the CLI a waypoint is named by the option that gave it when ``waypoint_names``
    (one per waypoint, e.g. ``["--from", "--via #1", "--to"]``) is passed. ``field_names``
    names fields the caller knows better (a waypoints file's ``waypoints[4].payload_kg``:
    "waypoint 4 (payload_kg = 0.9 in the file)"), in either units.
    """
    if field_names is not None and path in field_names:
        return field_names[path]
    if path is None or units == "si":
        return path
    if path.startswith("waypoints["):
        index = _index(path)
        if waypoint_names is not None and index is not None and index < len(waypoint_names):
            return waypoint_names[index]
        return path
    option = contract.cli_option(path)
    if option is None or "/" in option:
        return path
    return option


def _index(path: str) -> int | None:
    """i of "waypoints[i]..." (a path the contract built)."""
    head = path.split("]", 1)[0]
    digits = head.split("[", 1)[1] if "[" in head else ""
    return int(digits) if digits.isdigit() else None


def _waypoint(i: int, units: Units, names: Sequence[str] | None) -> str:
    if units == "cli" and names is not None and i < len(names):
        return names[i]
    return f"waypoint {i}" if units == "cli" else f"waypoints[{i}]"


def describe_violation(v: Violation, units: Units = "si",
                       waypoint_names: Sequence[str] | None = None,
                       field_names: Mapping[str, str] | None = None) -> str:
    """One line naming sample, time, pose, segment (or waypoint), joint, value and limit;
    the field to change is ``v.field`` in the user's terms (:func:`field_name`). A violation
    found before timing (no sample: a pose the arm cannot hold) names the waypoint, or the
    path's segment and pose."""
    where = []
    if v.waypoint is not None:
        where.append(_waypoint(v.waypoint, units, waypoint_names))
    elif v.segment is not None:
        a, b = (_waypoint(i, units, waypoint_names) for i in v.segment)
        where.append(f"segment {a} → {b}" if units == "cli" or waypoint_names
                     else f"segment waypoint {v.segment[0]} → {v.segment[1]}")
    if v.sample is not None:
        where[:0] = [f"sample {v.sample}"]
        where.append(f"t={v.t:.3f} s")
    elif v.waypoint is None:
        where[:0] = ["the path"]
    where.append(pose_text(v.pose, units))
    head = f"{where[0]} ({', '.join(where[1:])})"
    who = f"joint {v.joint!r} " if v.joint else ""
    if v.quantity == "reach":
        return f"{head}: {_reach_text(v, units)}"
    if v.quantity == "keepout":
        text = f"{head}: {keepout_text(v, units)}"
        if v.other_branch_ok:
            flag = "--elbow" if units == "cli" else "elbow"
            text += f"; the other elbow branch would pass ({flag})"
        return text
    if v.quantity == "position":
        text = (f"{head}: {who}at {quantity(v.value, v.unit, units)} is outside its limit "
                f"{quantity(v.limit, v.unit, units)}")
    elif v.quantity == "ticks":
        text = f"{head}: {who}needs tick {v.value:.0f}, outside its tick limit {v.limit:.0f}"
    elif v.quantity in _TOOL_WHAT:
        text = (f"{head}: {_TOOL_WHAT[v.quantity]} {quantity(v.value, v.unit, units)}, above "
                f"{field_name(v.field, units)} {quantity(v.limit, v.unit, units)}: lengthen "
                f"{field_name('duration', units)} (or raise {field_name(v.field, units)})")
    elif v.quantity == "torque" and v.field.rsplit(".", 1)[-1] == "payload_kg":
        # gravity alone (links and payload) overloads the joint there: no timing helps (the
        # field is the request's payload_kg, or a file's waypoints[4].payload_kg)
        value, limit = quantity_pair(v.value, v.limit, v.unit, units)
        text = (f"{head}: {who}needs {value} just to hold the arm, limit {limit} (torque): "
                "lighten "
                f"{field_name(v.field, units, field_names=field_names)} or avoid that pose")
    else:
        option = field_name(v.field, units, field_names=field_names)
        value, limit = quantity_pair(v.value, v.limit, v.unit, units)
        text = (f"{head}: {who}needs {value}, limit {limit} ({_WHAT[v.quantity]}): "
                f"lengthen {option}")
    if v.other_branch_ok is not None:
        flag = "--elbow" if units == "cli" else "elbow"
        text += ("; the other elbow branch would pass (" + flag + ")" if v.other_branch_ok
                 else "; the other elbow branch fails too")
    return text


def _range_in_units(item: Any, units: Units) -> str | None:
    """A number out of its range (contract.checks.fail's data) restated in the user's
    units: ``= 83.2° is outside the limits of joint 'elbow', -103.0°..80.2°`` on the CLI for
    ``start_joints[2] = 1.4527 rad …``; None where the error's own reason says it already."""
    number, bounds, unit = (getattr(item, k, None) for k in ("number", "bounds", "unit"))
    if units != "cli" or number is None or bounds is None or unit not in _CLI_UNITS \
            or _CLI_UNITS[unit][1] == 1.0:
        return None
    lo, hi = (quantity(b, unit, units) for b in bounds)
    joint = getattr(item, "joint", None)
    if joint is not None:
        return (f"= {quantity(number, unit, units)} is outside the limits of joint "
                f"{joint!r}, {lo}..{hi}")
    return f"must be within {lo}..{hi}, got {quantity(number, unit, units)}"


def describe(item: RobodcnError | Violation | Warning, units: Units = "si",
             waypoint_names: Sequence[str] | None = None,
             field_names: Mapping[str, str] | None = None) -> str:
    """``item`` in the user's terms (module docstring); errors from data, not text.

    For an InputError raised by :mod:`robodcn.contract` the field path is swapped for the
    CLI option (``--rate must be within 1..1000 Hz, got 5000``); a PlanError carrying a
    :class:`Violation` is reworded from it; anything else keeps its own message.
    """
    if isinstance(item, Violation):
        return describe_violation(item, units, waypoint_names, field_names)
    if isinstance(item, PlanError) and item.violation is not None:
        return describe_violation(item.violation, units, waypoint_names, field_names)
    reason = getattr(item, "reason", None)
    path = getattr(item, "field", None)
    if reason is not None and path is not None:
        name = field_name(path, units, waypoint_names, field_names)
        restated = _range_in_units(item, units)
        return f"{name} {restated or reason}"
    if isinstance(item, PlanError) and item.waypoint is not None and units == "cli" \
            and waypoint_names is not None and item.waypoint < len(waypoint_names):
        return f"{item.message} ({waypoint_names[item.waypoint]})"
    if isinstance(item, Warning):
        message: Any = getattr(item, "message", str(item))
        return str(message).replace("beta", field_name("beta", units) or "beta", 1)
    return str(getattr(item, "message", item))
