"""The service's result types, declared once: the controller returns them typed, the
surfaces' edge (the HTTP handlers, the console's event stream) sends :func:`to_json` of them
and ``/openapi.json`` documents :func:`robodcn.contract.schema_of` of them, so the documented
schema and the answer cannot drift apart.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Literal

from robodcn.workflow.gripper import GripperResult

#: Move lifecycle. ``done``: every sample sent and the arm at rest in position;
#: ``degraded``: completed with samples skipped, or at rest out of position (the report's
#: ``out_of_position`` names each joint's error);
#: ``stopped``: stopped by a request (the arm holds); ``fault``: a bus or servo fault ended
#: it after motion began; ``collision``: the collision stop ended it; ``failed``: refused
#: before any sample was sent; ``replaced``: a move with ``"replace": true`` took over the
#: rest of it in flight.
MoveState = Literal["queued", "running", "following", "done", "degraded", "stopped",
                    "collision", "fault", "failed", "replaced"]


def _doc(text: str, **schema: Any) -> dict[str, Any]:
    """Field metadata for contract.schema_of: a description, and a schema when bounds are
    given."""
    return {"description": text, **({"schema": schema} if schema else {})}


@dataclass
class ErrorDetail:
    """What went wrong: a stable ``code``, a message and the request field at fault."""

    code: str
    message: str
    field: str | None
    sample: int | None = dataclasses.field(default=None, metadata=_doc("first failing sample"))
    t: float | None = dataclasses.field(default=None, metadata=_doc("its time (s)"))
    joint: str | None = None
    #: The body exactly as the error gave it (:meth:`robodcn.errors.RobodcnError.to_dict`:
    #: only the keys it has, and a plan error's ``violation``), which :func:`to_json` sends.
    body: dict[str, Any] | None = dataclasses.field(default=None, repr=False,
                                                     metadata={"json": False})

    @classmethod
    def of(cls, body: dict[str, Any]) -> ErrorDetail:
        """The detail of an error body ``{"code", "message", "field", ...}``."""
        return cls(code=str(body["code"]), message=str(body["message"]),
                   field=body.get("field"), sample=body.get("sample"), t=body.get("t"),
                   joint=body.get("joint"), body=dict(body))

    def to_json(self) -> dict[str, Any]:
        if self.body is not None:
            return dict(self.body)
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                if f.name != "body"}


@dataclass
class ErrorResponse:
    """Every error answer: ``{"error": {code, message, field, ...}}``."""

    error: ErrorDetail


@dataclass
class ApproachInfo:
    """A joint-space approach from where the arm was to the start of the path: the first
    ``samples`` sample periods, ``duration_s`` seconds."""

    samples: int
    duration_s: float


@dataclass
class MoveStatus:
    """A move: status, progress (fraction of samples sent) and, once finished, its report
    (robodcn.stream.ExecutionReport.to_dict(), as is). Times are Unix seconds."""

    id: str
    status: MoveState
    progress: float = field(metadata=_doc("fraction of samples sent", type="number",
                                          minimum=0, maximum=1))
    elapsed: float = 0.0
    duration: float = 0.0
    samples: int = 0
    tracking_error: float | None = field(default=None, metadata=_doc(
        "rad, largest over the joints (robodcn.stream tracking error: present outside the "
        "last commanded step); the latest while running, the report's maximum once finished"))
    approach: ApproachInfo | None = field(default=None, metadata=_doc(
        "the joint-space approach that opens the move (planned from the present joints, or "
        "inserted by the streamer), or null"))
    created: float = 0.0
    started: float | None = None
    finished: float | None = None
    report: dict[str, Any] | None = None
    error: ErrorDetail | None = None
    paused: bool = field(default=False, metadata=_doc("paused (POST /v1/pause)"))
    speed_scale: float = field(default=1.0, metadata=_doc(
        "speed scale k of the limits (PUT /v1/speed)", type="number", exclusiveMinimum=0,
        maximum=1))
    tool: dict[str, Any] | None = field(default=None, metadata=_doc(
        "the tool point's peak speed along the planned trajectory and where a tool limit "
        "binds (robodcn.planner.tool_peak.ToolPeak.to_dict(): peak_speed m/s, t s, sample, "
        "pose, peak_acceleration m/s², speed_limit and acceleration_limit (the request's "
        "tool_speed and tool_acceleration, or null), binds_from and binds_to s, "
        "binding_share)"))
    recovery: dict[str, Any] | None = field(default=None, metadata=_doc(
        "the slow joint-space recovery that opens the move when the arm was outside its "
        "joint limits (robodcn.planner.recovery.Recovery: joints moved with start, target "
        "(rad) and speed (rad/s), samples, duration_s, share of the limits, message), or "
        "null"))


@dataclass
class State:
    """Where the arm is: joints (rad), pose (FK, metres and radians), ticks, torque, alerts.
    ``source`` is ``bus`` for a read, ``stream`` for the streamer's latest feedback."""

    joints: list[float]
    pose: list[float]
    ticks: list[int]
    joint_names: list[str]
    torque: bool | None
    alerts: dict[str, str]
    moving: bool
    move: str | None
    source: Literal["bus", "stream"]
    paused: bool = field(default=False, metadata=_doc("the running move is paused"))
    speed_scale: float | None = field(default=None, metadata=_doc(
        "speed scale of the running move (null when none runs)"))
    gripper_width_m: float | None = field(default=None, metadata=_doc(
        "the gripper's jaw width (m, from its Present Position); null without a [gripper] "
        "or while a move streams"))
    holding: bool | None = field(default=None, metadata=_doc(
        "the gripper holds an object: torque on, the jaws at rest short of their goal, "
        "pushing with at least half the grip current; null as gripper_width_m"))
    velocities: list[float] | None = field(default=None, metadata=_doc(
        "joint velocities (rad/s, the joints' order and sense) from Present Velocity read "
        "with the positions; null when the feedback does not give them (no feedback map "
        "configured, or before a move's first read)"))
    efforts: list[float] | None = field(default=None, metadata=_doc(
        "joint torques (N·m, the joints' sense) the servos' Present Current stands for: "
        "direction·K_t·i, K_t = stall torque / stall current of the servo model; null as "
        "velocities"))


