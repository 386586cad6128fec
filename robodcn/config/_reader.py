"""Typed access to one TOML table, naming the file and the dotted key in every error."""

from __future__ import annotations

import math
from typing import Any

from robodcn.errors import ConfigError

#: Largest integer any key may hold (a 32-bit register; far past every real range).
MAX_INT = 2**31 - 1


def show_value(value: Any) -> str:
    """A short form of a config value for messages: never a whole table or a long number."""
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list) and any(isinstance(v, dict | list) for v in value):
        return f"an array of {len(value)} entries"
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > MAX_INT:
        return f"an integer of {len(str(abs(value)))} digits"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


class Reader:
    """Typed access to one TOML table that names file and dotted key in every error."""

    def __init__(self, source: str, table: Any, prefix: str) -> None:
        self.source = source
        self.prefix = prefix
        if not isinstance(table, dict):
            raise ConfigError(f"{self.key_name('')!r} must be a table, got {show_value(table)}",
                              file=source, key=prefix or "<top>", value=table)
        self.table = table

    def key_name(self, key: str) -> str:
        if not key:
            return self.prefix
        return f"{self.prefix}.{key}" if self.prefix else key

    def fail(self, key: str, message: str, value: Any) -> ConfigError:
        name = self.key_name(key)
        return ConfigError(f"key {name!r} = {show_value(value)}: {message}", file=self.source,
                           key=name, value=value)

    def only(self, allowed: set[str]) -> None:
        for key in self.table:
            if key not in allowed:
                raise self.fail(key, f"unknown key (allowed: {', '.join(sorted(allowed))})",
                                self.table[key])

    def missing(self, key: str) -> ConfigError:
        name = self.key_name(key)
        return ConfigError(f"missing key {name!r}", file=self.source, key=name, value=None)

    def has(self, key: str) -> bool:
        return key in self.table

    def string(self, key: str, default: str | None = None,
               choices: tuple[str, ...] | None = None) -> str:
        if key not in self.table:
            if default is None:
                raise self.missing(key)
            return default
        value = self.table[key]
        if not isinstance(value, str) or not value:
            raise self.fail(key, "must be a non-empty string", value)
        if choices is not None and value not in choices:
            raise self.fail(key, f"must be one of {', '.join(choices)}", value)
        return value

    def integer(self, key: str, default: int | None = None) -> int:
        if key not in self.table:
            if default is None:
                raise self.missing(key)
            return default
        value = self.table[key]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(key, "must be an integer", value)
        if abs(value) > MAX_INT:
            raise self.fail(key, "is far too large", value)
        return value

    def number(self, key: str, default: float | None = None) -> float:
        if key not in self.table:
            if default is None:
                raise self.missing(key)
            return default
        value = self.table[key]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, "must be a number", value)
        if isinstance(value, int) and abs(value) > MAX_INT:
            raise self.fail(key, "is far too large", value)
        if not math.isfinite(value):
            raise self.fail(key, "must be finite", value)
        return float(value)

    def angle(self, key: str, deg_key: str, scale: float = math.pi / 180.0,
              default: float | None = None) -> float:
        """A quantity given in SI under ``key`` or in degrees under ``deg_key`` (not both)."""
        if key in self.table and deg_key in self.table:
            raise self.fail(deg_key, f"give either {self.key_name(key)!r} or "
                            f"{self.key_name(deg_key)!r}, not both", self.table[deg_key])
        if deg_key in self.table:
            return self.number(deg_key) * scale
        if key in self.table or default is not None:
            return self.number(key, default)
        raise ConfigError(f"missing key {self.key_name(key)!r} (or {self.key_name(deg_key)!r})",
                          file=self.source, key=self.key_name(key), value=None)

    def sub(self, key: str, default: Any = None) -> Reader:
        if key not in self.table:
            if default is None:
                raise self.missing(key)
            return Reader(self.source, default, self.key_name(key))
        return Reader(self.source, self.table[key], self.key_name(key))


    def pair(self, key: str, value: Any, what: str = "(r, z) in metres") -> tuple[float, float]:
        """``value`` (found under ``key``) as a pair of finite numbers."""
        if not isinstance(value, list) or len(value) != 2:
            raise self.fail(key, f"must be a pair {what}", value)
        items = Reader(self.source, {f"{key}[{i}]": v for i, v in enumerate(value)},
                        self.prefix)
        return items.number(f"{key}[0]"), items.number(f"{key}[1]")

    def numbers(self, key: str, n: int, what: str) -> list[float]:
        """The list under ``key`` as exactly ``n`` finite numbers."""
        raw = self.table[key]
        if not isinstance(raw, list) or len(raw) != n:
            raise self.fail(key, f"must be a list of {n} numbers ({what})", raw)
        items = Reader(self.source, {f"{key}[{i}]": v for i, v in enumerate(raw)},
                        self.prefix)
        return [items.number(f"{key}[{i}]") for i in range(n)]
