"""The streaming loop's sample source of a follow session: the online generator's samples,
made one period at a time as the loop asks for them.

The loop (:mod:`robodcn.stream.loop`) asks for sample i when it is due; :class:`FollowSamples`
then asks its ``step`` (the session's: one :meth:`robodcn.online.Generator.update` toward
the newest target) for every sample up to i it has not made yet — samples the loop skipped
after a stall are made too, so the motion stays on the clock — and keeps every one made
(joints, goal ticks, the encoded Sync Write row: the session's record). Its length grows by
:data:`CHUNK` samples ahead of the loop (:meth:`robodcn.stream.loop.Stream.swap`); when
``step`` says the session is over (at rest at its last target, or braked to rest), the
length becomes the samples made and the loop ends after the last one, as a move ends.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn import servo_units
from robodcn.bus import ServoBus

#: samples the source's length runs ahead of the loop
CHUNK = 4096
#: the length grows when the loop gets within this many samples of it
MARGIN = 64

#: one period of the session: the commanded joints (k,) rad of sample i, and whether it
#: is the last
Step = Callable[[int], tuple[NDArray[np.float64], bool]]


class FollowSamples:
    """A sample source made on demand (stream/source.py protocol; module notes)."""

    def __init__(self, step: Step, bus: ServoBus, arm: Any, rate_hz: float,
                 joint_names: Sequence[str]) -> None:
        self.rate_hz = float(rate_hz)
        self.period = 1.0 / self.rate_hz
        self.joint_names = tuple(joint_names)
        self.arm = arm
        self.start_goal = None
        self.compensated = False
        self.bus = bus
        self.stream: Any = None
        self._step = step
        k = len(bus.servos)
        self._limits = np.asarray(bus.limits, dtype=np.int64)
        self.joints = np.zeros((CHUNK, k))
        self.ticks = np.zeros((CHUNK, k), dtype=np.int64)
        self._encoded: list = []
        #: samples made so far
        self.made = 0
        #: index of the session's last sample once it is over (None while it runs)
        self.final: int | None = None
        self._n = CHUNK

    def __len__(self) -> int:
        return self._n

    def _make(self, i: int) -> None:
        """Make every sample up to ``i`` (the loop's thread)."""
        while self.made <= i and self.final is None:
            m = self.made
            q, last = self._step(m)
            if m == len(self.joints):
                self.joints = np.vstack([self.joints, np.zeros_like(self.joints)])
                self.ticks = np.vstack([self.ticks, np.zeros_like(self.ticks)])
            # the generator keeps the joint limits up to its rounding; the servos' tick
            # limits are the last word (a goal outside them is refused by the bus)
            ticks = np.clip(servo_units.radians_to_ticks(q, self.bus.servos),
                            self._limits[:, 0], self._limits[:, 1])
            self.joints[m] = q
            self.ticks[m] = ticks
            self._encoded.append(self.bus.encode_goals(ticks)[0])
            self.made = m + 1
            if last:
                self._resize(m + 1)
                self.final = m
            elif m + MARGIN >= self._n:
                self._resize(self._n + CHUNK)

    def _resize(self, n: int) -> None:
        self._n = n
        if self.stream is not None:
            self.stream.swap(self)

    def _index(self, i: int) -> int:
        return min(max(i, 0), self.made - 1)

    def encoded(self, i: int) -> Sequence[Sequence[int]]:
        """Sample i as :meth:`ServoBus.write_encoded` takes it (made now if it is new)."""
        self._make(i)
        return self._encoded[self._index(i)]

    def goal(self, i: int) -> NDArray[np.int64]:
        """Goal ticks (k,) of sample i (past the samples made: the newest)."""
        if not self.made:
            self._make(0)
        return self.ticks[self._index(i)]

    sent_goal = goal

    def joint(self, i: int) -> NDArray[np.float64]:
        """Commanded joints (k,) rad of sample i (past the samples made: the newest)."""
        if not self.made:
            self._make(0)
        return self.joints[self._index(i)]


__all__ = ["CHUNK", "FollowSamples", "Step"]
