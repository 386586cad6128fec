"""Warn before streaming when the requested rate is more than the bus can carry."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from robodcn.bus import mean_cycle_wire_time


class RateWarning(UserWarning):
    """The requested rate needs more wire time per period than the bus has at its baud.

    Carries the numbers as data (``rate_hz``, ``max_rate_hz``, ``wire_time_s``, ``baud``,
    ``n_servos``, ``feedback``, ``feedback_every``) so the CLI and HTTP can print them in
    their own terms; ``to_dict()`` is the ``{"code", "message", ...}`` form reports carry.
    """

    code = "rate_above_bus_capacity"

    def __init__(self, info: RateCheck) -> None:
        super().__init__(info.message)
        self.info = info

    def to_dict(self) -> dict[str, Any]:
        return {"code": self.code, "message": self.info.message, **self.info.to_dict()}


@dataclass(frozen=True)
class RateCheck:
    """Wire time per sample (average, s) against the period at ``rate_hz``."""

    rate_hz: float
    wire_time_s: float
    baud: int
    n_servos: int
    feedback: str
    feedback_every: int

    @property
    def max_rate_hz(self) -> float:
        return 1.0 / self.wire_time_s

    @property
    def exceeded(self) -> bool:
        return self.rate_hz > self.max_rate_hz

    @property
    def message(self) -> str:
        reads = ("no read-back" if self.feedback == "none" or not self.feedback_every else
                 f"{'Fast ' if self.feedback == 'fast' else ''}Sync Read every "
                 f"{self.feedback_every} sample(s)")
        return (f"rate {self.rate_hz:g} Hz is more than the bus carries: {self.n_servos} "
                f"servo(s) at {self.baud} baud with {reads} need "
                f"{1e6 * self.wire_time_s:.0f} µs of wire time a sample, at most "
                f"{self.max_rate_hz:.0f} Hz; samples will be skipped (lower the rate, "
                "read back less often or raise the baud)")

    def to_dict(self) -> dict[str, Any]:
        return {"rate_hz": self.rate_hz, "max_rate_hz": self.max_rate_hz,
                "wire_time_s": self.wire_time_s, "baud": self.baud,
                "n_servos": self.n_servos, "feedback": self.feedback,
                "feedback_every": self.feedback_every}


def check_rate(rate_hz: float, n_servos: int, baud: int, *, feedback_every: int = 1,
               fast_read: bool | None = True, return_delay_us: float = 0.0,
               item_bytes: int = 4) -> RateWarning | None:
    """A :class:`RateWarning` when ``rate_hz`` exceeds what the bus carries, else None.

    The average wire time per sample (robodcn.bus.wire: one Sync Write each sample, one
    (Fast) Sync Read every ``feedback_every``-th) must fit in the period 1/rate_hz.
    ``fast_read`` None (unknown before :meth:`ServoBus.verify`) assumes Fast Sync Read,
    the cheaper read, so the warning only fires when no configuration could keep up.
    ``item_bytes``: bytes read from each servo (4: positions; 11: the feedback block).
    """
    feedback = "none" if not feedback_every else ("sync" if fast_read is False else "fast")
    wire = mean_cycle_wire_time(n_servos, baud, feedback=feedback,
                                feedback_every=feedback_every,
                                return_delay_us=return_delay_us, item_bytes=item_bytes)
    check = RateCheck(float(rate_hz), wire, int(baud), int(n_servos), feedback,
                      int(feedback_every))
    return RateWarning(check) if check.exceeded else None


__all__ = ["RateCheck", "RateWarning", "check_rate"]
