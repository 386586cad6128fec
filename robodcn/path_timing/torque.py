"""Joint torque limits along a path: the linear constraints TOPP-RA takes beside v and a.

On a path q(s) the inverse dynamics is linear in (s̈, ṡ²) (Pham & Pham, "A New Approach to
Time-Optimal Path Parameterization Based on Reachability Analysis", IEEE T-RO 34(3), 2018,
§III; :func:`robodcn.dynamics.path_torque_coefficients`)::

    τ(s) = a(s)·s̈ + b(s)·ṡ² + c(s)

with links, the payload at the tool point, gravity and each servo's reflected rotor inertia
(armature) in a, b and c. |τ_j| ≤ τ_max,j is the row −τ_max − c ≤ a·s̈ + b·ṡ² ≤ τ_max − c of
the reachability analysis (:mod:`robodcn.path_timing.reachability`), like the acceleration
row −a_max ≤ q′·s̈ + q″·ṡ² ≤ a_max.

A speed scale k (the law s(k t)) multiplies a·s̈ + b·ṡ² by k² and leaves c: the scaled law
keeps k²·(±τ_max − c). A stage where gravity alone needs more than τ_max (|c| > τ_max·(1 +
:data:`SLACK`): the arm cannot hold itself there) gets no torque row: the law is timed
without it and the planner's validation names the sample and joint (TorqueLimitError); the
planner refuses such a path before timing it (:meth:`TorqueLimits.overloaded` on its dense
samples, :mod:`robodcn.planner.holding`), since near it the law crawls. Within the slack
gravity counts as at the limit (c clipped to ±τ_max), so the timing, the precheck and the
validation (``planner.validate``: |τ| ≤ τ_max·(1 + SLACK)) draw one line.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from robodcn.config import Arm, rigid_chain
from robodcn.dynamics import (
    RigidChain,
    gravity_torque,
    inverse_dynamics,
    path_torque_coefficients,
)

__all__ = ["SLACK", "TorqueLimits", "TorqueRows"]

#: Relative tolerance of every torque comparison (float rounding only): the rows below,
#: the planner's holding precheck and its validation (planner.validate.LIMIT_SLACK).
SLACK = 1e-9

#: paths whose coefficients (a, b, c) a TorqueLimits and its shrunk copies keep (a re-timing
#: tries several shares of the limits on one path, a duration fit several speeds)
KEEP_PATHS = 4

#: (A, B, lo, hi), each (N, k): lo ≤ A·s̈ + B·ṡ² ≤ hi per stage and joint
TorqueRows = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                   NDArray[np.float64]]


@dataclass(frozen=True)
class TorqueLimits:
    """Per-joint torque limits ``tau`` (k,) N·m (inf: none) of the rigid ``chain`` carrying
    ``payload_kg`` at the tool point."""

    chain: RigidChain
    tau: NDArray[np.float64]
    payload_kg: float = 0.0
    #: (a, b, c) of the last few paths, shared with the :meth:`shrunk` copies (the
    #: coefficients do not depend on τ_max); lives as long as these limits do
    _kept: dict = field(default_factory=dict, repr=False, compare=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False, compare=False)

    @classmethod
    def of(cls, arm: Arm, payload_kg: float | None = None) -> TorqueLimits | None:
        """The arm's ``max_torque_nm`` limits (None when no joint sets one); the payload
        defaults to the arm's ``[dynamics] payload_kg``."""
        raw = arm.max_torques
        if all(t is None for t in raw):
            return None
        tau = np.array([math.inf if t is None else float(t) for t in raw], dtype=np.float64)
        load = arm.payload_kg if payload_kg is None else float(payload_kg)
        return cls(rigid_chain(arm), tau, load)

    def shrunk(self, share: float) -> TorqueLimits:
        """Every torque limit times ``share`` (a margin)."""
        return replace(self, tau=self.tau * share)

    def rows(self, q: NDArray, dq: NDArray, ddq: NDArray, scale: float = 1.0) -> TorqueRows:
        """The rows (A, B, lo, hi) at the path samples q with q′, q″ (module doc); a joint
        without a limit, or one gravity alone overloads there, gets lo = −inf, hi = inf."""
        a, b, c = self.coefficients(q, dq, ddq)
        k2 = scale * scale
        tau = self.tau[None, :]
        off = ~np.isfinite(tau) | self.overloaded(c)
        c = np.clip(c, -tau, tau)  # within SLACK of the limit: at it (module doc)
        lo, hi = k2 * (-tau - c), k2 * (tau - c)
        if off.any():
            off = np.broadcast_to(off, c.shape)
            a, b = np.where(off, 0.0, a), np.where(off, 0.0, b)
            lo, hi = np.where(off, -np.inf, lo), np.where(off, np.inf, hi)
        return a, b, lo, hi

    def coefficients(self, q: NDArray, dq: NDArray, ddq: NDArray
                     ) -> tuple[NDArray, NDArray, NDArray]:
        """(a, b, c) (N, k) of :func:`robodcn.dynamics.path_torque_coefficients` at the path
        samples, kept for the last :data:`KEEP_PATHS` paths (keyed by their bytes: the same
        bits give the same coefficients; read-only arrays)."""
        key = (q.shape, q.tobytes(), dq.tobytes(), ddq.tobytes())
        with self._lock:
            got = self._kept.get(key)
        if got is None:
            got = path_torque_coefficients(self.chain, q, dq, ddq, self.payload_kg)
            for arr in got:
                arr.setflags(write=False)
            with self._lock:
                if len(self._kept) >= KEEP_PATHS:
                    del self._kept[next(iter(self._kept))]  # the oldest
                self._kept[key] = got
        return got

    def gravity(self, q: NDArray) -> NDArray[np.float64]:
        """τ_g (n, k): the torque that holds the arm still at q (n, k) with the payload
        (inverse dynamics at q̇ = q̈ = 0: links, payload and gravity; the static holding
        torque, :func:`robodcn.dynamics.gravity_torque`)."""
        return gravity_torque(self.chain, q, self.payload_kg)

    def overloaded(self, g: NDArray) -> NDArray[np.bool_]:
        """Where holding torques g (n, k) pass the limits: |g| > τ_max·(1 + SLACK)."""
        return np.abs(g) > self.tau * (1.0 + SLACK)

    def torques(self, q: NDArray, qd: NDArray, qdd: NDArray) -> NDArray[np.float64]:
        """τ (n, k) of the motion (q, q̇, q̈) (robodcn.dynamics.inverse_dynamics)."""
        return inverse_dynamics(self.chain, q, qd, qdd, self.payload_kg)
