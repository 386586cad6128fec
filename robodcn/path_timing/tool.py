"""Tool-space limits along a path: the tool point's speed, orientation rate and acceleration
along its path, as constraints of the same TOPP-RA pass as the joint limits.

On a joint path q(s) the tool point p(q(s)) has p′ = J q′ and p″ = J q″ + J̇ q′
(:func:`robodcn.dynamics.tool_motion`, the forward pass with (q̇, q̈) = (q′, q″)). With σ the
tool's arc length, σ′ = |p′| and σ″ = p′·p″ / |p′|, so along a law s(t)::

    tool speed      σ̇ = σ′ ṡ                ≤ v_tool   (first order: ṡ² ≤ (v_tool / σ′)²)
    orientation     |w·q′| ṡ                ≤ ω_tool   (θ's rate; the omx's pitch and yaw)
    along the path  σ̈ = σ′ s̈ + σ″ ṡ²        ∈ [−a_tool, a_tool]  (a row like torque's)

The first two bound x = ṡ² at each grid point (the reachability sets' cap, like a joint's
velocity limit), the third is a linear row lo ≤ A u + B x ≤ hi of
:mod:`robodcn.path_timing.reachability` (u = s̈), as the torque rows are
(:mod:`robodcn.path_timing.torque`). UR's ``movel(pose, a, v)``, ABB's ``speeddata``
(v_tcp, v_ori) and MoveIt Pilz's ``LIN`` name the same quantities.

A speed scale k (the law s(k t)) multiplies σ̇ by k and σ̈ by k²: :meth:`ToolLimits.scaled`.
Where the tool point stands still (σ′ = 0: a pure turn of the tool about it) the speed
bounds nothing and σ″ is taken as 0 (σ̈ is then |p″| ṡ², bounded by the speed's neighbours).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from robodcn.config import Arm, rigid_chain
from robodcn.dynamics import RigidChain, tool_motion
from robodcn.path_timing.torque import TorqueRows

__all__ = ["ToolLimits", "orientation_rates"]

#: |p′| below which the tool point counts as standing still (m per unit of s)
STILL = 1e-12


def orientation_rates(arm: Arm) -> NDArray[np.float64]:
    """W (m, k): the tool's orientation rates are W q̇. A planar arm's θ = q₁ + … + q_k
    (one row of ones); an arm with a base yaw has its pitch (minus the chain joints' sum:
    ROBOTIS's clockwise angles) and its yaw (joint 0) — two rows."""
    k = arm.dof
    if not arm.yawed:
        return np.ones((1, k))
    w = np.zeros((2, k))
    w[0, 1:] = -1.0
    w[1, 0] = 1.0
    return w


@dataclass(frozen=True)
class ToolLimits:
    """The tool point's limits (inf: none) and the chain that moves it.

    chain : the arm's :class:`~robodcn.dynamics.RigidChain` (its tool point is the plan's)
    rates : (m, k) orientation-rate rows W (:func:`orientation_rates`)
    speed : m/s; angular_speed : rad/s (each of W q̇); acceleration : m/s², along the path

    Two are equal when their limits are (the chain and rates are the arm's).
    """

    chain: RigidChain = field(compare=False)
    rates: NDArray[np.float64] = field(compare=False)
    speed: float = math.inf
    angular_speed: float = math.inf
    acceleration: float = math.inf

    @classmethod
    def of(cls, arm: Arm, speed: float | None = None, angular_speed: float | None = None,
           acceleration: float | None = None) -> ToolLimits | None:
        """The limits of ``arm`` (None where not given; None when none is: nothing to keep)."""
        if speed is None and angular_speed is None and acceleration is None:
            return None

        def value(x: float | None) -> float:
            return math.inf if x is None else float(x)

        return cls(rigid_chain(arm), orientation_rates(arm), value(speed),
                   value(angular_speed), value(acceleration))

    def scaled(self, k: float) -> ToolLimits:
        """Speed scaling k: speeds × k, acceleration × k²."""
        return replace(self, speed=self.speed * k, angular_speed=self.angular_speed * k,
                       acceleration=self.acceleration * k * k)

    def shrunk(self, share: float) -> ToolLimits:
        """Every limit × ``share`` (a margin, not a speed scale)."""
        return replace(self, speed=self.speed * share,
                       angular_speed=self.angular_speed * share,
                       acceleration=self.acceleration * share)

    def path_terms(self, q: NDArray, dq: NDArray, ddq: NDArray
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(σ′, σ″) (n,) of the tool's arc length at the path samples q with q′, q″."""
        _, dp, ddp = tool_motion(self.chain, q, dq, ddq)
        ds = np.sqrt(np.einsum("ni,ni->n", dp, dp))
        moving = ds > STILL
        dds = np.where(moving, np.einsum("ni,ni->n", dp, ddp) / np.where(moving, ds, 1.0),
                       0.0)
        return ds, dds

    def cap(self, q: NDArray, dq: NDArray, scale: float = 1.0,
            ds: NDArray | None = None) -> NDArray[np.float64] | None:
        """The bound on x = ṡ² (n,) at the path samples from the speed and the orientation
        rate (module doc), or None when neither is set. ``ds``: σ′ when known."""
        out = None
        with np.errstate(divide="ignore"):
            if math.isfinite(self.speed):
                if ds is None:
                    ds = self.path_terms(q, dq, np.zeros_like(dq))[0]
                out = (self.speed * scale / ds) ** 2
            if math.isfinite(self.angular_speed):
                w = np.abs(dq @ self.rates.T).max(axis=1)
                turn = (self.angular_speed * scale / w) ** 2
                out = turn if out is None else np.minimum(out, turn)
        return out

    def rows(self, ds: NDArray, dds: NDArray, scale: float = 1.0) -> TorqueRows | None:
        """The along-path acceleration row (A, B, lo, hi), each (n, 1): −a ≤ σ′ u + σ″ x ≤ a
        (× k² under a speed scale k), or None without an acceleration limit."""
        if not math.isfinite(self.acceleration):
            return None
        bound = np.full((ds.shape[0], 1), self.acceleration * scale * scale)
        return ds[:, None].copy(), dds[:, None].copy(), -bound, bound

    def constraints(self, q: NDArray, dq: NDArray, ddq: NDArray, scale: float = 1.0
                    ) -> tuple[NDArray[np.float64] | None, TorqueRows | None]:
        """(x cap, acceleration row) at the path samples (:meth:`cap`, :meth:`rows`)."""
        ds = dds = None
        if math.isfinite(self.speed) or math.isfinite(self.acceleration):
            ds, dds = self.path_terms(q, dq, ddq)
        cap = self.cap(q, dq, scale, ds)
        rows = None if ds is None or dds is None else self.rows(ds, dds, scale)
        return cap, rows
