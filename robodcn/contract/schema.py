"""JSON Schemas derived from declarations: the plan request body (from
:data:`~robodcn.contract.fields.FIELDS`) and result dataclasses (from their type hints and
field metadata)."""

from __future__ import annotations

import dataclasses
import types
import typing
from collections.abc import Iterable
from typing import Any

from robodcn.config import Arm
from robodcn.contract.fields import FIELDS, TOOL_FIELDS, waypoints_field


def request_schema(arm: Arm | None = None, omit: Iterable[str] = ()) -> dict[str, Any]:
    """JSON Schema (2020-12 / OpenAPI 3.1) of the plan request body.

    With ``arm`` the arm-dependent parts are exact: a waypoint has 2 or 3 entries by the
    arm's joint count (an arm with a base yaw: 4, [x, y, z, pitch]), ``start_joints`` one
    entry per joint within that joint's limits, and the ``rate_hz`` and ``payload_kg``
    defaults are the arm's bus rate and payload. ``omit`` drops fields (a move body omits
    :data:`MOVE_OMIT`).
    """
    omit = set(omit)
    properties: dict[str, Any] = {}
    for f in FIELDS:
        if f.name in omit:
            continue
        if f.name == "waypoints":
            f = waypoints_field(arm)
        schema = _copy(f.schema)
        if arm is not None:
            _specialise(f.name, schema, arm)
        schema["description"] = f.description + (f" Unit: {f.unit}." if f.unit else "")
        default = f.default
        if f.name == "rate_hz" and arm is not None:
            default = arm.bus.rate_hz
        elif f.name == "payload_kg" and arm is not None:
            default = arm.payload_kg
        elif f.name in TOOL_FIELDS and arm is not None:
            default = getattr(arm.tool, f.name.removeprefix("tool_"))
        if default is not None or f.name in ("start_joints", "elbow"):
            schema["default"] = default
        properties[f.name] = schema
    return {"type": "object", "additionalProperties": False,
            "required": [f.name for f in FIELDS if f.required and f.name not in omit],
            "properties": properties}


def _copy(schema: Any) -> Any:
    if isinstance(schema, dict):
        return {k: _copy(v) for k, v in schema.items()}
    if isinstance(schema, list):
        return [_copy(v) for v in schema]
    return schema


def _specialise(name: str, schema: dict[str, Any], arm: Arm) -> None:
    if name in TOOL_FIELDS:
        top = getattr(arm.tool, "max_" + name.removeprefix("tool_"))
        if top is not None:
            schema["maximum"] = top
    elif name == "waypoints":
        items = schema["items"]
        if arm.yawed:
            items["minItems"] = 3 if len(arm.chain_joints) == 2 else 4
        else:
            items["minItems"] = 2 if arm.dof == 2 else 3
            items["maxItems"] = 3
    elif name == "start_joints":
        schema["minItems"] = schema["maxItems"] = arm.dof
        schema["prefixItems"] = [{"type": "number", "minimum": j.min_angle,
                                  "maximum": j.max_angle} for j in arm.joints]
        schema["items"] = False
    elif name == "start_state":
        props = schema["properties"]
        for key, bound in (("joints", None), ("velocities", "max_velocity"),
                           ("accelerations", "max_acceleration")):
            item = props[key]
            item["minItems"] = item["maxItems"] = arm.dof
            item["prefixItems"] = [
                {"type": "number", "minimum": j.min_angle, "maximum": j.max_angle}
                if bound is None else
                {"type": "number", "minimum": -getattr(j, bound), "maximum": getattr(j, bound)}
                for j in arm.joints]
            item["items"] = False


_SCALARS: dict[Any, dict[str, Any]] = {
    float: {"type": "number"}, int: {"type": "integer"}, str: {"type": "string"},
    bool: {"type": "boolean"}, type(None): {"type": "null"},
}


def _schema_of_type(hint: Any) -> dict[str, Any]:
    if hint in _SCALARS:
        return dict(_SCALARS[hint])
    if dataclasses.is_dataclass(hint) and isinstance(hint, type):
        return schema_of(hint)
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin is typing.Annotated:
        return _schema_of_type(args[0])
    if origin is typing.Literal:
        values = list(args)
        kinds = {type(v) for v in values}
        out: dict[str, Any] = {"enum": values}
        if kinds == {str}:
            out["type"] = "string"
        return out
    if origin in (typing.Union, types.UnionType):
        options = [_schema_of_type(a) for a in args]
        simple = [o.get("type") for o in options]
        if all(isinstance(t, str) for t in simple) and all(len(o) == 1 for o in options):
            return {"type": simple}
        return {"anyOf": options}
    if origin in (tuple,):
        if len(args) == 2 and args[1] is Ellipsis:
            return {"type": "array", "items": _schema_of_type(args[0])}
        return {"type": "array", "prefixItems": [_schema_of_type(a) for a in args],
                "minItems": len(args), "maxItems": len(args), "items": False}
    if origin in (list, typing.Sequence, Iterable) or (origin is not None and \
            getattr(origin, "__name__", "") in ("Sequence", "list")):
        return {"type": "array", "items": _schema_of_type(args[0]) if args else {}}
    if origin is dict:
        return {"type": "object",
                "additionalProperties": _schema_of_type(args[1]) if len(args) == 2 else {}}
    if hint is Any:
        return {}
    raise TypeError(f"no JSON Schema for type {hint!r}: give metadata={{'schema': ...}}")


def schema_of(cls: type) -> dict[str, Any]:
    """JSON Schema of the dataclass ``cls`` from its type hints and field metadata.

    A field's ``metadata`` may carry ``"description"`` and ``"schema"`` (a schema that
    replaces the one derived from the hint, e.g. for numpy arrays); ``"json": False`` leaves
    the field out. Fields without a default are required.
    """
    hints = typing.get_type_hints(cls, include_extras=False)
    properties: dict[str, Any] = {}
    required = []
    for f in dataclasses.fields(cls):
        if not f.metadata.get("json", True):
            continue
        schema = dict(f.metadata["schema"]) if "schema" in f.metadata \
            else _schema_of_type(hints[f.name])
        if "description" in f.metadata:
            schema["description"] = f.metadata["description"]
        properties[f.name] = schema
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            required.append(f.name)
    out: dict[str, Any] = {"type": "object", "properties": properties, "required": required}
    doc = (cls.__doc__ or "").strip().split("\n", 1)[0]
    if doc:
        out["description"] = doc
    return out
