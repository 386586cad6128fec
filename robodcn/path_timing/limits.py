"""Per-joint dynamic limits of an arm: velocity, acceleration, (optional) jerk and torque.

The one derivation of the limits from an :class:`~robodcn.config.Arm` (its joints'
``max_velocity``, ``max_acceleration``, ``max_jerk`` and ``max_torque_nm``, the latter with
the arm's rigid-body model and a payload: :class:`~robodcn.path_timing.torque.TorqueLimits`):
the planner, the path timing, the validation and the online operations all read a
:class:`JointLimits`.

A speed scale k maps a law q(s(t)) onto q(s(k t)): joint velocity scales by k, acceleration
by k² and jerk by k³ (:meth:`JointLimits.scaled`; the tool's speed by k and its
acceleration by k²; torque is physical and stays: the path
timing applies the scale to its dynamic part, :mod:`robodcn.path_timing.torque`); a margin
scales every limit alike (:meth:`JointLimits.shrunk`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodcn.config import Arm
from robodcn.path_timing.tool import ToolLimits
from robodcn.path_timing.torque import TorqueLimits

__all__ = ["JointLimits"]


@dataclass(frozen=True)
class JointLimits:
    """Per-joint limits, arrays of shape (n_joints,).

    v : velocity (rad/s); a : acceleration (rad/s²); j : jerk (rad/s³), ``inf`` for a joint
    without one, or None when no joint sets a jerk limit; torque : the torque limits with
    the arm's dynamics and payload, None when no joint sets ``max_torque_nm``; tool : the
    tool point's speed, orientation rate and acceleration along the path (a request's
    ``tool_*`` fields: :mod:`robodcn.path_timing.tool`), None when none is set.
    """

    v: NDArray[np.float64]
    a: NDArray[np.float64]
    j: NDArray[np.float64] | None = None
    torque: TorqueLimits | None = None
    tool: ToolLimits | None = None

    @classmethod
    def of(cls, arm: Arm, payload_kg: float | None = None, *, torque: bool = True
           ) -> JointLimits:
        """The arm's joint limits (``j`` None when no joint sets ``max_jerk``, ``torque``
        None when none sets ``max_torque_nm`` or ``torque=False``: the kinematic limits
        only, without building the arm's rigid-body model; ``payload_kg`` None: the
        arm's)."""
        jerk = [jt.max_jerk for jt in arm.joints]
        return cls(np.array([jt.max_velocity for jt in arm.joints], dtype=np.float64),
                   np.array([jt.max_acceleration for jt in arm.joints], dtype=np.float64),
                   None if all(x is None for x in jerk)
                   else np.array([math.inf if x is None else x for x in jerk],
                                 dtype=np.float64),
                   TorqueLimits.of(arm, payload_kg) if torque else None)

    @property
    def jerk_limited(self) -> bool:
        """Whether any joint sets a jerk limit."""
        return self.j is not None

    @property
    def jerk(self) -> NDArray[np.float64]:
        """The jerk limits with ``inf`` for every joint without one (also when none has)."""
        return np.full_like(self.v, math.inf) if self.j is None else self.j

    def scaled(self, k: float) -> JointLimits:
        """Speed scaling k: v·k, a·k², j·k³."""
        return JointLimits(self.v * k, self.a * (k * k),
                           None if self.j is None else self.j * k ** 3, self.torque,
                           None if self.tool is None else self.tool.scaled(k))

    def shrunk(self, share: float) -> JointLimits:
        """Every limit times ``share`` (a margin, not a speed scale)."""
        return JointLimits(self.v * share, self.a * share,
                           None if self.j is None else self.j * share,
                           None if self.torque is None else self.torque.shrunk(share),
                           None if self.tool is None else self.tool.shrunk(share))
