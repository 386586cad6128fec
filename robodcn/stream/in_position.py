"""Where the arm ended: the final measured position against the move's goal, per joint.

A move that sent every sample is ``done`` only when the arm came to rest on its goal: every
joint within its in-position tolerance (:attr:`robodcn.config.JointSpec.
in_position_tolerance`, the arm file's ``in_position_deg``; :data:`robodcn.config.
IN_POSITION_TICKS` ticks when the plan names no arm) of the plan's last sample. A joint
beyond it is a :class:`PositionMiss` and the move ends ``degraded`` (exit code 5 on the
command line): a load the plan did not expect (a heavier payload than declared), a joint
held back, a servo that lost its gains. The final position is read after a bounded wait
for the arm to come to rest (:data:`robodcn.stream.finish.IN_POSITION_SETTLE_S`).

Error e_j = (final_j − goal_j)·direction_j·2π/ticks_per_turn_j (joint radians, the
sign of the joint angle); a miss is |final_j − goal_j| > tolerance_j in ticks, the
tolerance in ticks being ⌊tolerance_rad / (2π/ticks_per_turn)⌋ (at least one tick).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.config import IN_POSITION_TICKS, Arm, ServoSpec
from robodcn.servo_units import radians_per_tick


@dataclass(frozen=True)
class PositionMiss:
    """One joint that came to rest out of position: ``error_ticks`` = final − goal (servo
    ticks), ``error_rad`` the same as a joint angle (rad, signed), ``tolerance_rad`` the
    joint's in-position tolerance."""

    joint: str
    servo_id: int
    error_ticks: int
    error_rad: float
    tolerance_rad: float

    def to_dict(self) -> dict[str, Any]:
        return {"joint": self.joint, "servo_id": self.servo_id,
                "error_ticks": self.error_ticks, "error_rad": self.error_rad,
                "tolerance_rad": self.tolerance_rad}


def tolerance_ticks(servos: Sequence[ServoSpec], arm: Arm | None = None) -> NDArray[np.int64]:
    """Per joint (bus order) the in-position tolerance in whole ticks (≥ 1): the arm's
    ``in_position_tolerance`` of each joint, else :data:`IN_POSITION_TICKS`."""
    if arm is None or tuple(arm.servo_ids) != tuple(s.id for s in servos):
        return np.full(len(servos), IN_POSITION_TICKS, dtype=np.int64)
    per_tick = radians_per_tick(servos)
    rad = np.array([j.in_position_tolerance for j in arm.joints])
    return np.maximum(1, np.floor(rad / per_tick + 1e-9)).astype(np.int64)


def position_misses(final: ArrayLike, goal: ArrayLike, tolerance: ArrayLike,
                    servos: Sequence[ServoSpec], joint_names: Sequence[str]
                    ) -> tuple[PositionMiss, ...]:
    """The joints whose ``final`` position (ticks, bus order) lies more than ``tolerance``
    ticks from ``goal`` (module docstring for the formula); empty when in position."""
    error = np.asarray(final, dtype=np.int64) - np.asarray(goal, dtype=np.int64)
    tol = np.asarray(tolerance, dtype=np.int64)
    per_tick = radians_per_tick(servos)
    direction = np.array([s.direction for s in servos], dtype=np.float64)
    out = []
    for j in np.flatnonzero(np.abs(error) > tol):
        out.append(PositionMiss(
            joint=joint_names[j], servo_id=int(servos[j].id), error_ticks=int(error[j]),
            error_rad=float(error[j] * direction[j] * per_tick[j]),
            tolerance_rad=float(tol[j] * per_tick[j])))
    return tuple(out)


def misses_text(misses: Sequence[PositionMiss | dict[str, Any]]) -> str:
    """The misses in degrees, one clause each: ``shoulder −4.92° (56 ticks, tolerance
    0.26°), elbow …``."""
    def get(m: PositionMiss | dict[str, Any], key: str) -> Any:
        return m[key] if isinstance(m, dict) else getattr(m, key)

    return ", ".join(f"{get(m, 'joint')} {math.degrees(get(m, 'error_rad')):+.2f}° "
                     f"({abs(get(m, 'error_ticks'))} ticks, tolerance "
                     f"{math.degrees(get(m, 'tolerance_rad')):.2f}°)" for m in misses)


__all__ = ["PositionMiss", "misses_text", "position_misses", "tolerance_ticks"]
