"""What a timing law hands the planner's pipeline: the plan's samples before validation.

Both laws (:mod:`~robodcn.planner.uniform`, :mod:`~robodcn.planner.optimal`) implement
:class:`Timing`: ``sample()`` → :class:`Sampled` (or the :class:`~robodcn.errors.Violation`
of a sample out of reach), ``slow(violation, sampled)`` → whether it slowed the failing part
(the pipeline then samples again), ``annotate(violation)`` → the violation as raised.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from robodcn.contract.request import StartState
from robodcn.errors import Violation


@dataclass
class Sampled:
    """The samples of a plan: poses (n, 3), joints (n, k), each sample's segment (−1 on an
    approach or brake), ``marks`` (sample → waypoint index sampled there), ``starts`` (the
    first sample of each piece), ``approach`` (sample periods of a prepended joint-space
    approach, 0: none) and ``history`` ((3, k) samples before t = 0 of a start state)."""

    poses: NDArray[np.float64]
    joints: NDArray[np.float64]
    segment_of: NDArray[np.int64]
    marks: dict[int, int]
    starts: NDArray[np.int64]
    approach: int = 0
    history: NDArray[np.float64] | None = None


class Timing(Protocol):
    """A timing law of the pipeline (module doc)."""

    #: Sample-and-validate rounds at most.
    rounds: int
    #: The moving state the plan starts from (on the Trajectory), or None.
    start_state: StartState | None

    def sample(self) -> Sampled | Violation: ...

    def slow(self, violation: Violation, sampled: Sampled | None) -> bool: ...

    def refine(self) -> bool:
        """Time the same path again on a finer geometry, once (True if it did)."""
        ...

    def annotate(self, violation: Violation) -> Violation: ...
