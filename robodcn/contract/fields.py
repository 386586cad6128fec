"""The plan request's fields, declared once: names, JSON Schemas, units, CLI names, defaults.

Every field of a plan request (the POST body of ``/v1/trajectories`` and ``/v1/moves``, the
keywords of :func:`robodcn.planner.plan`, the CLI options of ``plan``/``sim``/``move``) is a
:class:`Field` in :data:`FIELDS`. The defaults are :data:`DEFAULTS` (one
:class:`Defaults`): the fields' ``default``, :class:`~robodcn.contract.PlanRequest`'s and
:func:`robodcn.plan`'s keywords all read it. ``rate_hz`` defaults to None: the arm's
``[bus] rate_hz``.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from robodcn.config import ELBOWS, RATE_RANGE, Arm
from robodcn.dcn import TURNS
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
#: Largest payload (kg) accepted: far beyond any Dynamixel arm, keeps torques finite.
MAX_PAYLOAD = 1e3
#: Largest tool speed (m/s), angular speed (rad/s) and acceleration (m/s²) accepted: far
#: beyond any Dynamixel arm (an arm file's ``[tool]`` ceilings are lower).
MAX_TOOL_SPEED = 100.0
MAX_TOOL_ANGULAR_SPEED = 1e3
MAX_TOOL_ACCELERATION = 1e4
#: The reduced tool speed (m/s) of hands-on work (jog, teach, the console's live drag): ISO
#: 10218-1's 250 mm/s at the tool.
HANDS_ON_SPEED = 0.25


def hands_on_speed(arm: Arm) -> float:
    """The tool speed (m/s) of hands-on work on ``arm`` (jog, teach, the console):
    :data:`HANDS_ON_SPEED`, or the arm's ``[tool]`` speed or ``max_speed`` where lower."""
    return min(x for x in (HANDS_ON_SPEED, arm.tool.speed, arm.tool.max_speed)
               if x is not None)


#: The tool-limit fields (their defaults: the arm's ``[tool]`` table; none: no limit).
TOOL_FIELDS = ("tool_speed", "tool_angular_speed", "tool_acceleration")


@dataclass(frozen=True)
class Defaults:
    """The value of every optional request field when it is absent (written here only).

    ``rate_hz`` None is the arm's ``[bus] rate_hz``; ``elbow`` None the arm's configured
    branch; ``start_joints``/``start_state`` None: start at the first waypoint;
    ``payload_kg`` None the arm's ``[dynamics] payload_kg``; ``tool_speed``,
    ``tool_angular_speed``, ``tool_acceleration`` None the arm's ``[tool]`` ``speed``,
    ``angular_speed``, ``acceleration`` (none there: no tool limit).
    """

    method: str = "sclerp"
    beta: float = 1.0
    turn: str = "shortest"
    duration: float | str = "auto"
    profile: str = "optimal"
    rate_hz: float | None = None
    blend: bool = False
    start_joints: None = None
    elbow: str | None = None
    start_state: None = None
    payload_kg: float | None = None
    tool_speed: float | None = None
    tool_angular_speed: float | None = None
    tool_acceleration: float | None = None


#: The defaults of the request fields (:class:`Defaults`).
DEFAULTS = Defaults()


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
    default: str | float | bool | None = None
    unit: str | None = None
    cli_option: str | None = None
    cli_unit: str | None = None
    required: bool = False

    @functools.cached_property
    def choices(self) -> tuple[str, ...]:
        """The enum of a string field (or of each entry of a per-segment list); found once
        (every request checks its choice fields against it)."""
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
ANGLE_ITEM = {"type": "number", "minimum": -MAX_ANGLE, "maximum": MAX_ANGLE}

