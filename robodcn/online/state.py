"""What the online motion generator reads and returns: its input, its output, an infeasible
result.

Shaped as Ruckig's ``InputParameter`` / ``OutputParameter`` (Berscheid & Kröger, "Jerk-limited
Real-time Trajectory Generation with Arbitrary Target States", RSS 2021): an operation on a
running motion is simply a new :class:`Input` — a joint target (with a velocity to arrive
with), a speed scale, a stop — and every period the generator answers one :class:`Sample`
of the commanded state. A law that cannot be met is an :class:`Infeasible` value, not an
exception: the caller chooses what to do next with an ``if``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

#: what an :class:`Input` asks of the motion
MODES = ("target", "stop")


@dataclass(frozen=True)
class Input:
    """One input of the generator (all arrays (k,), rad, rad/s; bus order).

    target : the joint target q* (mode "target"); ignored by a stop.
    velocity : the velocity q̇* to pass q* with (None: arrive at rest). Clamped per joint to
        the scaled velocity limit and to what the joint can still brake to rest from before
        its position limit (√(2·a·distance)).
    acceleration : the acceleration q̈* to pass q* with (None: zero). Clamped per joint to the
        scaled acceleration limit; zero where q̇* and q̈* together would need more than the
        velocity limit to settle (|q̇*| + q̈*²/(2·j) > v: Ruckig's bound on a target state).
    scale : speed scale k ∈ (0, 1]: the limits v·k, a·k², j·k³ (as
        :meth:`robodcn.path_timing.JointLimits.scaled`).
    mode : "target" (head for q*) or "stop" (brake to rest wherever that is, the shortest
        way the limits allow: a pause, a smooth stop).
    duration : reach the target state no sooner than this many seconds after the input is
        taken (Ruckig's minimum duration: a stream's next target is expected then); None:
        as soon as the limits allow.
    """

    target: NDArray[np.float64] | None = None
    velocity: NDArray[np.float64] | None = None
    acceleration: NDArray[np.float64] | None = None
    scale: float = 1.0
    mode: str = "target"
    duration: float | None = None

    @classmethod
    def stop(cls, scale: float = 1.0) -> Input:
        """Brake to rest (a pause, a smooth stop)."""
        return cls(scale=scale, mode="stop")


@dataclass(frozen=True)
class Sample:
    """The commanded state one period on (arrays (k,)): q rad, q̇ rad/s, q̈ rad/s².

    reached : the motion is at the input's target state (or at rest after a stop).
    remaining_s : time left to it on the present law (0 when reached).
    share : the share of the kinematic limits the present law keeps (1: all of them; less
        where the torque limits needed it: :meth:`robodcn.online.Generator.check`).
    """

    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]
    reached: bool
    remaining_s: float
    share: float = 1.0


@dataclass(frozen=True)
class Infeasible:
    """Why an input cannot be met (a result value, never raised by the generator).

    reason : "torque" (no share of the limits keeps |τ| ≤ τ_max), "input" (Ruckig refused
        the input: a non-finite target, a limit of zero) or "calculation" (Ruckig found no
        law).
    message : one line saying what failed, in SI units.
    joint : the joint index concerned (None: not one joint's).
    value, limit : the offending quantity and its limit (SI), where there is one.
    """

    reason: str
    message: str
    joint: int | None = None
    value: float | None = None
    limit: float | None = None
    details: dict = field(default_factory=dict)


__all__ = ["MODES", "Infeasible", "Input", "Sample"]
