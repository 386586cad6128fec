"""What every feedback read of an execution saw: :class:`ExecutionTrace` and its recorder.

The streamer records, at each feedback read, the time, the present ticks, the tracking error
(:func:`robodcn.stream.report.tracking_error`, the report's one definition) and, with the
feedback map (:mod:`robodcn.bus.feedback`), the present current of every joint, into arrays
allocated before the loop (one row per sample at most: a sample reads at most once), so
recording costs no allocation in the loop. ``ExecutionReport.trace`` carries the result for
the dry run's plot (:func:`robodcn.plots.plot_motion`); it is left out of
``ExecutionReport.to_dict()`` unless asked for, since it grows with the motion.

Angles and currents are in the joint's sign (the servo's ``direction`` applied), so they
compare with the plan and with the predicted currents (:mod:`robodcn.stream.collision`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True, eq=False)
class ExecutionTrace:
    """One row per feedback read, in the order read (joints in bus order).

    Attributes
    ----------
    sample : (n,) index of the planned sample whose write the read followed
    t : (n,) seconds from the first write's due time to the read
    ticks : (n, k) present positions, ticks
    tracking_error_rad : (n, k) signed tracking error, rad (joint sign)
    current_a : (n, k) present current, A (joint sign; NaN for a read without the feedback
        map), or None when no read carried currents
    joint_names : (k,)
    tracking_limit_rad : the tracking-error stop limit (None: no stop)
    current_limit_a : (k,) the servos' Current Limit, A (None when unknown)
    collision_threshold_a : (k,) collision-stop thresholds, A (None for a joint whose stop is
        off; the whole tuple None when there are none)
    predicted_current_a : (m, k) current the plan asks for at each planned sample, A (joint
        sign; :func:`robodcn.stream.collision.predicted_currents`), or None
    """

    sample: NDArray[np.int64]
    t: NDArray[np.float64]
    ticks: NDArray[np.int64]
    tracking_error_rad: NDArray[np.float64]
    current_a: NDArray[np.float64] | None
    joint_names: tuple[str, ...]
    tracking_limit_rad: float | None = None
    current_limit_a: tuple[float, ...] | None = None
    collision_threshold_a: tuple[float | None, ...] | None = None
    predicted_current_a: NDArray[np.float64] | None = None

    def __len__(self) -> int:
        return len(self.t)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready lists (large: one row per read)."""
        def rows(a: NDArray[Any] | None) -> list[Any] | None:
            if a is None:
                return None
            return np.where(np.isnan(a), None, a).tolist() if a.dtype.kind == "f" else \
                a.tolist()

        return {"sample": self.sample.tolist(), "t": self.t.tolist(),
                "ticks": self.ticks.tolist(),
                "tracking_error_rad": rows(self.tracking_error_rad),
                "current_a": rows(self.current_a), "joint_names": list(self.joint_names),
                "tracking_limit_rad": self.tracking_limit_rad,
                "current_limit_a": None if self.current_limit_a is None
                else list(self.current_limit_a),
                "collision_threshold_a": None if self.collision_threshold_a is None
                else list(self.collision_threshold_a),
                "predicted_current_a": rows(self.predicted_current_a)}


class TraceRecorder:
    """Preallocated rows for :class:`ExecutionTrace` (one per sample; grows only if the
    motion does, e.g. a source swapped for a longer one between two samples)."""

    def __init__(self, samples: int, direction: Sequence[int],
                 rad_per_tick: NDArray[np.float64]) -> None:
        k = len(direction)
        self.direction = np.asarray(direction, dtype=np.float64)
        self.rad_per_tick = self.direction * np.asarray(rad_per_tick, dtype=np.float64)
        rows = max(1, samples)
        self.sample = np.zeros(rows, dtype=np.int64)
        self.t = np.zeros(rows)
        self.ticks = np.zeros((rows, k), dtype=np.int64)
        self.error = np.zeros((rows, k))
        self.current = np.full((rows, k), np.nan)
        self.count = 0
        self.with_current = False

    def record(self, sample: int, t: float, ticks: NDArray[np.int64],
               error_ticks: NDArray[np.float64], current: NDArray[np.float64] | None) -> None:
        """One read: present ``ticks``, tracking error in ticks and currents (A, servo sign;
        None without the feedback map)."""
        i = self.count
        if i == len(self.t):
            self._grow()
        self.sample[i] = sample
        self.t[i] = t
        self.ticks[i] = ticks
        self.error[i] = error_ticks
        if current is not None:
            self.current[i] = current
            self.with_current = True
        self.count = i + 1

    def _grow(self) -> None:
        for name in ("sample", "t", "ticks", "error", "current"):
            a = getattr(self, name)
            more = np.full_like(a, np.nan) if name == "current" else np.zeros_like(a)
            setattr(self, name, np.concatenate([a, more]))

    def trace(self, joint_names: Sequence[str], **limits: Any) -> ExecutionTrace:
        """The rows recorded so far (in rad and A, joint sign); ``limits`` are
        :class:`ExecutionTrace`'s limit and prediction fields."""
        n = self.count
        return ExecutionTrace(
            sample=self.sample[:n], t=self.t[:n], ticks=self.ticks[:n],
            tracking_error_rad=self.error[:n] * self.rad_per_tick,
            current_a=self.current[:n] * self.direction if self.with_current else None,
            joint_names=tuple(joint_names), **limits)


__all__ = ["ExecutionTrace", "TraceRecorder"]