FIELDS: tuple[Field, ...] = (
    Field("waypoints",
          {"type": "array", "minItems": 1, "maxItems": MAX_WAYPOINTS,
           "items": {"type": "array", "minItems": 2, "maxItems": 4,
                     "prefixItems": [_POSE_ITEM, _POSE_ITEM, ANGLE_ITEM],
                     "items": ANGLE_ITEM}},
          "Poses [x, y, θ] in metres and radians, at least two (one with start_joints or "
          f"start_state, or in a move: from there), at most {MAX_WAYPOINTS}; on a 2-joint "
          "(position-only) arm [x, y] (θ, if given, is "
          "ignored); on an arm with a base yaw [x, y, z, pitch].",
          unit="m, m, rad", cli_option="--from/--via/--to", cli_unit="m, m, deg",
          required=True),
    Field("method", _per_segment_schema(_choice_schema(METHODS)),
          "Interpolation method, or a list with one per segment.", default=DEFAULTS.method,
          cli_option="--method"),
    Field("beta", _per_segment_schema({"type": "number", "minimum": BETA_RANGE[0],
                                       "maximum": BETA_RANGE[1]}),
          "KenLERP bias β, or a list with one per segment: 0 is SEP-LERP, 1 ScLERP, above 1 "
          "extrapolates past ScLERP; negative values are refused. Only kenlerp reads it.",
          default=DEFAULTS.beta, cli_option="--beta"),
    Field("turn", _per_segment_schema(_choice_schema(TURNS)),
          "Turn direction of θ, or a list with one per segment.", default=DEFAULTS.turn,
          cli_option="--turn"),
    Field("duration",
          {"oneOf": [{"type": "number", "exclusiveMinimum": 0, "maximum": MAX_DURATION},
                     {"type": "string", "enum": ["auto"]}]},
          "Total seconds (rounded up to whole sample periods; at least one period per "
          f"segment and at most {MAX_SAMPLES} samples), or \"auto\": the shortest within the "
          "joint limits.", default=DEFAULTS.duration, unit="s", cli_option="--duration"),
    Field("profile", {"type": "string", "enum": list(PROFILES)},
          "Time law: \"optimal\" (the default) times the whole path time-optimally within "
          "every joint's velocity, acceleration and (where configured) jerk limit; "
          "\"linear\", \"quintic\" and \"trapezoid\" stretch one uniform law over each "
          "segment (or the blended path).", default=DEFAULTS.profile,
          cli_option="--profile"),
    Field("rate_hz", {"type": "number", "minimum": RATE_RANGE[0], "maximum": RATE_RANGE[1]},
          "Sample rate. Default: the arm's [bus] rate_hz.", default=DEFAULTS.rate_hz,
          unit="Hz",
          cli_option="--rate"),
    Field("blend", {"type": "boolean"},
          "Pass through via points with continuous velocity instead of stopping at each.",
          default=DEFAULTS.blend, cli_option="--blend"),
    Field("start_joints",
          {"type": ["array", "null"], "minItems": 2, "maxItems": 4, "items": ANGLE_ITEM},
          "Joint angles to start from, one per joint, each within its limits; a joint-space "
          "approach is prepended when they differ from the first waypoint's IK. Default: "
          "none (start at the first waypoint).", default=DEFAULTS.start_joints, unit="rad",
          cli_unit="deg"),
    Field("elbow", {"type": ["string", "null"], "enum": [*ELBOWS, None]},
          "IK branch: \"up\" (q2 ≤ 0) or \"down\" (q2 ≥ 0); it also breaks the tie at a "
          "stretched-out (singular) start. Default: the arm's configured elbow.",
          default=DEFAULTS.elbow, cli_option="--elbow"),
    Field("start_state",
          {"type": ["object", "null"], "additionalProperties": False, "required": ["joints"],
           "properties": {
               "joints": {"type": "array", "minItems": 2, "maxItems": 4, "items": ANGLE_ITEM},
               "velocities": {"type": "array", "minItems": 2, "maxItems": 4,
                              "items": {"type": "number"}},
               "accelerations": {"type": "array", "minItems": 2, "maxItems": 4,
                                 "items": {"type": "number"}}}},
          "A moving joint state to plan from (a retarget): joints (rad), velocities (rad/s) "
          "and accelerations (rad/s²), one per joint, each within its limit. The path runs "
          "from the pose at those joints through every waypoint, timed from that state "
          "(profile optimal). Default: none.", default=DEFAULTS.start_state,
          unit="rad, rad/s, rad/s²",
          cli_unit="deg, deg/s, deg/s²"),
    Field("payload_kg", {"type": ["number", "null"], "minimum": 0.0, "maximum": MAX_PAYLOAD},
          "Mass carried at the tool point, for the torque limits the timing keeps "
          "(max_torque_nm). Default: the arm's [dynamics] payload_kg.",
          default=DEFAULTS.payload_kg, unit="kg", cli_option="--payload"),
    Field("tool_speed",
          {"type": ["number", "null"], "exclusiveMinimum": 0.0, "maximum": MAX_TOOL_SPEED},
          "The tool point's largest linear speed along the whole path (UR's movel v, ABB's "
          "v_tcp), kept with every joint limit; a straight line (seplerp, or kenlerp with "
          "beta 0) then runs at exactly this speed where the joints allow. At most the "
          "arm's [tool] max_speed. Default: the arm's [tool] speed (none: no limit).",
          default=DEFAULTS.tool_speed, unit="m/s", cli_option="--tool-speed"),
    Field("tool_angular_speed",
          {"type": ["number", "null"], "exclusiveMinimum": 0.0,
           "maximum": MAX_TOOL_ANGULAR_SPEED},
          "The largest rate of the tool's orientation: of θ, or of pitch and of yaw on an arm "
          "with a base yaw (ABB's v_ori). At most the arm's [tool] max_angular_speed. "
          "Default: the arm's [tool] angular_speed (none: no limit).",
          default=DEFAULTS.tool_angular_speed, unit="rad/s", cli_option="--tool-angular-speed",
          cli_unit="deg/s"),
    Field("tool_acceleration",
          {"type": ["number", "null"], "exclusiveMinimum": 0.0,
           "maximum": MAX_TOOL_ACCELERATION},
          "The tool point's largest acceleration along its path (d²σ/dt², σ its arc "
          "length: UR's movel a), at both ends of a straight line and wherever the speed "
          "changes. At most the arm's [tool] max_acceleration. Default: the arm's [tool] "
          "acceleration (none: no limit).",
          default=DEFAULTS.tool_acceleration, unit="m/s²", cli_option="--tool-acceleration"),
)
_BY_NAME = {f.name: f for f in FIELDS}

