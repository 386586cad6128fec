"""Speed scaling and resume: the rest of the present path re-timed under the limits scaled
by k (v·k, a·k², j·k³, as ros2_controllers' joint_trajectory_controller speed_scaling),
after a brake along the path if the present speed is over what they allow, and never
faster than k × the path's own first law (:meth:`Timing.retimed`).

Where no law under the scaled limits joins the present state, or nothing of the path is
left to re-time, the samples planned stand: :class:`KeepPlanned` (its ``reason``).
"""

from __future__ import annotations

from robodcn.stream.online.samples import Segment
from robodcn.stream.online.state import State
from robodcn.stream.online.timing import NoLaw, Timing, samples
from robodcn.stream.online_path import LawExceedsLimits, check_limits_named


class KeepPlanned(Exception):
    """No new law from this state: the samples planned stand (``reason`` says why)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def speed_scale(value: float) -> float:
    """A speed scale k ∈ (0, 1] (InputError naming ``scale`` otherwise)."""
    return check_limits_named("scale", value)


def _retimed(timing: Timing, state: State, k: float,
             keep: tuple[type[Exception], ...]) -> list[Segment]:
    try:
        sigma = timing.retimed(state, k)
    except keep as exc:
        raise KeepPlanned(str(exc)) from exc
    if sigma is None:
        raise KeepPlanned("nothing of the path is left to re-time")
    return samples(state.path, sigma)


def speed_tail(timing: Timing, state: State, k: float) -> list[Segment]:
    """The rest of the path at speed scale k; :class:`KeepPlanned` near the end, where the
    move already brakes to rest at the full limits (a slower law from here would overrun
    the path) or no law keeps every limit from this state."""
    return _retimed(timing, state, k, (NoLaw, LawExceedsLimits))


def resume_tail(timing: Timing, state: State, k: float) -> list[Segment]:
    """The rest of the path from where a pause left it, at speed scale k;
    :class:`KeepPlanned` when no law from there joins it (the held end stands)."""
    return _retimed(timing, state, k, (NoLaw,))


__all__ = ["KeepPlanned", "resume_tail", "speed_scale", "speed_tail"]
