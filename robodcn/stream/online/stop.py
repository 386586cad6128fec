"""Smooth stop and pause: the fastest brake along the present path to rest.

A smooth stop ends the stream on the brake's last goal (the arm holds it); a pause keeps
the stream alive, repeating the last goal (:class:`PauseKeeper` keeps
:data:`PAUSE_AHEAD_S` of rest ahead of the loop while paused). Where the present path ends
before a brake could stop (:class:`PathEnds`), the move's own end is the stop.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from robodcn.stream.online.samples import OnlineSamples, Segment
from robodcn.stream.online.state import State
from robodcn.stream.online.switch import Switcher
from robodcn.stream.online.timing import Timing, samples

#: samples of rest a paused stream keeps ahead of itself (extended while paused)
PAUSE_AHEAD_S = 1.0


class PathEnds(Exception):
    """The present path ends before a brake could stop: its end is the stop (nothing is
    swapped in). ``index``: the switch sample planned from."""

    def __init__(self, index: int) -> None:
        super().__init__(f"the move ends before a brake from sample {index} could stop it")
        self.index = index


def brake_to_rest(timing: Timing, state: State) -> list[Segment]:
    """The brake along the present path from ``state`` to rest (raises :class:`PathEnds`)."""
    sigma = timing.brake(state)
    if sigma is None:
        raise PathEnds(state.index)
    return samples(state.path, sigma)


def pause_hold(rate_hz: float) -> int:
    """Repeats of the last goal a pause starts with."""
    return max(1, int(PAUSE_AHEAD_S * rate_hz))


class PauseKeeper:
    """While ``paused()``, keep :data:`PAUSE_AHEAD_S` of rest ahead of the loop (a thread
    that extends the held end of the source)."""

    def __init__(self, switcher: Switcher, paused: Callable[[], bool],
                 done: threading.Event) -> None:
        self.switcher = switcher
        self.paused = paused
        self.done = done
        self.thread = threading.Thread(target=self._run, daemon=True, name="robodcn-pause")
        self.thread.start()

    def _run(self) -> None:
        sw = self.switcher
        while self.paused() and not self.done.is_set():
            with sw.lock:
                if not self.paused():
                    return
                src: OnlineSamples = sw.stream.source
                if len(src) - sw.sample < PAUSE_AHEAD_S * src.rate_hz / 2:
                    sw.stream.swap(src.held(src.hold + int(PAUSE_AHEAD_S * src.rate_hz)))
            self.done.wait(PAUSE_AHEAD_S / 4)


__all__ = ["PAUSE_AHEAD_S", "PathEnds", "PauseKeeper", "brake_to_rest", "pause_hold"]
