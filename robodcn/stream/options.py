"""How :func:`robodcn.stream.execute` runs a trajectory: one validated options object.

:class:`ExecutionOptions` holds the data (numbers, flags, the bus profile and the clock);
the callbacks and the stop signal are :class:`ExecutionHooks`, its ``hooks`` field.
:meth:`ExecutionOptions.build` takes both kinds by name (``stop=``, ``progress=``,
``attach=`` go to the hooks), as :func:`~robodcn.stream.execute` takes its keywords.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from robodcn._checks import is_finite_real, is_int
from robodcn.bus import StreamProfile
from robodcn.errors import InputError
from robodcn.stream.clock import REAL_CLOCK, Clock, as_clock
from robodcn.stream.report import Progress
from robodcn.stream.signal import StopSignal, Waitable


def _number(name: str, value: Any, *, low: float = 0.0, allow_low: bool = False,
            allow_none: bool = False) -> None:
    if value is None and allow_none:
        return
    if not is_finite_real(value) or value < low or (value == low and not allow_low):
        bound = f"≥ {low:g}" if allow_low else f"> {low:g}"
        raise InputError(f"{name} must be a finite number {bound}, got {value!r}", field=name,
                         value=value)


def _integer(name: str, value: Any, low: int) -> None:
    if not is_int(value) or value < low:
        raise InputError(f"{name} must be an integer ≥ {low}, got {value!r}", field=name,
                         value=value)


def _flag(name: str, value: Any) -> None:
    if not isinstance(value, bool):
        raise InputError(f"{name} must be true or false, got {value!r}", field=name,
                         value=value)


def _callable(name: str, value: Any) -> None:
    if value is not None and not callable(value):
        raise InputError(f"{name} must be callable", field=name, value=value)


@dataclass(frozen=True)
class ExecutionHooks:
    """What an execution calls or watches while it runs (checked on construction).

    Attributes
    ----------
    stop : StopSignal or ``threading.Event`` set from any thread to stop; the arm holds.
    progress : called with :class:`Progress` at most every 50 ms and at the end.
    attach : called with the streaming loop just before the first sample (its ``source``
        and ``swap``: online operations, :func:`robodcn.stream.start`).
    """

    stop: StopSignal | Waitable | None = None
    progress: Callable[[Progress], None] | None = None
    attach: Callable[[Any], None] | None = None

    def __post_init__(self) -> None:
        if self.stop is not None and not (hasattr(self.stop, "is_set")
                                          and hasattr(self.stop, "wait")):
            raise InputError("stop must be a StopSignal or threading.Event", field="stop",
                             value=self.stop)
        _callable("progress", self.progress)
        _callable("attach", self.attach)


#: the names :meth:`ExecutionOptions.build` routes to :class:`ExecutionHooks`
HOOK_NAMES = tuple(f.name for f in dataclasses.fields(ExecutionHooks))


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
    release : torque off when finished or stopped (otherwise the servos hold).
    settle : seconds to keep reading after the last sample until the arm is on the final
        goal, or at rest within one tick of it (0: one read).
    health_interval : seconds between Hardware Error Status / Bus Watchdog polls.
    watchdog_ms : Bus Watchdog timeout; None = max(250 ms, 10 periods); 0 = not armed.
    profile : passed to :meth:`ServoBus.configure` when the servos need configuring.
    skip_late : skip samples whose slot has passed (True) or send them late (False).
    realtime : run the calling thread under SCHED_FIFO while streaming.
    clock : the loop's time source (:class:`~robodcn.stream.clock.Clock`; default the real
        clock; a bare callable is read as a real clock's ``now``).
    compensation : send the goals the servos need to follow the plan (a lead by the
        position loop's lag, :mod:`robodcn.stream.compensation`) instead of the plan itself.
    collision_current : per-joint collision-stop thresholds, A (None: from the plan,
        :func:`robodcn.stream.collision.thresholds`); ``collision_cycles`` consecutive feedback
        reads above it stop the move. ``collision=False`` disables the stop.
    recover : on an overload alert, reboot that servo, hold it where it is, re-enable
        torque and report it (the move stays stopped).
    hooks : :class:`ExecutionHooks` (``stop``, ``progress``, ``attach``; also readable as
        attributes of the options).
    start_at : UNIX time (s, this host's clock) the first sample is due; None: as soon as
        the loop starts. A time already past starts at once.
    """

    feedback_every: int = 1
    start_tolerance: float = 0.05
    approach: bool = False
    max_comm_failures: int = 3
    tracking_limit: float | None = 0.25
    release: bool = False
    settle: float = 0.0
    health_interval: float = 0.05
    watchdog_ms: float | None = None
    profile: StreamProfile | None = None
    skip_late: bool = True
    realtime: bool = False
    clock: Clock = REAL_CLOCK
    compensation: bool = True
    collision: bool = True
    collision_current: tuple[float, ...] | None = None
    collision_cycles: int = 3
    recover: bool = False
    hooks: ExecutionHooks = field(default_factory=ExecutionHooks)
    start_at: float | None = None

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
        if self.profile is not None and not isinstance(self.profile, StreamProfile):
            raise InputError(f"profile must be a StreamProfile, got "
                             f"{type(self.profile).__name__}", field="profile",
                             value=self.profile)
        if not isinstance(self.clock, Clock) and not callable(self.clock):
            raise InputError("clock must be a Clock (now, wait_until, sleep) or a callable",
                             field="clock", value=self.clock)
        object.__setattr__(self, "clock", as_clock(self.clock))
        if not isinstance(self.hooks, ExecutionHooks):
            raise InputError(f"hooks must be ExecutionHooks, got {type(self.hooks).__name__}",
                             field="hooks", value=self.hooks)

    @property
    def stop(self) -> StopSignal | Waitable | None:
        return self.hooks.stop

    @property
    def progress(self) -> Callable[[Progress], None] | None:
        return self.hooks.progress

    @property
    def attach(self) -> Callable[[Any], None] | None:
        return self.hooks.attach

    @classmethod
    def build(cls, base: ExecutionOptions | None = None,
              overrides: Mapping[str, Any] | None = None) -> ExecutionOptions:
        """``base`` (default options) with ``overrides`` (option or hook names); an unknown
        name is an InputError."""
        base = cls() if base is None else base
        if not isinstance(base, ExecutionOptions):
            raise InputError(f"options must be ExecutionOptions, got {type(base).__name__}",
                             field="options", value=base)
        overrides = dict(overrides or {})
        names = {f.name for f in dataclasses.fields(cls)} | set(HOOK_NAMES)
        unknown = sorted(set(overrides) - names)
        if unknown:
            raise InputError(f"unknown execution option {unknown[0]!r} (known: "
                             f"{', '.join(sorted(names))})", field=unknown[0],
                             value=overrides[unknown[0]])
        if not overrides:
            return base
        hooks = {k: overrides.pop(k) for k in HOOK_NAMES if k in overrides}
        if hooks:
            overrides["hooks"] = dataclasses.replace(overrides.get("hooks", base.hooks),
                                                     **hooks)
        return dataclasses.replace(base, **overrides)


__all__ = ["HOOK_NAMES", "ExecutionHooks", "ExecutionOptions"]
