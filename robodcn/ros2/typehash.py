"""REP 2016 type version hashes (``RIHS01_<sha256 hex>``) of the shipped interfaces.

The hash is SHA-256 of the JSON of the type description: ``{"type_description":
{"type_name", "fields"}, "referenced_type_descriptions": [...]}`` with every type the
type refers to (transitively, sorted by name, each once), each field as ``{"name",
"type": {"type_id", "capacity", "string_capacity", "nested_type_name"}}`` — no default
values, no constants, no comments — written with ``", "`` and ``": "`` separators and no
sorting of keys (REP 2016, "Type Version Hash"; rosidl_generator_type_description).
``type_id`` is the ``type_description_interfaces/FieldType`` code: the primitive's, plus
48 for a fixed array, 96 for a bounded and 144 for an unbounded sequence.
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Mapping

from robodcn.ros2.idl import Field, Struct, registry, struct

#: type_description_interfaces/msg/FieldType codes of the single (non-array) types.
FIELD_TYPE_IDS = {
    "nested": 1, "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7,
    "int64": 8, "uint64": 9, "float32": 10, "float64": 11, "char": 13, "wchar": 14,
    "bool": 15, "byte": 16, "string": 17, "wstring": 18, "bounded_string": 21,
    "bounded_wstring": 22,
}
#: What an array kind adds to the element's code.
KIND_OFFSETS = {"single": 0, "array": 48, "bounded": 96, "sequence": 144}


def _field_type(field: Field) -> dict[str, object]:
    if field.nested:
        base = "nested"
    elif field.string_capacity:
        base = f"bounded_{field.base}"
    else:
        base = field.base
    return {"type_id": FIELD_TYPE_IDS[base] + KIND_OFFSETS[field.kind],
            "capacity": field.size,
            "string_capacity": field.string_capacity,
            "nested_type_name": field.base if field.nested else ""}


def _fields(type_name: str, types: Mapping[str, Struct] | None) -> Struct:
    if types is None or type_name not in types:
        return struct(type_name)  # InputError naming the type when unknown
    return types[type_name]


def _description(type_name: str, types: Mapping[str, Struct] | None) -> dict[str, object]:
    return {"type_name": type_name,
            "fields": [{"name": f.name, "type": _field_type(f)}
                       for f in _fields(type_name, types)]}


def referenced(type_name: str, types: Mapping[str, Struct] | None = None) -> list[str]:
    """Every type ``type_name`` refers to, transitively, sorted by name (itself excluded);
    ``types`` defaults to the shipped interfaces (:func:`robodcn.ros2.idl.registry`)."""
    seen: set[str] = set()
    todo = [type_name]
    while todo:
        for f in _fields(todo.pop(), types):
            if f.nested and f.base not in seen:
                seen.add(f.base)
                todo.append(f.base)
    seen.discard(type_name)
    return sorted(seen)


def description_json(type_name: str, types: Mapping[str, Struct] | None = None) -> str:
    """The hashed text: the type description of ``type_name`` as REP 2016 writes it."""
    full = {"type_description": _description(type_name, types),
            "referenced_type_descriptions": [_description(t, types)
                                             for t in referenced(type_name, types)]}
    return json.dumps(full, separators=(", ", ": "), ensure_ascii=True, allow_nan=False)


def type_hash(type_name: str, types: Mapping[str, Struct] | None = None) -> str:
    """``RIHS01_`` + SHA-256 hex of :func:`description_json` (REP 2016, version 1), of a
    shipped interface or of one in ``types`` (e.g. ``registry() | idl.expand(...)``)."""
    if types is None:
        return _shipped_hash(type_name)
    return "RIHS01_" + hashlib.sha256(description_json(type_name, types).encode()).hexdigest()


@functools.cache
def _shipped_hash(type_name: str) -> str:
    return type_hash(type_name, registry())