#: ``waypoints`` on an arm with a base yaw (a 2-link chain's pitch may be left out).
YAWED_WAYPOINTS = Field(
    "waypoints",
    {"type": "array", "minItems": 1, "maxItems": MAX_WAYPOINTS,
     "items": {"type": "array", "minItems": 4, "maxItems": 4,
               "prefixItems": [_POSE_ITEM, _POSE_ITEM, _POSE_ITEM, ANGLE_ITEM],
               "items": False}},
    "Poses [x, y, z, pitch] in the arm's base frame (origin on the yaw axis at the mounting "
    "plate, z up, x forward at yaw 0; pitch the tool axis's elevation above the horizontal, "
    "positive up), metres and radians, at least two (one with start_joints or start_state, "
    f"or in a move: from there), at most {MAX_WAYPOINTS}. A pose "
    "behind the base (|pitch| > 90°, or on the yaw axis) is refused.",
    unit="m, m, m, rad", cli_option="--from/--via/--to", cli_unit="m, m, m, deg",
    required=True)


def waypoints_field(arm: Arm | None) -> Field:
    """The ``waypoints`` :class:`Field` of ``arm`` (an :class:`~robodcn.config.Arm`, or None
    for the arm-independent one): :data:`YAWED_WAYPOINTS` for an arm with a base yaw."""
    return YAWED_WAYPOINTS if arm is not None and arm.yawed else _BY_NAME["waypoints"]

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
