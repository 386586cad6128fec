"""The sample source of an online execution: a chain whose tail an operation replaces.

Each node holds the samples from its switch on (joints on a joint path at arc lengths σ,
their ticks and encoded rows); the samples before the switch are the previous node's. The
loop reads the chain afresh at every sample (:meth:`robodcn.stream.loop.Stream.swap`), so a
new node swapped in before the loop reaches its switch changes no sample the loop read.

With tracking compensation a node's goals are led like the plan's, across its switch (the
commanded samples before it give the differences) and from the goal sent before it, so
every goal steps at most v_max·T from the one before; an operation's last segment, which
ends at rest, is lengthened by samples at rest where it is too short for that ramp
(:meth:`OnlineSamples._commanded`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import servo_units
from robodcn.bus import ServoBus
from robodcn.planner import Trajectory
from robodcn.stream.compensation import max_steps
from robodcn.stream.online_path import JointPath
from robodcn.stream.source import PlannedSamples

#: how a node's joints (m, k) rad are led into goal ticks from the goal sent before them
#: (:meth:`robodcn.stream.source.PlannedSamples.commanded_for`; None: the joints are sent)
Lead = Callable[..., NDArray[np.int64] | None]


#: commanded samples before a switch a tail's lead is computed over (:meth:`OnlineSamples._led`)
LEAD_HISTORY = 4
#: rounds of lengthening a tail that ends at rest until its lead's ramp fits
SETTLE_TRIES = 4


class OnlineSamples:
    """A sample source whose tail an online operation replaces (stream/source.py protocol).

    Samples i < ``switch`` are ``prev``'s; samples switch … switch + m − 1 are this node's
    joints (m, k) on ``path`` at arc lengths ``sigma``; after them the last goal repeats
    ``hold`` times (a pause). Any index past the end answers the last goal, so a loop that
    still has an older, longer bound never reads outside."""

    def __init__(self, prev: OnlineSamples | None, switch: int, joints: NDArray[np.float64],
                 sigma: NDArray[np.float64], path: JointPath, bus: ServoBus, rate_hz: float,
                 joint_names: Sequence[str], *, ticks: NDArray[np.int64] | None = None,
                 encoded: list | None = None, hold: int = 0, lead: Lead | None = None,
                 commanded: NDArray[np.int64] | None = None, step: ArrayLike | None = None,
                 settle: bool = False) -> None:
        self.prev = prev
        self.switch = int(switch)
        self.joints = np.asarray(joints, dtype=np.float64)
        self.sigma = np.asarray(sigma, dtype=np.float64)
        self.path = path
        self.bus = bus
        self.rate_hz = float(rate_hz)
        self.period = 1.0 / self.rate_hz
        self.joint_names = tuple(joint_names)
        #: the goals the servos need to follow the joints (tracking compensation, as the
        #: plan's: :meth:`robodcn.stream.source.PlannedSamples.commanded_for`), or None
        self.lead = lead if lead is not None else (None if prev is None else prev.lead)
        self.compensated = self.lead is not None
        #: each joint's largest goal step δ = v_max·T, ticks (inf: none; as the plan's)
        self.step = np.asarray(step if step is not None else
                               (np.inf if prev is None else prev.step), dtype=np.float64)
        if commanded is None:   # (may lengthen the joints: settle)
            commanded = self._commanded(settle and ticks is None)
        if ticks is None:
            ticks = servo_units.radians_to_ticks(self.joints, bus.servos)
            bus.check_ticks(ticks)
        self.ticks = np.asarray(ticks, dtype=np.int64)
        #: the goals sent for this node's own samples, ticks (m, k)
        self.commanded = np.asarray(self.ticks if commanded is None else commanded,
                                    dtype=np.int64)
        if encoded is None:
            encoded = bus.encode_goals(self.commanded)
        self._encoded = encoded
        self.hold = int(hold)
        self._own = len(self.ticks)

    def _led(self, joints: NDArray[np.float64],
              start: NDArray[np.int64] | None) -> NDArray[np.int64] | None:
        """The lead's goals for ``joints`` (m, k) after the switch, led from the commanded
        samples before it: the :data:`LEAD_HISTORY` joints the previous node sends before
        the switch are the rows before ``first`` (:meth:`~robodcn.stream.source.
        PlannedSamples.commanded_for`), so q̇ and q̈ at the tail's first samples are the
        central differences across the switch and the friction sign is the motion's before
        it (led on its own, a tail's first velocity was a one-sided difference and a tail
        under three samples had none at all: no velocity, acceleration or friction lead)."""
        assert self.lead is not None
        prev = self.prev
        k = 0 if prev is None else min(LEAD_HISTORY, self.switch)
        if prev is None or k == 0:
            return self.lead(joints, start_goal=start)
        before = np.array([prev.joint(i) for i in range(self.switch - k, self.switch)])
        led = self.lead(np.vstack([before, joints]), start_goal=start, first=k)
        return None if led is None else led[k:]

    def _commanded(self, settle: bool) -> NDArray[np.int64] | None:
        """What is sent for this node's joints: the plan's ticks (None), or with a lead the
        compensated goals, led like the plan's from the goal sent before the switch
        (``start_goal``: the previous node's goal at sample switch − 1, so the first goal
        steps at most δ from it and a lead that differs from the one before the switch
        is ramped in over the next samples instead of stepping there; :meth:`_led`).

        Where the tail is too short to ramp from that goal to its own last goal within δ
        per sample (a brake of a sample or two at a move's start, where the plan's goals
        still carry the lead of its acceleration and the rest goal does not), the start's
        cone would keep the tail off its last goal: with ``settle`` (the tail ends at rest:
        the last segment of an operation) the tail is lengthened by samples at rest on its
        last joints until the ramp fits (every step within δ: issue 17 §7), else it is led
        without that start (its last goal kept; the loop's step guard slews the step)."""
        if self.lead is None:
            return None
        start = None if self.prev is None else self.prev.sent_goal(self.switch - 1)
        commanded = self._led(self.joints, start)
        if commanded is None or start is None or not len(commanded):
            return commanded
        for _ in range(SETTLE_TRIES if settle else 0):
            if self._ramp_samples(commanded[-1], start) <= len(commanded):
                return commanded
            # the start's cone clipped the last goal: ramp to the rest goal of the last
            # joints (led without that start, two samples at rest after them: the central
            # differences there see rest on both sides) over as many samples as it takes
            rest = self._led(np.vstack([self.joints, self.joints[-1:], self.joints[-1:]]),
                             None)
            assert rest is not None
            more = max(2, self._ramp_samples(rest[-1], start) - len(commanded))
            self.joints = np.vstack([self.joints, np.repeat(self.joints[-1:], more, 0)])
            self.sigma = np.concatenate([self.sigma, np.repeat(self.sigma[-1:], more)])
            commanded = self._led(self.joints, start)
            assert commanded is not None
        if self._ramp_samples(commanded[-1], start) > len(commanded):
            free = self._led(self.joints, None)
            if free is not None and not np.array_equal(free[-1], commanded[-1]):
                return free
        return commanded

    def _ramp_samples(self, last: NDArray[np.int64], start: NDArray[np.int64]) -> int:
        """Samples a ramp from goal ``start`` to ``last`` needs at δ per sample (with half a
        tick of rounding spare)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            n = np.where(np.isfinite(self.step) & (self.step > 0),
                         np.ceil((np.abs(last - start) + 0.5) / self.step), 0.0)
        return int(n.max()) if n.size else 0

    def sent_goal(self, i: int) -> NDArray[np.int64]:
        """The goal ticks (k,) sample i sends (the lead's; the plan's ticks without one)."""
        node, j = self._node(i)
        return node.commanded[j]

    @classmethod
    def of_trajectory(cls, trajectory: Trajectory, bus: ServoBus,
                      encoded: list | None = None, lead: Lead | None = None,
                      commanded: NDArray[np.int64] | None = None,
                      step: ArrayLike | None = None) -> OnlineSamples:
        """The root of a chain: the planned samples (``encoded``, ``commanded``: as the
        streamer encoded and sent them; ``lead``: how a tail's goals are compensated, None
        to send the joints; ``step``: the joints' goal step limit δ, ticks)."""
        path, sigma = JointPath.of_samples(trajectory.joints)
        if commanded is None and lead is None:
            commanded = trajectory.ticks
        return cls(None, 0, trajectory.joints, sigma, path, bus, trajectory.rate_hz,
                   trajectory.joint_names, ticks=trajectory.ticks, encoded=encoded, lead=lead,
                   commanded=commanded, step=step)

    @classmethod
    def of_planned(cls, planned: PlannedSamples, bus: ServoBus) -> OnlineSamples:
        """The root of a chain over the streamer's planned samples, encoded and led as they
        are (:class:`~robodcn.stream.source.PlannedSamples`)."""
        lead = planned.commanded_for if planned.compensated else None
        step = max_steps(planned.arm, bus.servos, planned.period, len(bus.servos))
        return cls.of_trajectory(planned.trajectory, bus, encoded=planned.encoded_rows,
                                 lead=lead, commanded=planned.commanded, step=step)

    def held(self, hold: int) -> OnlineSamples:
        """This source with ``hold`` repeats of its last goal (shares every array)."""
        return OnlineSamples(self.prev, self.switch, self.joints, self.sigma, self.path,
                             self.bus, self.rate_hz, self.joint_names, ticks=self.ticks,
                             encoded=self._encoded, hold=hold, lead=self.lead,
                             commanded=self.commanded, step=self.step)

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
