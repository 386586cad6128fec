"""The independent side of the ROS 2 wire tests: rosbags' CDR codec (its Jazzy type store,
plus the shipped control_msgs/action texts parsed by rosbags' own .msg parser) and a
converter between rosbags' message objects and the plain dicts robodcn's codec uses."""

from __future__ import annotations

import dataclasses
import functools
import re
from importlib import resources
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.msg import get_types_from_msg

#: The action parts rosidl derives, written as .msg texts for rosbags' parser.
_ACTION_PARTS = {
    "SendGoal_Request": "unique_identifier_msgs/UUID goal_id\n{a}_Goal goal",
    "SendGoal_Response": "bool accepted\nbuiltin_interfaces/Time stamp",
    "GetResult_Request": "unique_identifier_msgs/UUID goal_id",
    "GetResult_Response": "int8 status\n{a}_Result result",
    "FeedbackMessage": "unique_identifier_msgs/UUID goal_id\n{a}_Feedback feedback",
}


_BARE = re.compile(r"^([A-Z]\w*)(?=[\[\s])", re.MULTILINE)


def _parse(text: str, name: str) -> dict[str, Any]:
    """rosbags' parse of a .msg text registered as ``name``: a bare type is the package's
    own message (``Header``: std_msgs'), as rosidl resolves it."""
    pkg = name.split("/")[0]
    text = _BARE.sub(lambda m: "std_msgs/Header" if m[1] == "Header" else f"{pkg}/{m[1]}",
                     text)
    (parsed,) = get_types_from_msg(text, f"{pkg}/msg/Parsed").values()
    return {name: parsed}


@functools.cache
def store():
    """rosbags' Jazzy store with the shipped interfaces it lacks, parsed by rosbags."""
    ts = get_typestore(Stores.ROS2_JAZZY)
    root = resources.files("robodcn.ros2") / "interfaces"
    found: dict[str, Any] = {}
    for pkg in root.iterdir():
        for kind in pkg.iterdir():
            for file in kind.iterdir():
                name = f"{pkg.name}/{kind.name}/{file.name.rsplit('.', 1)[0]}"
                text = file.read_text()
                if kind.name == "msg" and name not in ts.fielddefs:
                    found.update(_parse(text, name))
                elif kind.name == "srv":
                    request, response = text.split("\n---")
                    found.update(_parse(request, f"{name}_Request"))
                    found.update(_parse(response, f"{name}_Response"))
                elif kind.name == "action":
                    for part, body in zip(("Goal", "Result", "Feedback"), text.split("\n---"),
                                          strict=True):
                        found.update(_parse(body, f"{name}_{part}"))
                    for part, body in _ACTION_PARTS.items():
                        found.update(_parse(body.format(a=name), f"{name}_{part}"))
    ts.register(found)
    return ts


def to_plain(msg: Any) -> Any:
    """A rosbags message as plain dicts/lists (uint8 arrays as bytes)."""
    if dataclasses.is_dataclass(msg):
        return {f.name: to_plain(getattr(msg, f.name)) for f in dataclasses.fields(msg)
                if not f.name.startswith("__") and not f.name.isupper()}
    if isinstance(msg, np.ndarray):
        return msg.tobytes() if msg.dtype == np.uint8 else msg.tolist()
    if isinstance(msg, list):
        return [to_plain(m) for m in msg]
    return msg


def decode(type_name: str, payload: bytes) -> Any:
    return store().deserialize_cdr(payload, type_name)


def encode(msg: Any, type_name: str) -> bytes:
    return bytes(store().serialize_cdr(msg, type_name))


_NUMPY = {"bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8,
          "uint8": np.uint8, "int16": np.int16, "uint16": np.uint16, "int32": np.int32,
          "uint32": np.uint32, "int64": np.int64, "uint64": np.uint64,
          "float32": np.float32, "float64": np.float64}
_ZERO = {"string": "", "bool": False}


def _value(desc: Any, value: Any) -> Any:
    kind, detail = desc
    if kind.name == "NAME":
        return from_plain(detail, value or {})
    if kind.name == "BASE":
        base = detail[0]
        return value if value is not None else _ZERO.get(base, 0)
    (inner_kind, inner), size = detail
    value = [] if value is None else value
    if inner_kind.name == "BASE" and inner[0] in _NUMPY:
        if isinstance(value, (bytes, bytearray)):
            return np.frombuffer(bytes(value), dtype=np.uint8).copy()
        return np.asarray(value if len(value) else [0] * size if kind.name == "ARRAY"
                          else [], dtype=_NUMPY[inner[0]])
    return [_value((inner_kind, inner), v) for v in value]


def from_plain(type_name: str, value: dict[str, Any]) -> Any:
    """A rosbags message of ``type_name`` from plain dicts (missing fields are zero)."""
    ts = store()
    _, fields = ts.fielddefs[type_name]
    return ts.types[type_name](**{name: _value(desc, value.get(name))
                                  for name, desc in fields})


def encode_plain(type_name: str, value: dict[str, Any]) -> bytes:
    """rosbags' CDR of a plain dict."""
    return encode(from_plain(type_name, value), type_name)
