"""The motion a stream of targets describes: where, how fast and how accelerating it is at
its newest target.

The polynomial p through the stream's last (up to) four targets — the cubic Lagrange
interpolant (e.g. Burden & Faires, *Numerical Analysis*, §3.1), the targets taken as evenly
spaced by the stream's mean gap h — gives the target state at the newest one: (q_k, ṗ(t_k),
p̈(t_k)). A follow session asks the online generator to reach that state one gap after q_k
arrived, when the next is due, so the arm runs one target period behind a steady stream
and passes every target at the stream's own speed instead of stopping at it. The
interpolant's derivatives at its end are accurate to O(h³) and O(h²) (consecutive targets'
states agree): a backward difference's velocity is half a gap old and its acceleration a
whole gap old, which a jerk-limited law cannot follow from one target to the next. A
target given with its velocity is a Hermite end condition instead (the given tangents are
exact). Two targets give the straight line (no acceleration); one, no reference.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class Segment:
    """The stream's motion up to its newest target, which arrived at ``start`` after a gap
    ``h``: the polynomial ``coeffs`` (d + 1, k) in u = (τ − t_k)/h, played one gap late
    (τ = t − h: :meth:`at` ``(start + h)`` is the state at the newest target)."""

    start: float
    h: float
    coeffs: NDArray[np.float64]
    #: the reference's velocity at the newest target (k,) rad/s (the next segment's start)
    m1: NDArray[np.float64]

    @classmethod
    def through(cls, times: NDArray[np.float64], joints: NDArray[np.float64],
                velocities: list[NDArray[np.float64] | None]) -> Segment:
        """The segment of the targets ``joints`` (m, k) that arrived at ``times`` (m,),
        oldest first, m ≥ 2: Hermite between the last two where both were given a velocity,
        else the Lagrange interpolant of them all."""
        tk = float(times[-1])
        h = float(times[-1] - times[-2])
        v0, v1 = velocities[-2], velocities[-1]
        if v0 is not None and v1 is not None:
            # cubic Hermite in u ∈ [−1, 0]: p(−1) = q0, p(0) = q1, p'(−1) = h·v0, p'(0) = h·v1
            q0, q1, d0, d1 = joints[-2], joints[-1], h * v0, h * v1
            a = d0 + d1 + 2 * (q0 - q1)
            b = 3 * (q0 - q1) + d0 + 2 * d1
            coeffs = np.array([q1, d1, b, a])
            return cls(tk, h, coeffs, np.asarray(v1, dtype=np.float64))
        u = (np.asarray(times, dtype=np.float64) - tk) / h
        vander = np.vander(u, len(u), increasing=True)
        coeffs = np.linalg.solve(vander, joints)
        return cls(tk, h, coeffs, coeffs[1] / h)

    def at(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                    NDArray[np.float64]]:
        """(r, ṙ, r̈) (k,) at time ``t`` (u = (t − h − t_k)/h; past the segment's end the
        polynomial extrapolates)."""
        h = self.h
        u = (t - self.start) / h - 1.0
        c = self.coeffs
        n = len(c)
        powers = u ** np.arange(n)
        r = powers @ c
        j = np.arange(1, n)
        dr = (j * powers[:-1]) @ c[1:] / h
        if n < 3:
            return r, dr, np.zeros_like(r)
        j2 = np.arange(2, n)
        ddr = (j2 * (j2 - 1) * powers[:-2]) @ c[2:] / (h * h)
        return r, dr, ddr

    @property
    def end(self) -> float:
        """When the reference reaches the newest target."""
        return self.start + self.h


__all__ = ["Segment"]
