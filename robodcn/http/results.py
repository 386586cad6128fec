"""The service's result types, declared once: the controller builds them, the handlers send
``to_json()`` of them and ``/openapi.json`` documents :func:`schema_of` of them, so the
documented schema and the answer cannot drift apart.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from dataclasses import dataclass, field
from typing import Any, Literal

#: Move lifecycle. ``done``: every sample sent; ``degraded``: completed with samples skipped;
#: ``stopped``: stopped by a request (the arm holds); ``fault``: a bus or servo fault ended
#: it after motion began; ``failed``: refused before any sample was sent.
MoveState = Literal["queued", "running", "done", "degraded", "stopped", "fault", "failed"]


def _doc(text: str, **schema: Any) -> dict[str, Any]:
    return {"description": text, **schema}


@dataclass
class ErrorDetail:
    """What went wrong: a stable ``code``, a message and the request field at fault."""

    code: str
    message: str
    field: str | None
    sample: int | None = dataclasses.field(default=None, metadata=_doc("first failing sample"))
    t: float | None = dataclasses.field(default=None, metadata=_doc("its time (s)"))
    joint: str | None = None


@dataclass
class ErrorResponse:
    error: ErrorDetail


@dataclass
class MoveStatus:
    """A move: status, progress (fraction of samples sent) and, once finished, its report
    (robodcn.stream.ExecutionReport.to_dict(), as is). Times are Unix seconds."""

    id: str
    status: MoveState
    progress: float = field(metadata=_doc("fraction of samples sent", minimum=0, maximum=1))
    elapsed: float = 0.0
    duration: float = 0.0
    samples: int = 0
    tracking_error: float | None = field(default=None, metadata=_doc(
        "rad; live |present − goal| while running, the report's maximum once finished"))
    created: float = 0.0
    started: float | None = None
    finished: float | None = None
    report: dict[str, Any] | None = None
    error: ErrorDetail | None = None


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


@dataclass
class StopAnswer:
    """Whether a running move was stopped, which, and its status after the stop."""

    stopped: bool
    move: str | None
    status: MoveState | None


@dataclass
class Health:
    status: Literal["ok"]
    version: str
    arm: str
    moving: bool


@dataclass
class ArmInfo:
    name: str
    dof: int
    joint_names: list[str]
    servo_ids: list[int]
    source: str | None
    config: dict[str, Any] = field(metadata=_doc("robodcn.config.Arm.to_dict()"))


RESULTS: dict[str, type] = {"Move": MoveStatus, "State": State, "Stop": StopAnswer,
                            "Health": Health, "Arm": ArmInfo, "Error": ErrorResponse}


def _type_schema(hint: Any) -> dict[str, Any]:
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if hint is type(None):
        return {"type": "null"}
    if origin in (typing.Union, types.UnionType):
        options = [_type_schema(a) for a in args]
        if all(set(o) == {"type"} for o in options):
            return {"type": [o["type"] for o in options]}
        return {"anyOf": options}
    if origin is Literal:
        return {"enum": list(args)}
    if origin is list:
        return {"type": "array", "items": _type_schema(args[0])}
    if origin is dict:
        value = _type_schema(args[1])
        return {"type": "object"} if value == {} else \
            {"type": "object", "additionalProperties": value}
    if dataclasses.is_dataclass(hint):
        return schema_of(hint)
    return {bool: {"type": "boolean"}, int: {"type": "integer"}, float: {"type": "number"},
            str: {"type": "string"}, Any: {}}[hint]


def schema_of(cls: type) -> dict[str, Any]:
    """The JSON schema of dataclass ``cls``: a property per field from its type hint (and
    ``metadata`` description/bounds); fields without a default are required."""
    hints = typing.get_type_hints(cls)
    props: dict[str, Any] = {}
    required = []
    for f in dataclasses.fields(cls):
        props[f.name] = {**_type_schema(hints[f.name]), **f.metadata}
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            required.append(f.name)
    schema: dict[str, Any] = {"type": "object", "required": required, "properties": props}
    if cls.__doc__ and not cls.__doc__.startswith(cls.__name__ + "("):
        schema["description"] = " ".join(cls.__doc__.split())
    return schema


def to_json(result: Any) -> dict[str, Any]:
    """A result dataclass as the JSON object its schema describes."""
    return dataclasses.asdict(result)
