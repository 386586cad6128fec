"""ROS 2 interface definitions (.msg, .srv, .action) as structures the codec and hasher read.

The definitions robodcn speaks are shipped as data under ``robodcn/ros2/interfaces`` (the
Jazzy texts of the public packages, comments kept). A service ``pkg/srv/Foo`` expands as
rosidl expands it (REP 2011, REP 2016): ``Foo_Request``, ``Foo_Response``, ``Foo_Event``
(``info: service_msgs/ServiceEventInfo``, ``request`` and ``response`` as bounded sequences
≤ 1) and the synthetic ``Foo`` holding ``request_message``, ``response_message`` and
``event_message``. An action ``pkg/action/Act`` gives ``Act_Goal``, ``Act_Result``,
``Act_Feedback``, the services ``Act_SendGoal`` (``goal_id``, ``goal`` → ``accepted``,
``stamp``) and ``Act_GetResult`` (``goal_id`` → ``status``, ``result``), the message
``Act_FeedbackMessage`` (``goal_id``, ``feedback``) and the synthetic ``Act`` (REP 2016's
``goal``, ``result``, ``feedback``, ``send_goal_service``, ``get_result_service``,
``feedback_message``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from importlib import resources
from typing import Literal

from robodcn.errors import InputError

#: Primitive types of the .msg grammar and their CDR size in bytes (strings: None).
PRIMITIVES: dict[str, int | None] = {
    "bool": 1, "byte": 1, "char": 1, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2,
    "int32": 4, "uint32": 4, "int64": 8, "uint64": 8, "float32": 4, "float64": 8,
    "string": None, "wstring": None,
}

Kind = Literal["single", "array", "bounded", "sequence"]


@dataclass(frozen=True)
class Field:
    """One field: ``base`` is a primitive name or a full type name ``pkg/msg/Name``;
    ``kind`` single, fixed ``array`` (``size`` elements), ``bounded`` sequence (≤ ``size``)
    or unbounded ``sequence``; ``string_capacity`` for ``string<=N``."""

    name: str
    base: str
    kind: Kind = "single"
    size: int = 0
    string_capacity: int = 0

    @property
    def nested(self) -> bool:
        return self.base not in PRIMITIVES


#: A structure: its fields in order.
Struct = tuple[Field, ...]

#: rosidl's placeholder member of an empty structure.
EMPTY_MEMBER = Field("structure_needs_at_least_one_member", "uint8")


def _resolve(base: str, package: str) -> str:
    """A field's type as a full name: ``Header`` is ``std_msgs/msg/Header``, ``Pkg/Name``
    is ``Pkg/msg/Name``, a bare ``Name`` is the defining package's."""
    if base in PRIMITIVES:
        return base
    if base == "Header":
        return "std_msgs/msg/Header"
    if base.count("/") == 2:
        return base
    if "/" in base:
        pkg, name = base.split("/")
        return f"{pkg}/msg/{name}"
    return f"{package}/msg/{base}"


def _field(line: str, package: str, where: str) -> Field | None:
    """The field of one .msg line, or None for a blank line, comment or constant."""
    text = line.split("#", 1)[0].strip()
    if not text:
        return None
    parts = text.split(None, 2)
    if len(parts) < 2:
        raise InputError(f"{where}: cannot read {line.strip()!r}", field="definition")
    type_text, name = parts[0], parts[1]
    if "=" in name or (len(parts) > 2 and parts[2].startswith("=")):
        return None  # a constant: not part of the wire or the hash
    kind: Kind = "single"
    size = 0
    if type_text.endswith("]"):
        type_text, bound = type_text[:-1].split("[")
        if not bound:
            kind = "sequence"
        elif bound.startswith("<="):
            kind, size = "bounded", int(bound[2:])
        else:
            kind, size = "array", int(bound)
    capacity = 0
    if type_text.startswith(("string<=", "wstring<=")):
        type_text, cap = type_text.split("<=")
        capacity = int(cap)
    return Field(name, _resolve(type_text, package), kind, size, capacity)


def parse_struct(text: str, package: str, where: str = "definition") -> Struct:
    """The fields of a .msg text (constants and default values left out)."""
    fields = tuple(f for f in (_field(line, package, where) for line in text.splitlines())
                   if f is not None)
    return fields or (EMPTY_MEMBER,)


def _service(types: dict[str, Struct], name: str, request: Struct, response: Struct) -> None:
    """Add a service's request, response, event and synthetic type under ``name``."""
    types[f"{name}_Request"] = request
    types[f"{name}_Response"] = response
    types[f"{name}_Event"] = (
        Field("info", "service_msgs/msg/ServiceEventInfo"),
        Field("request", f"{name}_Request", "bounded", 1),
        Field("response", f"{name}_Response", "bounded", 1))
    types[name] = (Field("request_message", f"{name}_Request"),
                   Field("response_message", f"{name}_Response"),
                   Field("event_message", f"{name}_Event"))


def expand(full_name: str, text: str) -> dict[str, Struct]:
    """The structures one interface file defines (``full_name``: ``pkg/msg|srv|action/Name``)."""
    package, kind, _ = full_name.split("/")
    parts = [parse_struct(p, package, full_name) for p in text.split("\n---")]
    types: dict[str, Struct] = {}
    if kind == "msg":
        types[full_name] = parts[0]
    elif kind == "srv":
        _service(types, full_name, parts[0], parts[1])
    else:
        goal, result, feedback = (f"{full_name}_{p}" for p in ("Goal", "Result", "Feedback"))
        types[goal], types[result], types[feedback] = parts
        uuid = Field("goal_id", "unique_identifier_msgs/msg/UUID")
        _service(types, f"{full_name}_SendGoal", (uuid, Field("goal", goal)),
                 (Field("accepted", "bool"), Field("stamp", "builtin_interfaces/msg/Time")))
        _service(types, f"{full_name}_GetResult", (uuid,),
                 (Field("status", "int8"), Field("result", result)))
        types[f"{full_name}_FeedbackMessage"] = (uuid, Field("feedback", feedback))
        types[full_name] = (
            Field("goal", goal), Field("result", result), Field("feedback", feedback),
            Field("send_goal_service", f"{full_name}_SendGoal"),
            Field("get_result_service", f"{full_name}_GetResult"),
            Field("feedback_message", f"{full_name}_FeedbackMessage"))
    return types


@functools.cache
def registry() -> dict[str, Struct]:
    """Every structure of the shipped interface files, by full type name."""
    root = resources.files("robodcn.ros2") / "interfaces"
    types: dict[str, Struct] = {}
    for pkg in root.iterdir():
        if not pkg.is_dir() or pkg.name.startswith(("_", ".")):
            continue
        for kind in pkg.iterdir():
            if not kind.is_dir() or kind.name.startswith(("_", ".")):
                continue
            for file in kind.iterdir():
                stem, dot, ext = file.name.rpartition(".")
                if dot and ext == kind.name:
                    types.update(expand(f"{pkg.name}/{kind.name}/{stem}",
                                        file.read_text(encoding="utf-8")))
    return types


def struct(type_name: str) -> Struct:
    """The fields of ``type_name`` (``pkg/msg/Name``); InputError naming it if unknown."""
    found = registry().get(type_name)
    if found is None:
        raise InputError(f"no ROS 2 interface {type_name!r} is shipped with robodcn",
                         field="type", value=type_name)
    return found


def dds_name(type_name: str) -> str:
    """rmw_zenoh's type name: ``pkg/msg/Name`` → ``pkg::msg::dds_::Name_``."""
    package, kind, name = type_name.split("/")
    return f"{package}::{kind}::dds_::{name}_"
