"""A waypoints TOML (``robodcn teach`` writes one, ``robodcn run`` plays it).

``[[waypoints]]`` tables with the arm's pose keys: ``x``, ``y`` (metres) and ``theta_deg``
(or ``theta``, radians) on a planar arm; ``x``, ``y``, ``z`` (metres) and ``pitch_deg`` (or
``pitch``, radians) on an arm with a base yaw. A waypoint may carry ``method`` / ``turn`` /
``beta`` for the segment that leads to it, ``gripper = "open" | "close"`` (acted on there,
the arm at rest) and ``payload_kg`` (the mass at the tool point from that waypoint on).
``[plan]`` holds ``method``, ``beta``, ``turn`` (the defaults of segments whose waypoint gives
none), ``duration``, ``profile``, ``rate_hz``, ``blend``, ``payload_kg`` (the payload at
the start) and the tool limits ``tool_speed`` (m/s), ``tool_angular_speed`` (rad/s) and
``tool_acceleration`` (m/s²) of every leg; ``arm`` names the arm the file was taught on
(``teach`` writes it): an example name or an arm config file, which ``run`` uses when no
``--arm`` is given
(:func:`waypoints_arm`).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn import contract
from robodcn.config import PLANAR_POSE, YAWED_POSE, Arm
from robodcn.errors import InputError
from robodcn.workflow.files._common import fail, in_file, number, read

PLAN_KEYS = ("method", "beta", "turn", "duration", "profile", "rate_hz", "blend", "payload_kg",
             *contract.TOOL_FIELDS)
#: What a waypoint may say besides its pose, acted on at that waypoint.
ACTION_KEYS = ("gripper", "payload_kg")
#: The gripper commands a waypoint may give.
GRIPPER_ACTIONS = ("open", "close")
#: What a segment takes when neither its waypoint nor ``[plan]`` says (the contract's).
SEGMENT_DEFAULTS = {key: contract.field(key).default for key in ("method", "turn", "beta")}
_SEGMENT_KEYS = tuple(SEGMENT_DEFAULTS)


@dataclass(frozen=True)
class WaypointsPlan:
    """A waypoints file: poses (m, len(keys)) in metres and radians (``keys`` the arm's pose
    keys), plan options given in the file, and per waypoint its actions (``gripper``,
    ``payload_kg``; an empty dict where it gives none)."""

    source: str
    waypoints: NDArray[np.float64]
    options: dict[str, Any]
    keys: tuple[str, ...] = PLANAR_POSE
    actions: tuple[Mapping[str, Any], ...] = field(default=())

    #: The file's ``arm`` (None: it names none).
    arm: str | None = None

    def plan_fields(self, **overrides: Any) -> dict[str, Any]:
        """PlanRequest keyword fields: the file's options, then ``overrides`` not None."""
        fields = dict(self.options)
        fields.update({k: v for k, v in overrides.items() if v is not None})
        fields["waypoints"] = self.waypoints
        return fields

    @property
    def has_actions(self) -> bool:
        """Whether any waypoint acts (a gripper command or a payload change)."""
        return any(self.actions)


def _payload(source: str, where: str, value: Any) -> float:
    """A payload in kg: a finite number ≥ 0."""
    with in_file(source, where):
        return contract.check_number(where, value, {"minimum": 0}, "kg")


def _plan_value(source: str, where: str, key: str, value: Any) -> Any:
    """A value of the file's ``[plan]`` (or a waypoint's method, turn or beta), checked as
    the request field ``key`` is (:mod:`robodcn.contract`): one value, not a list."""
    if key == "payload_kg":
        return _payload(source, where, value)
    f = contract.field(key)
    with in_file(source, where):
        if key in ("method", "turn"):
            return contract.check_choice(where, value, f.choices)
        if key == "beta" or (key == "duration" and not isinstance(value, str)):
            return contract.check_number(where, value, f.schema["oneOf"][0], f.unit)
        if key == "duration":
            return contract.check_choice(where, value, ("auto",))
        return contract.check_field(key, value)     # profile, rate_hz, blend, tool_*


def _file_keys(rows: Sequence[Any], arm: Arm | None) -> tuple[str, ...]:
    """The pose keys the file is read with: the arm's, else (no arm) a yawed arm's when a
    waypoint gives z or pitch."""
    if arm is not None:
        return arm.pose_keys
    yawed = any(isinstance(r, dict) and {"z", "pitch", "pitch_deg"} & set(r) for r in rows)
    return YAWED_POSE if yawed else PLANAR_POSE


def _allowed(keys: Sequence[str]) -> str:
    angle = keys[-1]
    return ", ".join([*keys[:-1], f"{angle}_deg or {angle}", *_SEGMENT_KEYS, *ACTION_KEYS])


