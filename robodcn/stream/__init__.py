"""Execute a :class:`~robodcn.planner.Trajectory` on a :class:`~robodcn.bus.ServoBus` in real time.

One concept a module: ``streamer`` (:func:`execute`; its docstring has the rules),
``options`` (:class:`ExecutionOptions`, :class:`ExecutionHooks`), ``clock`` (the loop's
time source: :class:`RealClock`, :class:`VirtualClock`), ``signal`` (:class:`StopSignal`),
``preflight`` (the refusals before any write, the approach, configuration), ``loop`` (the
schedule), ``feedback`` (reads, tracking, collision, health), ``finish`` (hold, recover,
final reads), ``summary`` (the report of a finished stream), ``report`` (:class:`Progress`,
:class:`ExecutionReport`, :class:`Approach`, the one tracking-error definition),
``source`` (the loop's sample source), ``rate`` (the bus-capacity warning), ``realtime``
(timer slack, SCHED_FIFO), ``servo_model`` (arm inverse dynamics and the DC-motor model),
``compensation`` (the goals that make a servo follow the plan), ``collision`` (predicted
currents, collision thresholds), ``trace`` (every feedback read, :class:`ExecutionTrace`),
``in_position`` (the final position against the goal, :class:`PositionMiss`),
``online`` (operations on a running stream: :func:`start`, :class:`Execution`) and
``online_path`` (its path maths), ``following`` (a stream of targets: :func:`follow`,
:class:`Follower`). Every public name is importable from ``robodcn.stream``.
"""

from __future__ import annotations

import logging

from robodcn.stream.clock import REAL_CLOCK, Clock, RealClock, VirtualClock
from robodcn.stream.collision import predicted_currents, thresholds
from robodcn.stream.compensation import compensated_ticks
from robodcn.stream.following import Follower, follow
from robodcn.stream.in_position import PositionMiss
from robodcn.stream.online import STOP_MODES, Execution, OnlineSamples, PlanningTimes, start
from robodcn.stream.options import ExecutionHooks, ExecutionOptions
from robodcn.stream.rate import RateCheck, RateWarning, check_rate
from robodcn.stream.realtime import (
    REALTIME_PRIORITY,
    SPIN_REALTIME_S,
    SPIN_S,
    realtime_priority,
    timer_slack,
)
from robodcn.stream.report import (
    OUTCOMES,
    STOP_REASONS,
    Approach,
    ExecutionReport,
    Progress,
    approach_of,
    near_limits,
    outcome_of,
    tracking_error,
)
from robodcn.stream.signal import StopSignal
from robodcn.stream.source import PlannedSamples
from robodcn.stream.streamer import PROGRESS_INTERVAL_S, execute
from robodcn.stream.trace import ExecutionTrace

# A library logs, the application decides where it goes: without a configured handler
# (the CLI's -v/--log-level, the service's logging), nothing is printed.
logging.getLogger("robodcn.stream").addHandler(logging.NullHandler())

__all__ = [
    "OUTCOMES",
    "PROGRESS_INTERVAL_S",
    "REALTIME_PRIORITY",
    "REAL_CLOCK",
    "SPIN_REALTIME_S",
    "SPIN_S",
    "STOP_MODES",
    "STOP_REASONS",
    "Approach",
    "Clock",
    "Execution",
    "ExecutionHooks",
    "ExecutionOptions",
    "ExecutionReport",
    "ExecutionTrace",
    "Follower",
    "OnlineSamples",
    "PlannedSamples",
    "PlanningTimes",
    "PositionMiss",
    "Progress",
    "RateCheck",
    "RateWarning",
    "RealClock",
    "StopSignal",
    "VirtualClock",
    "approach_of",
    "check_rate",
    "compensated_ticks",
    "execute",
    "follow",
    "near_limits",
    "outcome_of",
    "predicted_currents",
    "realtime_priority",
    "start",
    "thresholds",
    "timer_slack",
    "tracking_error",
]