@dataclass
class StopAnswer:
    """Whether something moving was stopped (the move, which, and its status after the
    stop; a gripper action), and why a hold was not written."""

    stopped: bool = field(metadata=_doc(
        "something was stopped: a smooth stop's brake is in the stream, a hold's move has "
        "ended with its hold written, or a gripper action was halted; false when nothing "
        "moved, the move had not ended within a second, or its hold was not written "
        "(hold_failed)"))
    move: str | None
    status: MoveState | None
    gripper: bool = field(default=False, metadata=_doc(
        "a gripper action was halted (its goal set to where the jaws were)"))
    hold_failed: str | None = field(default=None, metadata=_doc(
        "why the stop's hold was not written (a stalled or lost bus; the move ends fault "
        "and only the servos' Bus Watchdog stops them), or null"))


@dataclass
class Health:
    """Liveness: the version, the arm served and whether a move runs."""

    status: Literal["ok"]
    version: str
    arm: str
    moving: bool


@dataclass
class ExecutionInfo:
    """The execution options in force for every move the service starts (``serve
    --compensation``, ``--tracking-limit``, ``--recover``, as ``move`` has them)."""

    compensation: bool = field(metadata=_doc(
        "the goals lead the plan by the servos' position-loop lag (robodcn.stream."
        "compensation); false: the plan itself is streamed"))
    tracking_limit_deg: float | None = field(metadata=_doc(
        "a joint lagging its goal by more than this many degrees stops the move (null: no "
        "tracking stop)"))
    recover: bool = field(metadata=_doc(
        "on an overload alert that servo is rebooted and held (the move stays stopped)"))

    @classmethod
    def of(cls, options: Any) -> ExecutionInfo:
        """The info of a :class:`robodcn.stream.ExecutionOptions` (tracking_limit in rad).

        The limit was given in degrees and is held in radians: the round trip is rounded to
        nine decimals, so ``--tracking-limit 15`` reads back 15, not 14.999999999999998.
        """
        limit = options.tracking_limit
        return cls(compensation=bool(options.compensation),
                   tracking_limit_deg=None if limit is None else round(math.degrees(limit), 9),
                   recover=bool(options.recover))


@dataclass
class ArmInfo:
    """The arm configuration (SI units): name, joints, servos and the whole config, and the
    execution options in force (null for a service that only plans)."""

    name: str
    dof: int
    joint_names: list[str]
    servo_ids: list[int]
    source: str | None
    config: dict[str, Any] = field(metadata=_doc("robodcn.config.Arm.to_dict()"))
    pose_axes: list[str] = field(default_factory=lambda: ["x", "y", "theta"], metadata={
        "description": "the numbers of a pose (waypoints rows, Trajectory poses, State "
                       "pose), in order: x, y, theta of a planar arm; x, y, z, pitch of an "
                       "arm with a base yaw (m, rad)",
        "schema": {"oneOf": [{"const": ["x", "y", "theta"]},
                             {"const": ["x", "y", "z", "pitch"]}]}})
    payload_kg: float = field(default=0.0, metadata=_doc(
        "the default payload (kg) at the tool point: the payload_kg of a plan or move body "
        "that gives none ([dynamics] payload_kg)"))
    gripper: bool = field(default=False, metadata=_doc(
        "the arm has a [gripper] (POST /v1/gripper drives it)"))
    execution: ExecutionInfo | None = field(default=None, metadata=_doc(
        "what every move the service starts executes with, or null (no arm attached)"))
    keep_out: list[dict[str, Any]] = field(default_factory=list, metadata={
        "description": "the keep-out zones no point of the arm may enter ([workspace]; a "
                       "plan into one is refused, 422 keep_out), in metres: "
                       "{name, kind: floor, axis, height} (nothing below height on axis), "
                       "{name, kind: cylinder, radius, top} (about the yaw axis, up to top), "
                       "{name, kind: box, min, max} (corners [x, y, z]; a planar arm's [x, y])",
        "schema": {"type": "array", "items": {"type": "object"}}})