def _pose(source: str, where: str, row: dict[str, Any], keys: Sequence[str],
          arm: Arm | None) -> list[float]:
    """One waypoint's pose (m, rad) from its keys; the angle defaults to 0 on a planar arm."""
    *lengths, angle = keys
    items = contract.field("waypoints").schema["items"]["prefixItems"]
    x_item = items[0]
    for key in lengths:
        if key not in row:
            what = f" (arm {arm.name!r} takes {', '.join(lengths)}, {angle}_deg)" \
                if arm is not None and arm.yawed else ""
            raise fail(source, f"{where}.{key}", f"missing{what}", None)
    deg = f"{angle}_deg"
    if angle in row and deg in row:
        raise fail(source, f"{where}.{deg}", f"give {deg} or {angle}, not both", row[deg])
    if deg in row:
        value = math.radians(number(source, f"{where}.{deg}", row[deg]))
    elif angle in row or angle == "theta":
        value = number(source, f"{where}.{angle}", row.get(angle, 0.0), items[-1], "rad")
    else:
        raise fail(source, f"{where}.{deg}", f"missing (give {deg} in degrees or {angle} in "
                   "radians)", None)
    return [*(number(source, f"{where}.{k}", row[k], x_item, "m") for k in lengths), value]


def _actions(source: str, where: str, row: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    if "gripper" in row:
        value = row["gripper"]
        if value not in GRIPPER_ACTIONS:
            raise fail(source, f"{where}.gripper", f"must be \"open\" or \"close\", got "
                       f"{value!r}", value)
        out["gripper"] = value
    if "payload_kg" in row:
        out["payload_kg"] = _payload(source, f"{where}.payload_kg", row["payload_kg"])
    return out


def _arm_name(source: str, data: dict[str, Any]) -> str | None:
    value = data.get("arm")
    if value is not None and (not isinstance(value, str) or not value.strip()):
        raise fail(source, "arm", "must be an arm name or config file (a string), got "
                   f"{value!r}", value)
    return value


def waypoints_arm(path: str | Path) -> str | None:
    """The ``arm`` a waypoints TOML names (None: none, or the file is not TOML: loading it
    says why); InputError when it is not a string."""
    try:
        data = tomllib.loads(read(path))
    except tomllib.TOMLDecodeError:
        return None
    return _arm_name(str(path), data)


def load_waypoints(path: str | Path, arm: Arm | None = None) -> WaypointsPlan:
    """Read a waypoints TOML (module docstring) for ``arm`` (its pose keys; without an arm
    the keys the file uses); InputError naming the file, the waypoint and the key otherwise."""
    source = str(path)
    try:
        data = tomllib.loads(read(path))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{source}: invalid TOML: {exc}", field="file", value=source) from exc
    unknown = set(data) - {"arm", "plan", "waypoints"}
    if unknown:
        key = sorted(unknown)[0]
        raise fail(source, key, "unknown key (allowed: arm, plan, waypoints)", data[key])
    plan = data.get("plan", {})
    if not isinstance(plan, dict):
        raise fail(source, "plan", "must be a table", plan)
    options: dict[str, Any] = {}
    for key, value in plan.items():
        if key not in PLAN_KEYS:
            raise fail(source, f"plan.{key}", f"unknown key (allowed: {', '.join(PLAN_KEYS)})",
                       value)
        options[key] = _plan_value(source, f"plan.{key}", key, value)
    rows = data.get("waypoints")
    if not isinstance(rows, list) or len(rows) < 2:
        raise fail(source, "waypoints", "needs at least two [[waypoints]] tables, got "
                   f"{0 if not isinstance(rows, list) else len(rows)}", None)
    keys = _file_keys(rows, arm)
    allowed = {*keys, f"{keys[-1]}_deg", *_SEGMENT_KEYS, *ACTION_KEYS}
    poses = np.empty((len(rows), len(keys)))
    actions: list[dict[str, Any]] = []
    per_segment: dict[str, list[Any]] = {key: [] for key in _SEGMENT_KEYS}
    for i, row in enumerate(rows):
        where = f"waypoints[{i}]"
        if not isinstance(row, dict):
            raise fail(source, where, "must be a table", row)
        extra = set(row) - allowed
        if extra:
            key = sorted(extra)[0]
            on = f" on arm {arm.name!r}" if arm is not None else ""
            raise fail(source, f"{where}.{key}", f"unknown key{on} (allowed: "
                       f"{_allowed(keys)})", row[key])
        poses[i] = _pose(source, where, row, keys, arm)
        actions.append(_actions(source, where, row))
        for key in per_segment:
            if key in row and i == 0:
                raise fail(source, f"{where}.{key}", "the first waypoint starts no segment: "
                           f"give {key} on the waypoint the segment leads to", row[key])
            if i > 0:
                per_segment[key].append(None if key not in row else
                                        _plan_value(source, f"{where}.{key}", key, row[key]))
    for key, values in per_segment.items():
        if any(v is not None for v in values):
            default = options.get(key, SEGMENT_DEFAULTS[key])
            options[key] = tuple(v if v is not None else default for v in values)
    return WaypointsPlan(source, poses, options, keys, tuple(actions),
                         _arm_name(source, data))


__all__ = ["ACTION_KEYS", "GRIPPER_ACTIONS", "PLAN_KEYS", "SEGMENT_DEFAULTS", "WaypointsPlan",
           "load_waypoints", "waypoints_arm"]
