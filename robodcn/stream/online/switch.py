"""Placing an online operation: plan a new tail from a switch sample ahead of the loop and
swap it in before the loop gets there, so no sample is left out or sent twice.

The switch is placed the expected planning time (:class:`PlanningTimes`) ahead of the later
of the last sample sent and the sample due now; when the loop got there first (planning or
the loop's catching up took longer), it is planned again :data:`SWITCH_MARGIN` × what that
attempt measured further ahead, up to :data:`SWITCH_TRIES` times (the loop never reads a
sample that changes under it). While a retarget plans, an :class:`EndKeeper` holds the
present move's end, so a retarget later than the move has left leaves from its end.

An operation given a ``budget`` (s) starts no attempt that would end after it (the last one
measured as its cost): a miss then is :class:`SwitchMissed`, nothing changed, rather than
an answer that waits for attempt after attempt (a service's answers come within a second).
Each kind of operation is measured apart (``measure``: a retarget to a numeric duration
fits its law in several rounds, so it takes a few times as long as one as fast as the
limits allow; from the others' times its switch would be placed too close, and planned again).
"""

from __future__ import annotations

import contextlib
import logging
import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from robodcn.bus import ServoBus
from robodcn.errors import InputError
from robodcn.stream.online.planning_times import PlanningTimes
from robodcn.stream.online.samples import OnlineSamples, Segment
from robodcn.stream.online.state import State
from robodcn.stream.online.timing import Timing

log = logging.getLogger("robodcn.stream")

#: attempts of an online operation before "the stream ran ahead of planning"; after a miss
#: the switch is placed this many times further ahead than the miss measured
SWITCH_TRIES = 8
SWITCH_MARGIN = 1.5
#: rest a retarget's end keeper keeps ahead of the loop while the retarget plans (s)
KEEP_AHEAD_S = 0.1

#: (request time on the stream's clock, first changed sample, its due time, planning
#: seconds of the request, the planning time the switch was placed for)
Switch = tuple[float, int, float, float, float]


class SwitchMissed(InputError):
    """No attempt of an operation landed before the loop (or the move ended first): nothing
    changed. ``what`` is the operation, ``value`` the execution's status."""

    def __init__(self, what: str, status: str,
                 why: str = "the stream ran ahead of planning") -> None:
        super().__init__(f"cannot {what}: {why}", field="execution", value=status)
        self.what = what