#: What a released arm was told, shared by TorqueAnswer and RebootAnswer.
_LOWERED = ("the arm was lowered to its rest pose ([arm.rest]) before torque went off (an "
            "arm under gravity, confirmed)")
_HOLD = ("why an arm under gravity could not be lowered first (no rest pose, a lowering "
         "refused): the user was to hold it; null when it was lowered or does not fall")


@dataclass
class TorqueAnswer:
    """Torque switched: on or off, for which joint (None: every joint), on which servos;
    off on an arm under gravity: whether it was lowered to its rest pose first."""

    on: bool
    joint: str | None
    servo_ids: list[int]
    lowered: bool = field(default=False, metadata=_doc(_LOWERED))
    hold: str | None = field(default=None, metadata=_doc(_HOLD))


@dataclass
class RebootAnswer:
    """Servos rebooted (hardware errors cleared; torque is off afterwards): on an arm under
    gravity after lowering it to its rest pose (confirmed)."""

    joint: str | None
    servo_ids: list[int]
    lowered: bool = field(default=False, metadata=_doc(_LOWERED))
    hold: str | None = field(default=None, metadata=_doc(_HOLD))


@dataclass
class Recording:
    """What a move measured (robodcn.workflow.record.recording): per feedback read, the time
    since the first write (s), the present ticks, joints (rad) and pose (FK, m and rad)."""

    move: str
    joint_names: list[str]
    servo_ids: list[int]
    t: list[float]
    ticks: list[list[int]]
    joints: list[list[float]]
    poses: list[list[float]]


# -- the console's event stream (GET /v1/events, robodcn.web.events) ----------------------------

@dataclass
class MoveInfo:
    """The latest move as a ``state`` event carries it: the first fields of
    :class:`MoveStatus`."""

    id: str
    status: MoveState
    progress: float
    elapsed: float
    duration: float
    tracking_error: float | None
    error: ErrorDetail | None
    report: dict[str, Any] | None = field(default=None, metadata=_doc(
        "the move's report once it has finished (robodcn.stream.ExecutionReport), else null"))


@dataclass
class StateEvent(State):
    """A ``state`` event: :class:`State` plus the latest move (or null) and the time."""

    move_info: MoveInfo | None = field(kw_only=True, metadata=_doc(
        "the latest move (GET /v1/moves/{id}, its first fields), or null before any"))
    time: float = field(kw_only=True, metadata=_doc("Unix seconds of the sample"))


@dataclass
class AlertEvent:
    """An ``alert`` event: the servos' hardware alerts (servo id → text) and the state
    read's failure (or null), whenever either changes."""

    alerts: dict[str, str]
    error: ErrorDetail | None


#: Event name → the type of its ``data`` (one JSON object per event).
EVENTS: dict[str, type] = {"state": StateEvent, "move": MoveStatus, "alert": AlertEvent}

@dataclass
class FollowTargetAnswer:
    """A follow session took a target (``PUT /v1/follow/target``)."""

    seq: int = field(metadata=_doc("the target's sequence number in the session (1, 2, …)",
                                   type="integer", minimum=1))


RESULTS: dict[str, type] = {"Move": MoveStatus, "FollowTarget": FollowTargetAnswer,
                            "State": State, "Stop": StopAnswer,
                            "Health": Health, "Arm": ArmInfo, "Torque": TorqueAnswer,
                            "Gripper": GripperResult,
                            "Reboot": RebootAnswer, "Record": Recording,
                            "Error": ErrorResponse, "StateEvent": StateEvent,
                            "AlertEvent": AlertEvent}


def to_json(result: Any) -> Any:
    """A result dataclass as the JSON object its schema describes.

    Dataclasses become objects field by field (one with a ``to_json`` method says how),
    lists and tuples arrays; every other value is taken as it is (JSON-ready).
    """
    if dataclasses.is_dataclass(result) and not isinstance(result, type):
        own = getattr(result, "to_json", None)
        if own is not None:
            return own()
        return {f.name: to_json(getattr(result, f.name)) for f in dataclasses.fields(result)}
    if isinstance(result, list | tuple):
        return [to_json(v) for v in result]
    if isinstance(result, dict):
        return {k: to_json(v) for k, v in result.items()}
    return result
