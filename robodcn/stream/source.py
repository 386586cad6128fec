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
from robodcn.errors import BusError
from robodcn.planner import Trajectory
from robodcn.stream.compensation import compensated_ticks


def servo_state(bus: ServoBus, present: NDArray[np.int64] | None = None
                ) -> tuple[NDArray[np.int64] | None, NDArray[np.int64] | None,
                           tuple[int, ...] | None]:
    """What the lead starts from: the Goal Position the servos hold and their Present
    Position (ticks, bus order; ``present`` when the caller has just read it) and Position
    I Gains, each None where it cannot be read."""
    try:
        goal: list[int] | None = [int(g) for g in bus.read_goals()]  # no straggler passes
    except BusError:
        goal = None
    if present is None:
        try:
            present = bus.read_positions()
        except BusError:
            present = None
    i_gains = getattr(bus, "position_i_gains", None)
    if i_gains is None:
        try:
            i_gains = bus.read_position_i_gains()
        except BusError:
            i_gains = None
    return (None if goal is None else np.array(goal, dtype=np.int64), present,
            None if i_gains is None else tuple(int(g) for g in i_gains))


class PlannedSamples:
    """A planned trajectory as a sample source: goals encoded once, vectorised, up front.

    ``goal(i)`` is the plan (what tracking error is measured against); what is sent,
    ``commanded`` (encoded), is the plan itself or, with ``compensation``, the goals the
    servos need to follow it (:func:`robodcn.stream.compensation.compensated_ticks`: led,
    the first step from the goal the servos hold now, read here with their present
    positions and I gains; the payload the plan's request names).
    """

    def __init__(self, trajectory: Trajectory, bus: ServoBus, *,
                 compensation: bool = False, present: NDArray[np.int64] | None = None
                 ) -> None:
        self.trajectory = trajectory
        self.ticks: NDArray[np.int64] = trajectory.ticks
        self.rate_hz = trajectory.rate_hz
        self.period = 1.0 / trajectory.rate_hz
        self.joint_names = tuple(trajectory.joint_names)
        self.compensated = bool(compensation)
        self.commanded: NDArray[np.int64] = trajectory.ticks
        request = trajectory.request
        self.arm = None if request is None else request.arm
        self.payload_kg = None if request is None else getattr(request, "payload_kg", None)
        self.i_gains: tuple[int, ...] | None = None
        #: the Goal Position (k,) the servos held before the stream, ticks (read with
        #: compensation; None otherwise): the loop's first write is step-limited from it
        self.start_goal: NDArray[np.int64] | None = None
        self._bus = bus
        if compensation:
            self.start_goal, present, self.i_gains = servo_state(bus, present)
            self.commanded = compensated_ticks(
                trajectory.joints, self.period, bus.servos, bus.limits, arm=self.arm,
                p_gains=bus.position_p_gains, i_gains=self.i_gains,
                start_goal=self.start_goal, present=present, payload_kg=self.payload_kg)
        self._encoded = bus.encode_goals(self.commanded)

    def commanded_for(self, joints: NDArray[np.float64], *,
                      start_goal: NDArray[np.int64] | None = None,
                      first: int = 0) -> NDArray[np.int64] | None:
        """The goals this source would send for other joint samples (n, k) rad at its
        period: compensated like its own (None without compensation: the plan is sent).
        An online tail (:mod:`robodcn.stream.online`) is led the same way as the plan;
        ``start_goal`` (the goal sent before row ``first``, ticks) limits the step into
        row ``first`` like the plan's first (rows before ``first``: the samples before the
        switch, for the differences only)."""
        if not self.compensated:
            return None
        bus = self._bus
        return compensated_ticks(joints, self.period, bus.servos, bus.limits, arm=self.arm,
                                 p_gains=bus.position_p_gains, i_gains=self.i_gains,
                                 start_goal=start_goal, payload_kg=self.payload_kg,
                                 first=first)

    def sent_goal(self, i: int) -> NDArray[np.int64]:
        """The goal ticks (k,) sample i sends (``commanded``; the plan without a lead)."""
        return self.commanded[i]

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
