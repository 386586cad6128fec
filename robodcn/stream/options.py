"""How :func:`robodcn.stream.execute` runs a trajectory: one validated options object."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from robodcn.bus import StreamProfile
from robodcn.errors import InputError
from robodcn.stream.report import Progress
from robodcn.stream.signal import StopSignal, Waitable


def _number(name: str, value: Any, *, low: float = 0.0, allow_low: bool = False,
            allow_none: bool = False) -> None:
    if value is None and allow_none:
        return
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value < low or (value == low and not allow_low):
        bound = f"≥ {low:g}" if allow_low else f"> {low:g}"
        raise InputError(f"{name} must be a finite number {bound}, got {value!r}", field=name,
                         value=value)


def _integer(name: str, value: Any, low: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise InputError(f"{name} must be an integer ≥ {low}, got {value!r}", field=name,
                         value=value)


def _flag(name: str, value: Any) -> None:
    if not isinstance(value, bool):
        raise InputError(f"{name} must be true or false, got {value!r}", field=name,
                         value=value)


@dataclass(frozen=True)
class ExecutionOptions:
    """Options of one execution; every field is checked on construction (InputError naming it).

    Attributes
    ----------
    feedback_every : read present positions every k-th sample (0: only at the end).
    start_tolerance : radians; largest |present − first sample| accepted per joint.
    approach : re-plan from the present joints instead of refusing when out of tolerance.
    max_comm_failures : consecutive failed transactions that stop the stream (a lost serial
        device stops it at once).
    tracking_limit : radians; None disables the tracking stop.
    stop : StopSignal or ``threading.Event`` set from any thread to stop; the arm holds.
    progress : called with :class:`Progress` at most every 50 ms and at the end.
    release : torque off when finished or stopped (otherwise the servos hold).
    settle : seconds to keep reading after the last sample until the arm is on the final
        goal, or at rest within one tick of it (0: one read).
    health_interval : seconds between Hardware Error Status / Bus Watchdog polls.
    watchdog_ms : Bus Watchdog timeout; None = max(250 ms, 10 periods); 0 = not armed.
    profile : passed to :meth:`ServoBus.configure` when the servos need configuring.
    skip_late : skip samples whose slot has passed (True) or send them late (False).
    realtime : run the calling thread under SCHED_FIFO while streaming.
    clock : monotonic clock in seconds (real time: the waits sleep on it).
    compensation : send the goals the servos need to follow the plan (a lead by the
        position loop's lag, :mod:`robodcn.stream.compensation`) instead of the plan itself.
    collision_current : per-joint collision-stop thresholds, A (None: from the plan,
        :func:`robodcn.stream.collision.thresholds`); ``collision_cycles`` consecutive feedback
        reads above it stop the move. ``collision=False`` disables the stop.
    recover : on an overload alert, reboot that servo, hold it where it is, re-enable
        torque and report it (the move stays stopped).
    attach : called with the streaming loop just before the first sample (its ``source``
        and ``swap``: online operations, :func:`robodcn.stream.start`).
    """

    feedback_every: int = 1
    start_tolerance: float = 0.05
    approach: bool = False
    max_comm_failures: int = 3
    tracking_limit: float | None = 0.25
    stop: StopSignal | Waitable | None = None
    progress: Callable[[Progress], None] | None = None
    release: bool = False
    settle: float = 0.0
    health_interval: float = 0.05
    watchdog_ms: float | None = None
    profile: StreamProfile | None = None
    skip_late: bool = True
    realtime: bool = False
    clock: Callable[[], float] = time.perf_counter
    compensation: bool = True
    collision: bool = True
    collision_current: tuple[float, ...] | None = None
    collision_cycles: int = 3
    recover: bool = False
    attach: Callable[[Any], None] | None = None

    def __post_init__(self) -> None:
        _integer("feedback_every", self.feedback_every, 0)
        _integer("max_comm_failures", self.max_comm_failures, 1)
        _number("start_tolerance", self.start_tolerance)
        _number("tracking_limit", self.tracking_limit, allow_none=True)
        _number("health_interval", self.health_interval)
        _number("watchdog_ms", self.watchdog_ms, allow_low=True, allow_none=True)
        _number("settle", self.settle, allow_low=True)
        _integer("collision_cycles", self.collision_cycles, 1)
        if self.collision_current is not None:
            values = self.collision_current
            if not isinstance(values, tuple | list) or not values:
                raise InputError(f"collision_current must be a list of currents (A), got "
                                 f"{values!r}", field="collision_current", value=values)
            for j, value in enumerate(values):
                _number(f"collision_current[{j}]", value)
        for name in ("approach", "release", "skip_late", "realtime", "compensation",
                     "collision", "recover"):
            _flag(name, getattr(self, name))
        if self.stop is not None and not (hasattr(self.stop, "is_set")
                                          and hasattr(self.stop, "wait")):
            raise InputError("stop must be a StopSignal or threading.Event", field="stop",
                             value=self.stop)
        if self.progress is not None and not callable(self.progress):
            raise InputError("progress must be callable", field="progress",
                             value=self.progress)
        if self.profile is not None and not isinstance(self.profile, StreamProfile):
            raise InputError(f"profile must be a StreamProfile, got "
                             f"{type(self.profile).__name__}", field="profile",
                             value=self.profile)
        if self.attach is not None and not callable(self.attach):
            raise InputError("attach must be callable", field="attach", value=self.attach)
        if not callable(self.clock):
            raise InputError("clock must be callable", field="clock", value=self.clock)

    @classmethod
    def build(cls, base: ExecutionOptions | None = None,
              overrides: Mapping[str, Any] | None = None) -> ExecutionOptions:
        """``base`` (default options) with ``overrides``; an unknown name is an InputError."""
        base = cls() if base is None else base
        if not isinstance(base, ExecutionOptions):
            raise InputError(f"options must be ExecutionOptions, got {type(base).__name__}",
                             field="options", value=base)
        overrides = dict(overrides or {})
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(overrides) - names)
        if unknown:
            raise InputError(f"unknown execution option {unknown[0]!r} (known: "
                             f"{', '.join(sorted(names))})", field=unknown[0],
                             value=overrides[unknown[0]])
        return dataclasses.replace(base, **overrides) if overrides else base
