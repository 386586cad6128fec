"""What every file reader shares: errors naming the file and the key, reading the text."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from robodcn import contract
from robodcn.errors import InputError

#: Slack on limits for float rounding only (as the planner's).
SLACK = 1e-9


def fail(path: str, where: str, message: str, value: Any = None) -> InputError:
    """InputError ``"<path>: <where>: <message>"`` with ``field`` = where."""
    return InputError(f"{path}: {where}: {message}", field=where, value=value)


def read(path: str | Path) -> str:
    """The file's text (UTF-8); InputError naming it when it cannot be read."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"FILE: cannot read {str(path)!r}: {exc}", field="file",
                         value=str(path)) from exc


@contextmanager
def in_file(source: str, where: str) -> Iterator[None]:
    """An InputError of :mod:`robodcn.contract`'s field checks inside, restated naming the
    file and the key (``poses.toml: plan.beta: must be within 0..10, got 12``)."""
    try:
        yield
    except InputError as exc:
        reason = getattr(exc, "reason", None) or exc.message
        raise fail(source, where, reason, exc.value) from None


def number(source: str, where: str, value: Any, schema: Mapping[str, Any] | None = None,
            unit: str | None = None) -> float:
    with in_file(source, where):
        return contract.check_number(where, value, schema or {}, unit)
