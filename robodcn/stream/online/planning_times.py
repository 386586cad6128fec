"""How long online operations take to plan: where the next switch is placed.

An operation's switch is placed its expected planning time ahead of the loop (then two
periods for the swap). The expectation is measured: a :class:`PlanningTimes` keeps the last
few planning times of each operation, per kind of arm (with jerk limits or not: their laws
take longer), and whoever creates executions may share one across them (a service: its
first retarget of each move is then placed from measurements, not from a guess).
"""

from __future__ import annotations

import threading

#: a retarget to a numeric duration, measured apart from one as fast as the limits allow
#: (fitting its law takes a few rounds: about 2–3 × as long)
RETARGET_TO_DURATION = "retarget to a duration"
#: first guesses (s) before anything was measured, per operation (others: DEFAULT_S)
FIRST_GUESS_S = {"retarget": 0.01, RETARGET_TO_DURATION: 0.03}
#: on a jerk-limited arm its laws take longer, and a first switch placed too close is
#: planned twice
JERK_FIRST_GUESS_S = {"retarget": 0.12, RETARGET_TO_DURATION: 0.3, "stop smoothly": 0.03,
                      "pause": 0.03, "resume": 0.1, "change speed": 0.15}
DEFAULT_S = 0.003
#: operations whose planning times spread widely on an arm without jerk limits too, placed
#: from the slowest kept: a retarget to a duration fits its law in rounds, and where the
#: moving start's stretch misses it is fitted again through rest (on the omx 30-340 ms
#: beside a stream; placed from the fastest it missed, was planned again, and a second
#: miss ran out of the operation's budget: 409 for a reachable request)
SPREAD = frozenset({RETARGET_TO_DURATION})
#: and with this much more than the slowest (a miss there costs a second planning, which the
#: operation's budget seldom has left)
SPREAD_MARGIN = 1.5
#: measurements kept per operation and kind of arm
KEEP = 5


class PlanningTimes:
    """Recent planning times of online operations (thread-safe; share it across executions).

    :meth:`expected` is optimistic on an arm without jerk limits (the fastest of the last
    few: a miss is planned again from further ahead) and the slowest of them with jerk
    limits and for the operations in :data:`SPREAD` (those laws take long and vary; with
    :data:`SPREAD_MARGIN` more). :attr:`warmed` says a retarget was planned with this
    estimator already (its first one pays the planner's and numpy's first calls)."""

    def __init__(self) -> None:
        self._seen: dict[tuple[str, bool], list[float]] = {}
        self._lock = threading.Lock()
        self.warmed = False

    def times(self, what: str, jerk: bool) -> list[float]:
        """The planning times kept for ``what``: the first guess, then the measurements
        (the guess drops out after :data:`KEEP` − 1 of them)."""
        with self._lock:
            return list(self._kept(what, jerk))

    def _kept(self, what: str, jerk: bool) -> list[float]:
        seen = self._seen.get((what, jerk))
        if seen:
            return seen
        return [(JERK_FIRST_GUESS_S if jerk else FIRST_GUESS_S).get(what, DEFAULT_S)]

    def expected(self, what: str, jerk: bool) -> float:
        """Seconds to place the switch of ``what`` ahead of the loop: the fastest kept, but
        the slowest with jerk limits or for a retarget to a duration (:data:`SPREAD`)."""
        if what in SPREAD:
            return SPREAD_MARGIN * max(self.times(what, jerk))
        return (max if jerk else min)(self.times(what, jerk))

    def record(self, what: str, jerk: bool, seconds: float) -> None:
        """One measured planning time of ``what``."""
        with self._lock:
            guesses = JERK_FIRST_GUESS_S if jerk else FIRST_GUESS_S
            kept = self._seen.get((what, jerk)) or ([guesses[what]] if what in guesses else [])
            self._seen[(what, jerk)] = [*kept[-(KEEP - 1):], float(seconds)]

    def seed(self, what: str, jerk: bool, seconds: float) -> None:
        """Before anything of ``what`` is measured: expect ``seconds`` (a warm-up's
        measurement, scaled to planning beside a stream), not less than the first guess."""
        with self._lock:
            if (what, jerk) not in self._seen:
                guess = (JERK_FIRST_GUESS_S if jerk else FIRST_GUESS_S).get(what, DEFAULT_S)
                self._seen[(what, jerk)] = [max(guess, float(seconds))]

    def set(self, what: str, jerk: bool, times: list[float]) -> None:
        """Replace what is kept for ``what`` (tests, a caller that knows better)."""
        with self._lock:
            self._seen[(what, jerk)] = [float(t) for t in times][-KEEP:]


__all__ = ["FIRST_GUESS_S", "JERK_FIRST_GUESS_S", "RETARGET_TO_DURATION", "SPREAD",
           "PlanningTimes"]
