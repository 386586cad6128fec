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
