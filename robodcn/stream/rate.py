"""Warn before streaming when the requested rate is more than the bus can carry, or so low
that the goals step further between samples than a servo should jump."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from robodcn.bus import mean_cycle_wire_time

#: The largest goal step between two samples (rad) streamed without a warning: beyond it
#: the servo's own profile, not the plan, shapes the motion between the samples.
MAX_QUIET_STEP = math.radians(5.0)


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


class CoarseStepWarning(UserWarning):
    """The rate is so low that consecutive goals step more than :data:`MAX_QUIET_STEP`.

    Data: ``rate_hz``, ``joint`` (its name), ``step_rad`` (the largest step), ``sample``
    (where it is) and ``suggested_rate_hz`` (the rate that keeps every step within
    :data:`MAX_QUIET_STEP`); ``to_dict()`` is the form reports carry.
    """

    code = "goal_steps_too_coarse"

    def __init__(self, rate_hz: float, joint: str, step_rad: float, sample: int,
                 suggested_rate_hz: float) -> None:
        self.rate_hz, self.joint, self.step_rad = rate_hz, joint, step_rad
        self.sample, self.suggested_rate_hz = sample, suggested_rate_hz
        super().__init__(self.message)

    @property
    def message(self) -> str:
        return (f"at {self.rate_hz:g} Hz the goals step up to {math.degrees(self.step_rad):.1f}° "
                f"between samples (joint {self.joint!r}, sample {self.sample}): the servo "
                f"jumps between them at its own profile speed; raise the rate to at least "
                f"{self.suggested_rate_hz:.0f} Hz for steps within "
                f"{math.degrees(MAX_QUIET_STEP):.0f}°")

    def to_dict(self) -> dict[str, Any]:
        return {"code": self.code, "message": self.message, "rate_hz": self.rate_hz,
                "joint": self.joint, "step_rad": self.step_rad, "sample": self.sample,
                "suggested_rate_hz": self.suggested_rate_hz}


def check_steps(joints: ArrayLike, rate_hz: float, joint_names: Sequence[str]
                ) -> CoarseStepWarning | None:
    """A :class:`CoarseStepWarning` when two consecutive samples of ``joints`` (n, k) differ
    by more than :data:`MAX_QUIET_STEP` on a joint, else None."""
    q = np.asarray(joints, dtype=np.float64)
    if q.shape[0] < 2:
        return None
    steps = np.abs(np.diff(q, axis=0))
    worst = float(steps.max())
    if worst <= MAX_QUIET_STEP:
        return None
    sample, joint = np.unravel_index(int(np.argmax(steps)), steps.shape)
    return CoarseStepWarning(float(rate_hz), str(joint_names[int(joint)]), worst,
                             int(sample) + 1, math.ceil(rate_hz * worst / MAX_QUIET_STEP))


__all__ = ["MAX_QUIET_STEP", "CoarseStepWarning", "RateCheck", "RateWarning", "check_rate",
           "check_steps"]
