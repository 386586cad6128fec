"""CDR (XCDR1, little-endian) encoding of the shipped ROS 2 interfaces.

The payload is the 4-byte encapsulation header ``00 01 00 00`` (CDR_LE, options 0) then
the fields in order (OMG DDS-XTypes 1.3 §7.4.3 "plain CDR"; what rmw_zenoh and Fast DDS put
on the wire for ROS 2 messages):

- a primitive of size n ∈ {1, 2, 4, 8} starts at an offset (counted from the byte after
  the header) that is a multiple of n, padding with zeros before it;
- a string is a uint32 length that counts the terminating NUL, the UTF-8 bytes, the NUL;
- an unbounded or bounded sequence is a uint32 element count, then the elements; a fixed
  array is its elements alone;
- a nested structure is its fields, with no alignment of its own.

Values are plain Python: a structure is a dict of its field names, a sequence a list
(a ``uint8``/``byte``/``char`` array or sequence: ``bytes``; ``float64[]``: any sequence of
floats, e.g. a numpy array). Missing fields encode as their zero value.
"""

from __future__ import annotations

import struct as _struct
from collections.abc import Mapping
from typing import Any

from robodcn.errors import InputError
from robodcn.ros2.idl import PRIMITIVES, Field, Struct, registry

#: The encapsulation header of little-endian plain CDR.
HEADER = b"\x00\x01\x00\x00"

_FORMATS = {"bool": "?", "byte": "B", "char": "B", "int8": "b", "uint8": "B", "int16": "h",
            "uint16": "H", "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q",
            "float32": "f", "float64": "d"}
_BYTES = frozenset({"uint8", "byte", "char"})


class CdrError(InputError):
    """A payload that is not a valid CDR encoding of its type (``field``: the JSON-like
    path of the field being read, ``value``: the byte offset)."""


def _types(types: Mapping[str, Struct] | None) -> Mapping[str, Struct]:
    return registry() if types is None else types


class _Writer:
    def __init__(self, types: Mapping[str, Struct]) -> None:
        self.out = bytearray()
        self.types = types

    def align(self, n: int) -> None:
        self.out += b"\x00" * (-len(self.out) % n)

    def scalar(self, base: str, value: Any) -> None:
        size = PRIMITIVES[base]
        if size is None:
            data = str(value).encode("utf-8")
            self.align(4)
            self.out += _struct.pack("<I", len(data) + 1) + data + b"\x00"
            return
        self.align(size)
        self.out += _struct.pack("<" + _FORMATS[base], value)

    def many(self, base: str, values: Any) -> None:
        size = PRIMITIVES.get(base)
        if base in _BYTES and isinstance(values, (bytes, bytearray)):
            self.out += bytes(values)
        elif size is not None:
            values = list(values)
            if values:
                self.align(size)
                self.out += _struct.pack(f"<{len(values)}{_FORMATS[base]}", *values)
        elif base in PRIMITIVES:
            for v in values:
                self.scalar(base, v)
        else:
            for v in values:
                self.struct(base, v)

    def field(self, f: Field, value: Any) -> None:
        if f.kind == "single":
            if f.nested:
                self.struct(f.base, value if value is not None else {})
            else:
                self.scalar(f.base, value if value is not None else _zero(f.base))
            return
        values = value if value is not None else []
        if f.kind == "array":
            if len(values) != f.size:
                raise InputError(f"{f.name} must have {f.size} elements, got {len(values)}",
                                 field=f.name, value=len(values))
        else:
            if f.kind == "bounded" and len(values) > f.size:
                raise InputError(f"{f.name} holds at most {f.size} elements, got "
                                 f"{len(values)}", field=f.name, value=len(values))
            self.scalar("uint32", len(values))
        self.many(f.base, values)

    def struct(self, type_name: str, value: Mapping[str, Any]) -> None:
        for f in self.types[type_name]:
            self.field(f, value.get(f.name))


def _zero(base: str) -> Any:
    if base in ("string", "wstring"):
        return ""
    return False if base == "bool" else 0


def encode(type_name: str, value: Mapping[str, Any],
           types: Mapping[str, Struct] | None = None) -> bytes:
    """The CDR payload (header included) of ``value``, a dict of ``type_name``'s fields."""
    writer = _Writer(_types(types))
    if type_name not in writer.types:
        raise InputError(f"no ROS 2 interface {type_name!r} is shipped with robodcn",
                         field="type", value=type_name)
    writer.struct(type_name, value)
    return HEADER + bytes(writer.out)


class _Reader:
    def __init__(self, data: bytes, types: Mapping[str, Struct]) -> None:
        self.data = memoryview(data)
        self.pos = 0
        self.types = types
        self.path: list[str] = []

    def fail(self, why: str) -> CdrError:
        where = ".".join(self.path) or "payload"
        return CdrError(f"bad CDR at byte {self.pos + 4} ({where}): {why}", field=where,
                        value=self.pos + 4)

    def take(self, n: int) -> memoryview:
        if n < 0 or self.pos + n > len(self.data):
            raise self.fail(f"needs {n} bytes, {len(self.data) - self.pos} left")
        chunk = self.data[self.pos:self.pos + n]
        self.pos += n
        return chunk

    def align(self, n: int) -> None:
        self.pos += -self.pos % n

    def scalar(self, base: str) -> Any:
        size = PRIMITIVES[base]
        if size is None:
            n = self.count()
            raw = bytes(self.take(n))
            if n == 0 or raw[-1] != 0:
                raise self.fail("a string must end with NUL")
            try:
                return raw[:-1].decode("utf-8")
            except UnicodeDecodeError as exc:
                raise self.fail("a string is not UTF-8") from exc
        self.align(size)
        return _struct.unpack("<" + _FORMATS[base], self.take(size))[0]

    def count(self) -> int:
        n = self.scalar("uint32")
        if n > len(self.data) - self.pos:
            raise self.fail(f"a length of {n} runs past the end")
        return n

    def many(self, base: str, n: int) -> Any:
        size = PRIMITIVES.get(base)
        if base in _BYTES:
            return bytes(self.take(n))
        if size is not None:
            if n:
                self.align(size)
            return list(_struct.unpack(f"<{n}{_FORMATS[base]}", self.take(n * size)))
        if base in PRIMITIVES:
            return [self.scalar(base) for _ in range(n)]
        return [self.struct(base) for _ in range(n)]

    def field(self, f: Field) -> Any:
        if f.kind == "single":
            return self.struct(f.base) if f.nested else self.scalar(f.base)
        n = f.size if f.kind == "array" else self.count()
        if f.kind == "bounded" and n > f.size:
            raise self.fail(f"{n} elements in a sequence bounded by {f.size}")
        return self.many(f.base, n)

    def struct(self, type_name: str) -> dict[str, Any]:
        out = {}
        for f in self.types[type_name]:
            self.path.append(f.name)
            out[f.name] = self.field(f)
            self.path.pop()
        return out


def decode(type_name: str, payload: bytes,
           types: Mapping[str, Struct] | None = None) -> dict[str, Any]:
    """The dict of ``type_name``'s fields in a CDR ``payload``; :class:`CdrError` naming the
    field and byte for a short, overlong-length or non-little-endian payload."""
    if len(payload) < 4 or bytes(payload[:2]) != HEADER[:2]:
        raise CdrError(f"a CDR payload starts with {HEADER[:2].hex()} (little-endian plain "
                       f"CDR), got {bytes(payload[:4]).hex() or 'nothing'}",
                       field="payload", value=0)
    reader = _Reader(bytes(payload[4:]), _types(types))
    return reader.struct(type_name)
