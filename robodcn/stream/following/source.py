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

With tracking compensation (``lead``: :meth:`robodcn.stream.source.PlannedSamples.
commanded_for`) the goal sent for sample i is led like a plan's — half a period ahead plus
the position loop's lag for the motion's velocity, acceleration and torques — over the
commanded joints i − :data:`LEAD_HISTORY` … i + 1, so sample i + 1 is made when sample i
is asked for (a target taken before sample i still changes the goal sent at i: the lead
looks half a period ahead) and the goal steps at most δ = v_max·T from the one sent before
it. A lead is one inverse dynamics of a few rows a sample (about a millisecond here): at
1 kHz a session streams uncompensated.
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
#: commanded samples before sample i its lead is computed over (as an online tail's)
LEAD_HISTORY = 4

#: one period of the session: the commanded joints (k,) rad of sample i, and whether it
#: is the last
Step = Callable[[int], tuple[NDArray[np.float64], bool]]
#: joints (m, k) → led goals (m, k) ticks (``start_goal``, ``first`` as commanded_for's)
Lead = Callable[..., NDArray[np.int64] | None]


class FollowSamples:
    """A sample source made on demand (stream/source.py protocol; module notes)."""

    def __init__(self, step: Step, bus: ServoBus, arm: Any, rate_hz: float,
                 joint_names: Sequence[str], *, lead: Lead | None = None,
                 start_goal: NDArray[np.int64] | None = None) -> None:
        self.rate_hz = float(rate_hz)
        self.period = 1.0 / self.rate_hz
        self.joint_names = tuple(joint_names)
        self.arm = arm
        #: the goal the servos held before the session (the first led step is from it)
        self.start_goal = start_goal
        self.compensated = lead is not None
        self.bus = bus
        self.stream: Any = None
        self._step = step
        self._lead = lead
        k = len(bus.servos)
        self._limits = np.asarray(bus.limits, dtype=np.int64)
        self.joints = np.zeros((CHUNK, k))
        self.ticks = np.zeros((CHUNK, k), dtype=np.int64)
        #: the goals sent (the lead's; the plan's ticks without one)
        self.commanded = np.zeros((CHUNK, k), dtype=np.int64)
        self._encoded: list = []
        #: samples made so far (joints and plan ticks)
        self.made = 0
        #: index of the session's last sample once it is over (None while it runs)
        self.final: int | None = None
        self._n = CHUNK

    def __len__(self) -> int:
        return self._n

    def _make_joints(self, i: int) -> None:
        """Make the generator's samples up to ``i`` (the loop's thread)."""
        while self.made <= i and self.final is None:
            m = self.made
            q, last = self._step(m)
            if m == len(self.joints):
                grow = [np.zeros_like(a) for a in (self.joints, self.ticks, self.commanded)]
                self.joints = np.vstack([self.joints, grow[0]])
                self.ticks = np.vstack([self.ticks, grow[1]])
                self.commanded = np.vstack([self.commanded, grow[2]])
            # the generator keeps the joint limits up to its rounding; the servos' tick
            # limits are the last word (a goal outside them is refused by the bus)
            self.ticks[m] = np.clip(servo_units.radians_to_ticks(q, self.bus.servos),
                                    self._limits[:, 0], self._limits[:, 1])
            self.joints[m] = q
            self.made = m + 1
            if last:
                self.final = m
            elif m + MARGIN >= self._n:
                self._resize(self._n + CHUNK)

    def _make(self, i: int) -> None:
        """Make sample ``i`` and every one before it: joints, the goal sent, its row."""
        while len(self._encoded) <= i:
            s = len(self._encoded)
            self._make_joints(s + (1 if self._lead is not None else 0))
            if s >= self.made:          # past the session's last sample
                break
            goal = self.ticks[s] if self._lead is None else self._led(s)
            self.commanded[s] = goal
            self._encoded.append(self.bus.encode_goals(goal)[0])
            if self.final is not None and s == self.final:
                self._resize(s + 1)

    def _led(self, s: int) -> NDArray[np.int64]:
        """The lead's goal for sample ``s``: over the joints s − LEAD_HISTORY … s + 1 (the
        last at rest again where the session ends at s), from the goal sent before s."""
        assert self._lead is not None
        lo = max(0, s - LEAD_HISTORY)
        after = self.joints[s + 1] if s + 1 < self.made else self.joints[s]
        window = np.vstack([self.joints[lo:s + 1], after[None, :]])
        start = self.commanded[s - 1] if s > 0 else self.start_goal
        led = self._lead(window, start_goal=start, first=s - lo)
        return self.ticks[s] if led is None else led[s - lo]

    def _resize(self, n: int) -> None:
        self._n = n
        if self.stream is not None:
            self.stream.swap(self)

    def _index(self, i: int) -> int:
        return min(max(i, 0), self.made - 1)

    def encoded(self, i: int) -> Sequence[Sequence[int]]:
        """Sample i as :meth:`ServoBus.write_encoded` takes it (made now if it is new)."""
        self._make(i)
        return self._encoded[min(max(i, 0), len(self._encoded) - 1)]

    def goal(self, i: int) -> NDArray[np.int64]:
        """Goal ticks (k,) of sample i (past the samples made: the newest)."""
        if not self.made:
            self._make(0)
        return self.ticks[self._index(i)]

    def sent_goal(self, i: int) -> NDArray[np.int64]:
        """The goal ticks (k,) sample i sends (the lead's; the plan's without one)."""
        if not self._encoded:
            self._make(0)
        return self.commanded[min(max(i, 0), len(self._encoded) - 1)]

    def joint(self, i: int) -> NDArray[np.float64]:
        """Commanded joints (k,) rad of sample i (past the samples made: the newest)."""
        if not self.made:
            self._make(0)
        return self.joints[self._index(i)]


__all__ = ["CHUNK", "LEAD_HISTORY", "FollowSamples", "Lead", "Step"]
