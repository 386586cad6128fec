"""Online execution: a running stream's path re-timed or replaced while it runs.

One concept a module: ``samples`` (:class:`OnlineSamples`, the source chain), ``state``
(:class:`State`, the commanded state at a switch), ``planning_times``
(:class:`PlanningTimes`, where switches are placed from), ``switch`` (placing and swapping
a tail, :class:`SwitchMissed`), ``timing`` (the laws on the present path, :class:`NoLaw`),
``stop`` (smooth stop and pause), ``speed`` (speed scaling and resume), ``retarget`` (the
retarget strategies), ``turns`` (:class:`Turns`, one operation at a time, a bounded wait)
and ``execution`` (:class:`Execution`, :func:`prepare`, :func:`start`). The path maths is
:mod:`robodcn.stream.online_path`.
"""

from __future__ import annotations

from robodcn.stream.online.execution import STOP_MODES, Execution, prepare, start, warm_up
from robodcn.stream.online.planning_times import PlanningTimes
from robodcn.stream.online.samples import OnlineSamples, Segment
from robodcn.stream.online.speed import KeepPlanned
from robodcn.stream.online.state import State
from robodcn.stream.online.stop import PAUSE_AHEAD_S, PathEnds
from robodcn.stream.online.switch import SwitchMissed
from robodcn.stream.online.timing import NoLaw
from robodcn.stream.online.turns import Turns

__all__ = ["PAUSE_AHEAD_S", "STOP_MODES", "Execution", "KeepPlanned", "NoLaw",
           "OnlineSamples", "PathEnds", "PlanningTimes", "Segment", "State", "SwitchMissed",
           "Turns", "prepare", "start", "warm_up"]
