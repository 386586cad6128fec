"""What a servo reports (:class:`ServoInfo`) and what is written before streaming
(:class:`StreamProfile`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from robodcn import _checks
from robodcn.errors import InputError


@dataclass(frozen=True)
class ServoInfo:
    """What a servo reported: its id, model number (and name when known), firmware, baud."""

    id: int
    model_number: int
    model: str | None
    firmware: int | None
    baud: int

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "model_number": self.model_number, "model": self.model,
                "firmware": self.firmware, "baud": self.baud}


@dataclass(frozen=True)
class StreamProfile:
    """Settings :meth:`ServoBus.configure` writes before streaming.

    ``velocity``/``acceleration`` are the raw Profile Velocity (0.229 rpm a unit) and
    Profile Acceleration (214.577 rev/min² a unit); 0/0 (the default) disables the servo's
    own profile so the position loop follows each streamed goal directly, which is what a
    pre-planned, rate-limited stream wants. ``return_delay_us`` is the Return Delay Time
    (2 µs a unit; the factory 500 µs costs more than the wire time of a whole cycle).
    """

    velocity: int = 0
    acceleration: int = 0
    return_delay_us: int = 0

    def __post_init__(self) -> None:
        for name, value, high in (("velocity", self.velocity, 32767),
                                  ("acceleration", self.acceleration, 32767),
                                  ("return_delay_us", self.return_delay_us, 508)):
            if not _checks.is_int(value) or not 0 <= value <= high:
                raise InputError(f"profile.{name} must be an integer in [0, {high}], "
                                 f"got {value!r}", field=f"profile.{name}", value=value)
