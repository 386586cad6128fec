"""One exception hierarchy for robodcn.

Every error names what is wrong (``field``) and the offending ``value`` so that the CLI
can print one line and the HTTP service can answer ``{"error": {code, message, field}}``.
The classes map onto CLI exit codes and HTTP statuses through ``exit_code`` and
``http_status``::

    RobodcnError                      exit 1   500
    ├── InputError (ValueError)       exit 2   422  bad argument, shape, method, value
    │   ├── ConfigError               exit 2   422  bad arm/bus TOML (file, key, value)
    │   ├── DegenerateError           exit 2   422  e.g. DLB with a zero denominator
    │   ├── TooLargeError             exit 2   413  a plan over the 10⁶-sample limit
    │   ├── GravityReleaseError       exit 2   409  torque off would drop the arm: confirm
    │   └── FileWriteError            exit 2   500  a file cannot be written (old one kept)
    ├── PlanError                     exit 3   422  plan infeasible (names the sample)
    │   ├── UnreachableError
    │   ├── JointLimitError
    │   ├── VelocityLimitError
    │   ├── AccelerationLimitError
    │   ├── JerkLimitError
    │   ├── TorqueLimitError
    │   ├── ToolLimitError                          tool speed / orientation rate / acceleration
    │   ├── TickLimitError
    │   └── KeepOutError                            a point of the arm inside a keep-out zone
    ├── BusError                      exit 4   503  servo or bus fault
    │   ├── CommError                               no/garbled status packet
    │   ├── ServoMismatchError                      missing servo, wrong model
    │   │   └── FeedbackMapError                    a servo ignores the indirect feedback map
    │   ├── HardwareAlertError                      Hardware Error Status non-zero
    │   └── StartMismatchError                      arm far from the first sample
    ├── BusyError                     exit 4   409  another move is running
    └── StoppedError                  exit 130 409  stopped by the user
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import field as _field
from typing import Any, Literal

#: What a :class:`Violation` exceeds, and its SI unit.
QUANTITY_UNITS = {"reach": "m", "position": "rad", "velocity": "rad/s",
                  "acceleration": "rad/s^2", "jerk": "rad/s^3", "ticks": "tick",
                  "torque": "N*m", "tool_speed": "m/s", "tool_angular_speed": "rad/s",
                  "tool_acceleration": "m/s^2", "keepout": "m"}
Quantity = Literal["reach", "position", "velocity", "acceleration", "jerk", "ticks", "torque",
                   "tool_speed", "tool_angular_speed", "tool_acceleration", "keepout"]


@dataclass(frozen=True)
class Violation:
    """The first sample of a plan that fails a check, as data (SI units).

    The planner's validation returns it; :class:`PlanError` carries it as ``.violation``;
    :func:`robodcn.messages.describe` words it for the CLI (degrees, options) or HTTP (SI,
    JSON fields). Finite-difference velocity is charged to sample i, acceleration to i + 1
    and jerk to i + 2 of the differences that produce them (planner module docstring).
    """

    sample: int | None = _field(metadata={
        "description": "Index of the first failing sample; null when the plan is refused "
                       "before it is timed (a pose the arm cannot hold: no sample exists)."})
    t: float | None = _field(metadata={
        "description": "Its time from the plan start (s); null with a null sample."})
    pose: tuple[float, ...] = _field(
        metadata={"description": "Its pose: [x, y, θ] (m, m, rad), or on an arm with a base "
                                 "yaw [x, y, z, pitch] (m, m, m, rad).",
                  "schema": {"type": "array", "items": {"type": "number"},
                             "minItems": 3, "maxItems": 4}})
    quantity: Quantity = _field(metadata={"description": "What is exceeded."})
    value: float = _field(metadata={
        "description": "The value needed (reach: wrist distance from the base, m; position: "
                       "joint angle, rad; velocity rad/s; acceleration rad/s²; jerk rad/s³; "
                       "ticks: goal position; torque: joint torque, N·m; tool_speed: the tool "
                       "point's speed, m/s; tool_angular_speed: its orientation rate, rad/s; "
                       "tool_acceleration: its acceleration along the path, m/s²; keepout: "
                       "how deep the point is inside the zone, m)."})
    limit: float = _field(metadata={
        "description": "The bound it passes (the nearer workspace radius for reach, the "
                       "crossed joint or tick limit for position and ticks, 0 for keepout: "
                       "the zone's surface)."})
    unit: str = _field(metadata={"description": "SI unit of value and limit."})
    joint: str | None = _field(default=None, metadata={"description": "Joint name, if one."})
    joint_index: int | None = _field(default=None,
                                    metadata={"description": "Joint index (0-based)."})
    segment: tuple[int, int] | None = _field(default=None, metadata={
        "description": "The path segment [i, i + 1] (waypoint i → i + 1); null on the "
                       "joint-space approach."})
    waypoint: int | None = _field(default=None, metadata={
        "description": "The waypoint index when the sample is a waypoint itself."})
    other_branch_ok: bool | None = _field(default=None, metadata={
        "description": "For position and tick limits: whether the other elbow branch would "
                       "pass this check along the whole plan (null: not asked)."})
    field: str = _field(default="duration", metadata={
        "description": "The request field to change (waypoints[i], duration, start_joints; "
                       "a tool limit's own field: tool_speed …)."})
    point: str | None = _field(default=None, metadata={
        "description": "For keepout: the point of the arm inside the zone (a joint's name "
                       "for its centre, \"tool\", or \"<a>–<b> link\" along a link)."})
    zone: str | None = _field(default=None, metadata={
        "description": "For keepout: the zone entered (\"floor\", \"base\" or a "
                       "[[workspace.keep_out]] box's name)."})
    position: tuple[float, ...] | None = _field(default=None, metadata={
        "description": "For keepout: the point's base-frame position [x, y, z] (m).",
        "schema": {"type": ["array", "null"], "items": {"type": "number"}}})

    def to_dict(self) -> dict[str, Any]:
        return {"sample": self.sample, "t": self.t, "pose": list(self.pose),
                "quantity": self.quantity, "value": self.value, "limit": self.limit,
                "unit": self.unit, "joint": self.joint, "joint_index": self.joint_index,
                "segment": None if self.segment is None else list(self.segment),
                "waypoint": self.waypoint, "other_branch_ok": self.other_branch_ok,
                "field": self.field, "point": self.point, "zone": self.zone,
                "position": None if self.position is None else list(self.position)}


class RobodcnError(Exception):
    """Base of every robodcn error.

    Parameters
    ----------
    message
        Human-readable, one or two lines, naming the bad value and how to fix it.
    field
        The argument, config key or request field at fault (``"waypoints[2]"``).
    value
        The offending value, kept for programmatic use.
    """

    code: str = "error"
    exit_code: int = 1
    http_status: int = 500

    def __init__(self, message: str, *, field: str | None = None, value: Any = None) -> None:
        super().__init__(message)
        self.message = message
        self.field = field
        self.value = value

    def to_dict(self) -> dict[str, Any]:
        """The ``{"code", "message", "field"}`` body the HTTP service returns."""
        return {"code": self.code, "message": self.message, "field": self.field}


class InputError(RobodcnError, ValueError):
    """An argument is malformed: wrong shape, non-finite, unknown name, out of range."""

    code = "invalid_input"
    exit_code = 2
    http_status = 422


class ConfigError(InputError):
    """An arm or bus configuration file is invalid; names file, key and value."""

    code = "invalid_config"

    def __init__(self, message: str, *, file: str | None = None, key: str | None = None,
                 value: Any = None) -> None:
        where = f"{file}: " if file else ""
        super().__init__(f"{where}{message}", field=key, value=value)
        self.file = file
        self.key = key


class DegenerateError(InputError):
    """The input is well-formed but the operation is undefined for it (zero denominator)."""

    code = "degenerate"


class TooLargeError(InputError):
    """The request is well-formed but larger than the service handles (e.g. > 10⁶ samples)."""

    code = "too_large"
    http_status = 413


class GravityReleaseError(InputError):
    """Torque off on an arm under gravity: it would fall, so it needs confirmation (the
    CLI's ``--yes``, HTTP ``"confirm": true``).

    ``arm`` names the arm, ``joints`` the joints gravity loads, ``holding_torque_nm`` the
    torque each joint holds at the present pose (N·m, joint order; None when not known),
    ``rest`` the rest pose the arm would be lowered to first (None: it has none).
    """

    code = "gravity_release"
    http_status = 409

    def __init__(self, message: str, *, arm: str, joints: tuple[str, ...],
                 holding_torque_nm: tuple[float, ...] | None,
                 rest: tuple[float, ...] | None, field: str = "confirm") -> None:
        super().__init__(message, field=field,
                         value={"arm": arm, "joints": list(joints),
                                "holding_torque_nm": None if holding_torque_nm is None
                                else list(holding_torque_nm),
                                "rest": None if rest is None else list(rest)})
        self.arm = arm
        self.joints = joints
        self.holding_torque_nm = holding_torque_nm
        self.rest = rest


class FileWriteError(InputError):
    """A file robodcn writes (a plan, taught poses, a calibrated config, a plot) cannot be
    written: ``path`` names it, ``strerror`` and ``errno`` are the operating system's reason
    (as in OSError). The write was atomic (:mod:`robodcn._files`): an existing file is
    unchanged. ``saved_to`` is where the content was saved instead, when it was (taught
    poses, a calibration: work a hand did that must not be lost).
    """

    code = "file_write"
    http_status = 500

    def __init__(self, message: str, *, path: str, strerror: str, errno: int | None = None,
                 field: str | None = None, saved_to: str | None = None) -> None:
        super().__init__(message, field=field, value=path)
        self.path = path
        self.strerror = strerror
        self.errno = errno
        self.saved_to = saved_to


class PlanError(RobodcnError):
    """A plan cannot be executed within the arm's limits.

    Carries the first failing ``sample`` index, its time ``t`` (s), ``pose`` (x, y, θ; a
    yawed arm's x, y, z, pitch) and
    ``joint`` name when known.
    """

    code = "plan_infeasible"
    exit_code = 3
    http_status = 422

    def __init__(self, message: str, *, field: str | None = None, value: Any = None,
                 sample: int | None = None, t: float | None = None,
                 pose: Any = None, joint: str | None = None,
                 violation: Violation | None = None, waypoint: int | None = None) -> None:
        if violation is not None:
            field = violation.field if field is None else field
            value = violation.value if value is None else value
            sample, t, pose, joint = (violation.sample, violation.t, list(violation.pose),
                                      violation.joint)
            waypoint = violation.waypoint if waypoint is None else waypoint
        super().__init__(message, field=field, value=value)
        self.sample = sample
        self.t = t
        self.pose = pose
        self.joint = joint
        self.violation = violation
        #: The waypoint at fault (index into the request's waypoints), when one is.
        self.waypoint = waypoint

    def to_dict(self) -> dict[str, Any]:
        body = super().to_dict()
        if self.sample is not None:
            body["sample"] = self.sample
            body["t"] = self.t
        if self.joint is not None:
            body["joint"] = self.joint
        if self.violation is not None:
            body["violation"] = self.violation.to_dict()
        return body


class UnreachableError(PlanError):
    code = "unreachable"


class JointLimitError(PlanError):
    code = "joint_limit"


class VelocityLimitError(PlanError):
    code = "velocity_limit"


class AccelerationLimitError(PlanError):
    code = "acceleration_limit"


class JerkLimitError(PlanError):
    code = "jerk_limit"


class TickLimitError(PlanError):
    code = "tick_limit"


class KeepOutError(PlanError):
    """A sample puts a point of the arm (a joint centre, the tool point, a point along a
    link) inside a keep-out zone of its ``[workspace]``: the floor, the base, a box.

    Its :class:`Violation` (quantity "keepout") names the sample, point, zone and depth;
    a waypoint whose tool point lies in a zone is refused before any sampling, with
    ``point``, ``zone``, ``depth`` (m) and ``position`` (the point's [x, y, z], m) given
    here instead (also under ``"keepout"`` in :meth:`to_dict`).
    """

    code = "keep_out"

    def __init__(self, message: str, *, point: str | None = None, zone: str | None = None,
                 depth: float | None = None, position: Any = None, **kwargs: Any) -> None:
        super().__init__(message, **kwargs)
        v = self.violation
        self.point = v.point if v is not None and point is None else point
        self.zone = v.zone if v is not None and zone is None else zone
        self.depth = v.value if v is not None and depth is None else depth
        self.position = (list(v.position) if v is not None and position is None
                         and v.position is not None else position)

    def to_dict(self) -> dict[str, Any]:
        body = super().to_dict()
        body["keepout"] = {"point": self.point, "zone": self.zone, "depth_m": self.depth,
                           "position": self.position}
        return body


class TorqueLimitError(PlanError):
    """A sample needs more joint torque (inverse dynamics with gravity, payload and rotor
    inertia) than the joint's ``max_torque_nm``."""

    code = "torque_limit"


#: The PlanError class of each violated quantity.
class ToolLimitError(PlanError):
    """A sample moves the tool point faster (or turns or accelerates it more along its path)
    than the request's ``tool_speed`` (``tool_angular_speed``, ``tool_acceleration``)."""

    code = "tool_limit"


VIOLATION_ERRORS: dict[str, type[PlanError]] = {
    "reach": UnreachableError, "position": JointLimitError, "velocity": VelocityLimitError,
    "acceleration": AccelerationLimitError, "jerk": JerkLimitError, "ticks": TickLimitError,
    "torque": TorqueLimitError, "tool_speed": ToolLimitError,
    "tool_angular_speed": ToolLimitError, "tool_acceleration": ToolLimitError,
    "keepout": KeepOutError}


class BusError(RobodcnError):
    """The servo bus failed: communication, wrong servos, hardware alert."""

    code = "bus_fault"
    exit_code = 4
    http_status = 503


class CommError(BusError):
    code = "communication"


class ServoMismatchError(BusError):
    code = "servo_mismatch"


class FeedbackMapError(ServoMismatchError):
    """A servo does not serve the indirect feedback map :meth:`ServoBus.configure` wrote
    (an older firmware, a clone): streaming through it would read wrong positions.

    ``servo_id`` names the servo, ``item`` what differs (``"indirect_address"``: the map
    read back is not the map written; ``"present_position"``: a read through the map is
    not the Present Position read directly), ``expected`` and ``got`` the two values.
    """

    code = "feedback_map"

    def __init__(self, message: str, *, servo_id: int, item: str, expected: Any,
                 got: Any) -> None:
        super().__init__(message, field=f"servo[{servo_id}]",
                         value={"servo_id": servo_id, "item": item, "expected": expected,
                                "got": got})
        self.servo_id = servo_id
        self.item = item
        self.expected = expected
        self.got = got


class HardwareAlertError(BusError):
    code = "hardware_alert"


class StartMismatchError(BusError):
    code = "start_mismatch"


class BusyError(RobodcnError):
    code = "busy"
    exit_code = 4
    http_status = 409


class NoMoveError(RobodcnError):
    """An operation on the running move (pause, resume, speed) while none runs."""

    code = "no_move"
    exit_code = 4
    http_status = 409


class StoppedError(RobodcnError):
    code = "stopped"
    exit_code = 130
    http_status = 409


class RobodcnWarning(UserWarning):
    """Base of robodcn's warnings: data (``field``) the surfaces can print or return."""

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.field = field


class BetaIgnoredWarning(RobodcnWarning):
    """``beta`` was given with a method that does not use it (only KenLERP does).

    Given through :mod:`warnings` by :class:`~robodcn.planner.PlanRequest`; ``field`` is
    "beta", ``method`` the request's method(s) and ``segments`` the indices of the segments
    whose β is ignored.
    """

    def __init__(self, message: str, *, field: str = "beta", method: Any = None,
                 segments: tuple[int, ...] = ()) -> None:
        super().__init__(message, field=field)
        self.method = method
        self.segments = segments


class BranchSwitchWarning(RobodcnWarning):
    """The plan's IK elbow branch changes along it (through a stretched-out or folded pose).

    ``samples`` are the sample indices (also ``Trajectory.branch_switches``).
    """

    def __init__(self, message: str, *, samples: tuple[int, ...] = ()) -> None:
        super().__init__(message, field="waypoints")
        self.samples = samples
