"""Where the streaming loop takes its samples from.

The loop asks its source for sample i (goal ticks and the encoded Sync Write row); it reads
``streamer.source`` afresh at every sample, so a source with the same sample count and
period can be replaced at a sample boundary (online retargeting, a smooth stop, speed
scaling) without touching the rest of the loop. The count and period are read once when
the stream starts (the per-sample timing records are preallocated from them): a source of
another length needs the loop's bounds updated with it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from robodcn.bus import ServoBus
from robodcn.planner import Trajectory
from robodcn.stream.compensation import compensated_ticks


class PlannedSamples:
    """A planned trajectory as a sample source: goals encoded once, vectorised, up front.

    ``goal(i)`` is the plan (what tracking error is measured against); what is sent,
    ``commanded`` (encoded), is the plan itself or, with ``compensation``, the goals the
    servos need to follow it (:func:`robodcn.stream.compensation.compensated_ticks`).
    """

    def __init__(self, trajectory: Trajectory, bus: ServoBus, *,
                 compensation: bool = False) -> None:
        self.trajectory = trajectory
        self.ticks: NDArray[np.int64] = trajectory.ticks
        self.rate_hz = trajectory.rate_hz
        self.period = 1.0 / trajectory.rate_hz
        self.joint_names = tuple(trajectory.joint_names)
        self.compensated = bool(compensation)
        self.commanded: NDArray[np.int64] = trajectory.ticks
        if compensation:
            request = trajectory.request
            self.commanded = compensated_ticks(
                trajectory.joints, self.period, bus.servos, bus.limits,
                arm=None if request is None else request.arm, p_gains=bus.position_p_gains)
        self._lead_args = (self.period, bus.servos, bus.limits,
                           None if trajectory.request is None else trajectory.request.arm,
                           bus.position_p_gains)
        self._encoded = bus.encode_goals(self.commanded)

    def commanded_for(self, joints: NDArray[np.float64]) -> NDArray[np.int64] | None:
        """The goals this source would send for other joint samples (n, k) rad at its
        period: compensated like its own (None without compensation: the plan is sent).
        An online tail (:mod:`robodcn.stream.online`) is led the same way as the plan."""
        if not self.compensated:
            return None
        period, servos, limits, arm, gains = self._lead_args
        return compensated_ticks(joints, period, servos, limits, arm=arm, p_gains=gains)

    def __len__(self) -> int:
        return len(self.ticks)

    def goal(self, i: int) -> NDArray[np.int64]:
        """Goal ticks (k,) of sample i."""
        return self.ticks[i]

    @property
    def encoded_rows(self) -> list:
        """Every sample as :meth:`ServoBus.write_encoded` takes it (a source built on this
        one shares them)."""
        return self._encoded

    def encoded(self, i: int) -> Sequence[Sequence[int]]:
        """Sample i as :meth:`ServoBus.write_encoded` takes it."""
        return self._encoded[i]
