"""The optimal law's pieces re-parameterised by joint-space arc length.

A pose path leaving (or reaching) a stretched or folded arm moves its joints like √u in the
path parameter u (:mod:`robodcn.path_timing.arclength`): its q′(u) is unbounded there and a
law timed in u cannot keep the joint acceleration between its first grid points. Each path
piece is therefore timed in σ, its joint-space arc length normalised to [0, 1]: the dense
samples are re-spaced evenly in σ where they were uneven (IK at the new u, a few rounds), and
the piece's path becomes an :class:`ArcPath` — the same poses, addressed by σ (its knots
too), so sampling, segments and marks read it like the original path.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from robodcn.contract.request import PlanRequest
from robodcn.path_timing.arclength import Smooth, arc_grid
from robodcn.planner.path import Path, joints_of
from robodcn.planner.pieces import DensePiece

__all__ = ["ArcPath", "by_arc_length"]


class ArcPath:
    """A :class:`~robodcn.planner.path.Path` addressed by its arc length σ ∈ [0, 1]:
    P(u(σ)) with u(σ) the C² quintic through the dense samples (σ_i, u_i)."""

    def __init__(self, path: Path, u: NDArray[np.float64], sigma: NDArray[np.float64]
                 ) -> None:
        self.path = path
        self.segments = path.segments
        self._u, self._sigma = u, sigma
        self._u_of: Smooth | None = None
        if path.knots.shape[0] == 2:  # no inner knot: both ends are set below anyway
            self.knots = np.array([0.0, 1.0])
        else:
            self.knots = np.interp(path.knots, u, sigma)
            self.knots[0], self.knots[-1] = 0.0, 1.0

    @property
    def u_of(self) -> Smooth:
        """u(σ), built on first use (the plan's samples are the joints' own interpolant:
        most plans never address the path by σ)."""
        if self._u_of is None:
            self._u_of = Smooth(self._sigma, self._u, monotone=True)
        return self._u_of

    def __call__(self, sigma: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.path(self.u_of(sigma))


def _respaced(req: PlanRequest, piece: DensePiece) -> None:
    assert piece.path is not None and piece.s is not None and piece.q is not None
    path, q_old = piece.path, piece.q

    def joints_at(u: NDArray[np.float64]) -> NDArray[np.float64] | None:
        q, _ = joints_of(req.arm, path(u), q_old[0], req.branch)
        if q is None:
            return None
        # the piece's joints may carry a 2π turn (an approach's): keep it
        turns = np.round((q_old[0] - q[0]) / (2.0 * math.pi))
        return q + 2.0 * math.pi * turns

    u, q, sigma = arc_grid(piece.s, q_old, joints_at, keep=path.knots)
    piece.s, piece.q = sigma, q
    piece.path = ArcPath(path, u, sigma)  # type: ignore[assignment]


def by_arc_length(req: PlanRequest, pieces: list[DensePiece]) -> list[DensePiece]:
    """Every path piece (not the joint-line approach) in σ (module doc), in place."""
    for piece in pieces:
        if piece.path is not None and not isinstance(piece.path, ArcPath):
            _respaced(req, piece)
    return pieces
