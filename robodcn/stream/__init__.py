"""Execute a :class:`~robodcn.planner.Trajectory` on a :class:`~robodcn.bus.ServoBus` in real time.

One concept a module: ``options`` (:class:`ExecutionOptions`), ``signal``
(:class:`StopSignal`), ``source`` (the loop's sample source), ``streamer`` (the loop and
:func:`execute`; its docstring has the rules), ``report`` (:class:`Progress`,
:class:`ExecutionReport`, the one tracking-error definition), ``rate`` (the bus-capacity
warning), ``realtime`` (timer slack, SCHED_FIFO), ``servo_model`` (arm inverse dynamics and
the DC-motor model), ``compensation`` (the goals that make a servo follow the plan),
``collision`` (predicted currents, collision thresholds) and ``trace`` (every feedback
read, :class:`ExecutionTrace`). Moving from the present pose lives in
:mod:`robodcn.present`. Every public name is importable from ``robodcn.stream``.
"""

from __future__ import annotations

import logging

from robodcn.stream.collision import predicted_currents, thresholds
from robodcn.stream.compensation import compensated_ticks
from robodcn.stream.online import STOP_MODES, Execution, OnlineSamples, start
from robodcn.stream.options import ExecutionOptions
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
    ExecutionReport,
    Progress,
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
    "SPIN_REALTIME_S",
    "SPIN_S",
    "STOP_MODES",
    "STOP_REASONS",
    "Execution",
    "ExecutionOptions",
    "ExecutionReport",
    "ExecutionTrace",
    "OnlineSamples",
    "PlannedSamples",
    "Progress",
    "RateCheck",
    "RateWarning",
    "StopSignal",
    "check_rate",
    "compensated_ticks",
    "execute",
    "near_limits",
    "outcome_of",
    "predicted_currents",
    "realtime_priority",
    "start",
    "thresholds",
    "timer_slack",
    "tracking_error",
]
