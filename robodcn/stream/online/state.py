"""The commanded state at a switch sample: where an online operation starts from."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn.stream.online_path import JointPath


@dataclasses.dataclass(frozen=True)
class State:
    """The commanded state at sample ``index``: joints q, q̇, q̈ (finite differences of the
    commanded joints), the path it is on, its σ and σ̇ = ‖q̇‖ (arc-length speed)."""

    index: int
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]
    path: JointPath
    sigma: float
    sd: float
    #: σ̈: the commanded acceleration along the direction of motion
    sdd: float = 0.0
    #: the commanded joints (3, k) of samples index − 2 … index (jerk checks across a switch)
    history: NDArray[np.float64] | None = None

    @classmethod
    def of_history(cls, index: int, history: NDArray[np.float64], path: JointPath,
                   sigma: float, rate_hz: float) -> State:
        """The state at the last of three commanded samples (3, k): q̇ and q̈ their backward
        differences at the stream rate, σ̇ = ‖q̇‖, σ̈ = q̈·q̇/σ̇ (along the motion)."""
        q2, q1, q0 = history
        qd = (q0 - q1) * rate_hz
        qdd = (q0 - 2.0 * q1 + q2) * rate_hz * rate_hz
        sd = float(np.linalg.norm(qd))
        sdd = float(qdd @ qd) / sd if sd > 1e-12 else 0.0
        return cls(index, q0, qd, qdd, path, sigma, sd, sdd, np.asarray(history))

    @classmethod
    def of_source(cls, source: Any, index: int) -> State:
        """The state at sample ``index`` of an online source (its commanded joints)."""
        q0 = source.joint(index)
        q1 = source.joint(index - 1) if index > 0 else q0
        q2 = source.joint(index - 2) if index > 1 else q1
        path, sigma = source.path_at(index)
        return cls.of_history(index, np.vstack([q2, q1, q0]), path, sigma, source.rate_hz)


__all__ = ["State"]