class Switcher:
    """The switches of one running stream (``stream``: :class:`~robodcn.stream.loop.Stream`)."""

    def __init__(self, stream: Any, bus: ServoBus, timing: Timing,
                 planning_times: PlanningTimes, done: threading.Event,
                 lock: threading.RLock) -> None:
        self.stream = stream
        self.bus = bus
        self.timing = timing
        self.planning_times = planning_times
        self.done = done
        self.lock = lock
        #: the swaps of a retarget's end keeper and the retarget's own (never interleaved)
        self.swap_lock = threading.Lock()
        self.switches: list[Switch] = []

    @property
    def sample(self) -> int:
        """Index of the last sample sent (−1 before the first)."""
        return self.stream.records.last_index()

    def state(self, index: int) -> State:
        return State.of_source(self.stream.source, index)

    def apply(self, what: str, tail: Callable[[State], list[Segment]], *, requested: float,
              hold: int = 0, speed: float = 1.0, status: str = "running",
              measure: str | None = None, budget: float | None = None,
              asked: float | None = None) -> int:
        """Plan ``tail`` from the state at a switch sample ahead of the loop and swap it in.

        ``tail`` returns the new samples as segments (joints, σ, path), each on one path;
        the last one is followed by ``hold`` repeats of its last goal. Returns the first
        changed sample. ``measure``: the name its planning times are kept under
        (:class:`PlanningTimes`; default ``what``); ``budget``: seconds from ``asked``
        (``time.perf_counter`` when the operation was asked; default now) within which the
        execution's lock must be had and an attempt be expected to end to be started
        (None: no bound).

        Raises
        ------
        SwitchMissed
            the stream ran ahead of planning every time (or the budget left no time for
            another attempt); nothing changed."""
        stream, jerk = self.stream, self.timing.jerk
        measure = measure or what
        started = time.perf_counter() if asked is None else asked
        wait = -1.0 if budget is None else max(0.0, budget - (time.perf_counter() - started))
        if not self.lock.acquire(timeout=wait):
            raise SwitchMissed(what, status, "another operation was being planned")
        keeper = EndKeeper(self) if what == "retarget" else None
        with contextlib.ExitStack() as held:
            held.callback(self.lock.release)
            held.enter_context(keeper or contextlib.nullcontext())
            log.debug("%s: waited %.1f ms for the execution's lock", what,
                      (time.perf_counter() - started) * 1000)
            ahead = self.planning_times.expected(measure, jerk)
            took = 0.0
            for _ in range(SWITCH_TRIES):
                if budget is not None and time.perf_counter() - started + took > budget:
                    log.info("%s: no time left for another attempt within %.0f ms", what,
                             budget * 1000)
                    raise SwitchMissed(what, status, f"planning took over {budget:g} s "
                                       "(a loaded host, or other operations before it)")
                rate = stream.source.rate_hz
                bound = stream.n
                # The loop may lag its clock on a loaded host and then catch up (or skip):
                # count from the later of the last sample sent and the one due now.
                last = max(self.sample, stream.due_now() - 1)
                if what == "retarget" and bound - last < math.ceil(ahead * rate) + 4:
                    # the move ends before planning could: keep its end (at rest) a while
                    # longer, so the new move leaves from there instead of being refused
                    src0: OnlineSamples = stream.source
                    stream.swap(src0.held(src0.hold + math.ceil(2 * ahead * rate) + 8))
                    bound = stream.n
                # state at switch, new samples from switch + 1: as far ahead as planning takes
                switch = last + 1 + math.ceil(ahead * rate)
                # the loop must still be running when it gets to the switch
                capped = switch >= bound - 2
                switch = min(switch, bound - 2)
                t_plan = time.perf_counter()
                state = self.state(max(switch, 0))
                segments = [seg for seg in tail(state) if len(seg[0])]
                if not segments:  # nothing to add: the switch state is where it ends
                    segments = [(state.q[None], np.array([state.sigma]), state.path)]
                first = switch + 1
                node = self._chain(stream.source, first, segments, hold)
                took = time.perf_counter() - t_plan
                running = stream.running and not self.done.is_set()
                if running and self.sample + 2 < first and self.sample + 2 < stream.n:
                    with self.swap_lock:
                        if keeper is not None:
                            keeper.stopped = True
                        stream.swap(node)
                    for _joints, sigma, path in segments:  # a new path's own law
                        self.timing.register_law(path, sigma, speed)
                    due = stream.t_start + first * stream.period
                    self.switches.append((requested, first, due,
                                          time.perf_counter() - started, ahead))
                    self.planning_times.record(measure, jerk, took)
                    log.info("%s: switch at sample %d (planned in %.2f ms, %.1f ms ahead, "
                             "%.1f ms since asked)", what, first, took * 1000, ahead * 1000,
                             (time.perf_counter() - started) * 1000)
                    return first
                if capped or not running:
                    break  # the move ends before any switch planning could reach
                # Missed: the stream ran on by more than planning was given. Next time give
                # it what this attempt measured (the planning and the loop's advance during
                # it, which includes a lagging loop catching up), with a margin.
                ran = (self.sample - last + 2) / rate
                ahead = SWITCH_MARGIN * max(ahead, took, ran)
                log.info("%s: the stream ran ahead of planning (%.1f ms), again %.1f ms ahead",
                         what, took * 1000, ahead * 1000)
        raise SwitchMissed(what, status)

    def _chain(self, src: OnlineSamples, first: int, segments: list[Segment],
               hold: int) -> OnlineSamples:
        node = src
        for n, (joints, sigma, path) in enumerate(segments):
            last = n == len(segments) - 1
            # the last segment ends at rest (a brake, a re-timed path's end, a retarget's
            # goal): a lead too short to ramp there within the step limit is given samples
            # at rest (OnlineSamples, settle)
            node = OnlineSamples(node, first if n == 0 else node.end, joints, sigma, path,
                                 self.bus, src.rate_hz, src.joint_names,
                                 hold=hold if last else 0, settle=last)
        return node


class EndKeeper:
    """While a retarget plans, the present move's end (at rest) is held on: the source is
    extended by repeats of its last goal whenever less than :data:`KEEP_AHEAD_S` of it is
    left, so a retarget that takes longer than the move has left leaves from its end
    instead of finding the stream finished."""

    def __init__(self, switcher: Switcher) -> None:
        self.switcher = switcher
        self.stopped = False
        self._wake = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="robodcn-keep")

    def __enter__(self) -> EndKeeper:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        with self.switcher.swap_lock:
            self.stopped = True
        self._wake.set()  # not a sleep's worth later: the operation's answer waits for it
        self._thread.join()

    def _run(self) -> None:
        sw = self.switcher
        stream = sw.stream
        while True:
            with sw.swap_lock:
                if self.stopped or sw.done.is_set() or not stream.running:
                    return
                src: OnlineSamples = stream.source
                rate = src.rate_hz
                if len(src) - sw.sample < KEEP_AHEAD_S * rate:
                    stream.swap(src.held(src.hold + math.ceil(2 * KEEP_AHEAD_S * rate)))
            self._wake.wait(KEEP_AHEAD_S / 10)


__all__ = ["KEEP_AHEAD_S", "SWITCH_MARGIN", "SWITCH_TRIES", "EndKeeper", "Switch",
           "SwitchMissed", "Switcher"]
