"""The last line of the goal-step bound (issue 17 §7): no written goal steps further than the
joint's velocity limit allows.

Every goal the loop writes is within δ_j + 1 ticks of the one written before it, per joint
j, where δ_j = v_max,j·T is the joint's largest step in one stream period T
(:func:`robodcn.stream.compensation.max_steps`) and the one tick is rounding: planned ticks
keep it by construction (|round(a) − round(b)| ≤ |a − b| + 1). A source whose goals step
further is slewed: the goal written is the last one moved toward the source's by the
allowed step, and the next writes close the rest (the servo could not have followed the
step anyway; a P loop takes it at full PWM, which a collision check may take for a
collision). Such steps come from samples the loop skipped after a stall: the write after
a skip is one write after the last on the wire (often a millisecond later, the stall having
delayed that one), so it keeps the one-period bound too, and the motion catches up with the
plan where the plan runs below the limit. (Online tails keep the bound themselves: a tail's
lead ramps from the goal sent before its switch, and an operation's last segment too short
for that ramp is lengthened at rest, :mod:`robodcn.stream.online.samples`; only a middle
segment too short for it is led without that start and slewed here.) The
first write is limited from the goal the servos held before the stream, where the source
read it (:attr:`~robodcn.stream.source.PlannedSamples.start_goal`).

While slewed, the written goals lag the source's: the tracking check widens the step it
measures the servos against by that lag (:meth:`StepGuard.lag`; the lag is the loop's
choice, not the servos' failure to follow). When the source's samples end with the written
goal still short of its last goal, the loop goes on writing slewed samples on its schedule
until it is there (:meth:`StepGuard.behind`): a move ends on its own last goal.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from robodcn.bus import decode_row, encode_row

#: Ticks of rounding a planned goal may add to a step (module notes).
ROUNDING_TICKS = 1


class StepGuard:
    """The goals one stream wrote and the bound on the next (module notes).

    Parameters
    ----------
    step : δ_j (k,), ticks per period per joint (inf: no bound for that joint).
    start : the goal (k,) the servos hold before the first write, or None (the first write
        is not bounded).
    """

    def __init__(self, step: ArrayLike, start: ArrayLike | None = None) -> None:
        self.step = [float(s) for s in np.asarray(step, dtype=np.float64)]
        self.on = any(math.isfinite(s) for s in self.step)
        #: the largest step written per joint, ticks (None: unbounded)
        self.allowed = [math.floor(s) + ROUNDING_TICKS if math.isfinite(s) else None
                        for s in self.step]
        #: the goal last written (ticks) and the sample index it was written for
        self.written: list[int] | None = None if start is None else [int(v) for v in start]
        self.at = -1
        #: the source's goal the last write was short of (None: the write was the source's)
        self.target: list[int] | None = None
        #: writes that were slewed
        self.slewed = 0

    def row(self, i: int, row: Sequence[Sequence[int]]) -> Sequence[Sequence[int]]:
        """The row to write for sample ``i`` whose source row is ``row``: ``row`` itself,
        or the last written goal moved toward it by the allowed step."""
        if not self.on:
            return row
        goals = decode_row(row)
        last = self.written
        if last is None:
            self._wrote(i, goals, None)
            return row
        out, slewed = [], False
        for g, w, allowed in zip(goals, last, self.allowed, strict=True):
            if allowed is not None and abs(g - w) > allowed:
                g = w + allowed if g > w else w - allowed
                slewed = True
            out.append(g)
        if not slewed:
            self._wrote(i, goals, None)
            return row
        self.slewed += 1
        self._wrote(i, out, goals)
        return encode_row(out)

    def _wrote(self, i: int, goals: list[int], target: list[int] | None) -> None:
        self.written, self.at, self.target = goals, i, target

    def behind(self) -> bool:
        """True while the last write was short of its source's goal."""
        return self.target is not None

    def lag(self) -> list[int] | None:
        """The source's goal minus the goal written, ticks per joint, while the last write
        was short of it (None otherwise): the lag the loop chose, which its tracking check
        does not count against the servos (:mod:`robodcn.stream.loop`)."""
        if self.target is None or self.written is None:
            return None
        return [t - w for t, w in zip(self.target, self.written, strict=True)]

    def catch_up(self, i: int) -> Sequence[Sequence[int]]:
        """The row for a sample ``i`` past the source's end: the last written goal moved
        toward the goal it was short of."""
        assert self.target is not None
        return self.row(i, encode_row(self.target))


__all__ = ["ROUNDING_TICKS", "StepGuard"]
