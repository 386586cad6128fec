"""The sample source of an online execution: a chain whose tail an operation replaces.

Each node holds the samples from its switch on (joints on a joint path at arc lengths σ,
their ticks and encoded rows); the samples before the switch are the previous node's. The
loop reads the chain afresh at every sample (:meth:`robodcn.stream.loop.Stream.swap`), so a
new node swapped in before the loop reaches its switch changes no sample the loop read.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from robodcn import servo_units
from robodcn.bus import ServoBus
from robodcn.planner import Trajectory
from robodcn.stream.online_path import JointPath
from robodcn.stream.source import PlannedSamples


class OnlineSamples:
    """A sample source whose tail an online operation replaces (stream/source.py protocol).

    Samples i < ``switch`` are ``prev``'s; samples switch … switch + m − 1 are this node's
    joints (m, k) on ``path`` at arc lengths ``sigma``; after them the last goal repeats
    ``hold`` times (a pause). Any index past the end answers the last goal, so a loop that
    still has an older, longer bound never reads outside."""

    def __init__(self, prev: OnlineSamples | None, switch: int, joints: NDArray[np.float64],
                 sigma: NDArray[np.float64], path: JointPath, bus: ServoBus, rate_hz: float,
                 joint_names: Sequence[str], *, ticks: NDArray[np.int64] | None = None,
                 encoded: list | None = None, hold: int = 0,
                 lead: Callable[[NDArray[np.float64]], NDArray[np.int64] | None] | None = None
                 ) -> None:
        self.prev = prev
        self.switch = int(switch)
        self.joints = np.asarray(joints, dtype=np.float64)
        self.sigma = np.asarray(sigma, dtype=np.float64)
        self.path = path
        self.bus = bus
        self.rate_hz = float(rate_hz)
        self.period = 1.0 / self.rate_hz
        self.joint_names = tuple(joint_names)
        if ticks is None:
            ticks = servo_units.radians_to_ticks(self.joints, bus.servos)
            bus.check_ticks(ticks)
        self.ticks = np.asarray(ticks, dtype=np.int64)
        #: the goals the servos need to follow the joints (tracking compensation, as the
        #: plan's: :meth:`robodcn.stream.source.PlannedSamples.commanded_for`), or None
        self.lead = lead if lead is not None else (None if prev is None else prev.lead)
        self.compensated = self.lead is not None
        if encoded is None:
            encoded = bus.encode_goals(self._commanded())
        self._encoded = encoded
        self.hold = int(hold)
        self._own = len(self.ticks)

    def _commanded(self) -> NDArray[np.int64]:
        """What is sent for this node's joints: the plan's ticks, or with a lead the
        compensated goals, from finite differences that start at the two samples before
        the switch (no step in the lead where the tail begins)."""
        if self.lead is None:
            return self.ticks
        before = [self.prev.joint(i) for i in range(max(0, self.switch - 2), self.switch)] \
            if self.prev is not None else []
        joints = np.vstack([*before, self.joints]) if before else self.joints
        commanded = self.lead(joints)
        return self.ticks if commanded is None else commanded[len(before):]

    @classmethod
    def of_trajectory(cls, trajectory: Trajectory, bus: ServoBus,
                      encoded: list | None = None,
                      lead: Callable[[NDArray[np.float64]], NDArray[np.int64] | None]
                      | None = None) -> OnlineSamples:
        """The root of a chain: the planned samples (``encoded``: as the streamer encoded
        them; ``lead``: how a tail's goals are compensated, None to send the joints)."""
        path, sigma = JointPath.of_samples(trajectory.joints)
        return cls(None, 0, trajectory.joints, sigma, path, bus, trajectory.rate_hz,
                   trajectory.joint_names, ticks=trajectory.ticks, encoded=encoded, lead=lead)

    @classmethod
    def of_planned(cls, planned: PlannedSamples, bus: ServoBus) -> OnlineSamples:
        """The root of a chain over the streamer's planned samples, encoded and led as they
        are (:class:`~robodcn.stream.source.PlannedSamples`)."""
        lead = planned.commanded_for if planned.compensated else None
        return cls.of_trajectory(planned.trajectory, bus, encoded=planned.encoded_rows,
                                 lead=lead)

    def held(self, hold: int) -> OnlineSamples:
        """This source with ``hold`` repeats of its last goal (shares every array)."""
        return OnlineSamples(self.prev, self.switch, self.joints, self.sigma, self.path,
                             self.bus, self.rate_hz, self.joint_names, ticks=self.ticks,
                             encoded=self._encoded, hold=hold, lead=self.lead)

    def __len__(self) -> int:
        return self.switch + self._own + self.hold

    def _node(self, i: int) -> tuple[OnlineSamples, int]:
        node = self
        while i < node.switch and node.prev is not None:
            node = node.prev
        return node, min(max(i - node.switch, 0), node._own - 1)

    def goal(self, i: int) -> NDArray[np.int64]:
        node, j = self._node(i)
        return node.ticks[j]

    def encoded(self, i: int) -> Sequence[Sequence[int]]:
        node, j = self._node(i)
        return node._encoded[j]

    def joint(self, i: int) -> NDArray[np.float64]:
        """Commanded joints (k,) rad of sample i (before rounding to ticks)."""
        node, j = self._node(i)
        return node.joints[j]

    def path_at(self, i: int) -> tuple[JointPath, float]:
        """The path sample i lies on and its σ there."""
        node, j = self._node(i)
        return node.path, float(node.sigma[j])

    @property
    def end(self) -> int:
        """Index after this node's own samples (where a hold begins)."""
        return self.switch + self._own


#: new samples on one path: joints (m, k), their σ (m,), the path
Segment = tuple[NDArray[np.float64], NDArray[np.float64], JointPath]


__all__ = ["OnlineSamples", "Segment"]
