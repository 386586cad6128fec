"""A way back: the slow joint-space recovery from a present state the planner refuses as a
start (issue 26 §4).

After a fall, a hand move or a power cycle the arm may rest where no plan may start: the
OpenMANIPULATOR-X's elbow on its end stop at 83.2°, 3° past its 80.2° limit. Every move from
there first brings the arm back:

* **Is the present acceptable as a start?** :func:`start_problems` answers with the
  :class:`StartProblem` s it finds — empty when it is. Each check in :data:`START_CHECKS`
  is a function (arm, joints (k,) rad) → problems; :func:`joint_limit_problems` is the
  first: a joint outside its limits. A keep-out zone of the arm's workspace adds its own
  check here (a problem names the joints it moves and where to: its ``target``).
* **The recovery** (:func:`recovery_joints`): the joints with a problem move to their
  targets — a joint outside its limits to :data:`RECOVERY_MARGIN` inside the limit it
  is past, so only toward its range — and the others stay. One quintic
  s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ (monotone: each joint moves one way only, rest to rest) timed at
  :data:`RECOVERY_SHARE` of each joint's velocity and acceleration limits:
  T = max_j max(15/8·|Δq_j|/(share·v_j), √(10/√3·|Δq_j|/(share·a_j))) (the quintic's
  peaks ds/dτ = 15/8 and |d²s/dτ²| = 10/√3), rounded up to whole sample periods.
* **Then the move** (:func:`with_recovery`): the move asked for is planned from the
  recovered joints first — a plan that fails raises before anything moves — and the
  recovery is put in front of it: one trajectory, streamed as one motion, checked against
  the arm's keep-out zones from where the arm is (a point inside may only leave).
  :class:`Recovery` says what it does, as data and as the one line surfaces announce.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import servo_units
from robodcn.config import Arm
from robodcn.errors import InputError, TickLimitError
from robodcn.planner import keepout
from robodcn.planner.path import user_pose
from robodcn.planner.trajectory import Trajectory

#: Share of each joint's velocity and acceleration limits a recovery moves at.
RECOVERY_SHARE = 0.2
#: How far inside its range a recovered joint comes to rest (rad, 1°): clear of the limit
#: by more than the position loop's rest error.
RECOVERY_MARGIN = math.radians(1.0)
#: The quintic's peak ds/dτ and |d²s/dτ²| (robodcn.workflow.files' approach uses the same).
_PEAK_V = 15.0 / 8.0
_PEAK_A = 10.0 / math.sqrt(3.0)


@dataclass(frozen=True)
class StartProblem:
    """Why a present state is not acceptable as a start: ``kind`` ("joint_limit"; a keep-out
    check adds its own), the ``joint`` (name, ``index``) concerned, its ``value`` and the
    ``limit`` it is past (rad), and ``target``: where the recovery takes that joint (rad)."""

    kind: str
    joint: str
    index: int
    value: float
    limit: float
    target: float

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def joint_limit_problems(arm: Arm, joints: NDArray[np.float64]) -> tuple[StartProblem, ...]:
    """The joints of ``joints`` (k,) rad outside their limits (beyond float rounding, as the
    planner's start check), each with the target :data:`RECOVERY_MARGIN` inside the limit
    it is past (the middle of a range narrower than twice the margin)."""
    out = []
    for j, (value, spec) in enumerate(zip(joints.tolist(), arm.joints, strict=True)):
        lo, hi = spec.min_angle, spec.max_angle
        margin = min(RECOVERY_MARGIN, (hi - lo) / 2.0)
        if value > hi + 1e-9:
            out.append(StartProblem("joint_limit", spec.name, j, value, hi, hi - margin))
        elif value < lo - 1e-9:
            out.append(StartProblem("joint_limit", spec.name, j, value, lo, lo + margin))
    return tuple(out)


#: The checks of a present state as a start, in order (module docstring): each
#: (arm, joints (k,) rad) → its problems.
START_CHECKS: list[Callable[[Arm, NDArray[np.float64]], tuple[StartProblem, ...]]] = [
    joint_limit_problems]


def start_problems(arm: Arm, joints: ArrayLike) -> tuple[StartProblem, ...]:
    """Everything :data:`START_CHECKS` finds wrong with ``joints`` (k,) rad as the start of a
    plan; empty when the present state is acceptable as a start."""
    q = np.asarray(joints, dtype=np.float64)
    if q.shape != (arm.dof,) or not np.isfinite(q).all():
        raise InputError(f"joints must be {arm.dof} finite angles (rad) for arm "
                         f"{arm.name!r}, got {q.tolist()}", field="joints", value=q.tolist())
    return tuple(p for check in START_CHECKS for p in check(arm, q))


@dataclass(frozen=True)
class JointRecovery:
    """One joint's part of a recovery: from ``start`` to ``target`` (rad), at up to
    ``speed`` rad/s (the quintic's peak, ≤ :data:`RECOVERY_SHARE` of its limit)."""

    joint: str
    index: int
    start: float
    target: float
    speed: float

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class Recovery:
    """A recovery at the start of a move: ``joints`` (the joints it moves), its
    ``samples`` sample periods (``duration_s`` seconds) at the front of the trajectory,
    the ``share`` of the limits it moves at and the ``problems`` it answers."""

    joints: tuple[JointRecovery, ...]
    samples: int
    duration_s: float
    share: float
    problems: tuple[StartProblem, ...]

    def line(self) -> str:
        """The one line a surface announces, in degrees and deg/s: ``recovery: elbow
        83.2° → 79.2° (3.97° back into its range) at up to 17.2°/s, 0.62 s, then the
        move``."""
        parts = [f"{r.joint} {math.degrees(r.start):.1f}° → {math.degrees(r.target):.1f}° "
                 f"({math.degrees(abs(r.target - r.start)):.2f}° back into its range) at up "
                 f"to {math.degrees(r.speed):.1f}°/s" for r in self.joints]
        return (f"recovery: {', '.join(parts)} ({100 * self.share:g} % of the limits, "
                f"{self.duration_s:.2f} s), then the move")

    def to_dict(self) -> dict[str, Any]:
        return {"joints": [r.to_dict() for r in self.joints], "samples": self.samples,
                "duration_s": self.duration_s, "share": self.share,
                "problems": [p.to_dict() for p in self.problems], "message": self.line()}


class Recovered(NamedTuple):
    """A trajectory that may open with a recovery: the whole ``trajectory`` and the
    ``recovery`` at its front (None: the present was acceptable as a start)."""

    trajectory: Trajectory
    recovery: Recovery | None


def recovery_target(arm: Arm, joints: ArrayLike,
                    problems: tuple[StartProblem, ...]) -> NDArray[np.float64]:
    """``joints`` (k,) rad with each problem's joint at its target."""
    q = np.array(joints, dtype=np.float64)
    for p in problems:
        q[p.index] = p.target
    return q


def recovery_joints(arm: Arm, present: ArrayLike, target: ArrayLike, rate_hz: float,
                    share: float = RECOVERY_SHARE) -> NDArray[np.float64]:
    """Joint samples (n + 1, k) rad every 1/rate_hz s from ``present`` to ``target``, rest
    to rest, at ``share`` of the limits (module docstring: the quintic and its T)."""
    q0 = np.asarray(present, dtype=np.float64)
    delta = np.asarray(target, dtype=np.float64) - q0
    v = share * np.array([j.max_velocity for j in arm.joints])
    a = share * np.array([j.max_acceleration for j in arm.joints])
    need = max(float(np.max(_PEAK_V * np.abs(delta) / v)),
               float(np.max(np.sqrt(_PEAK_A * np.abs(delta) / a))))
    intervals = max(2, math.ceil(need * rate_hz - 1e-9))
    tau = np.arange(intervals + 1) / intervals
    s = 10 * tau ** 3 - 15 * tau ** 4 + 6 * tau ** 5
    return q0 + np.outer(s, delta)


def _check_ticks(arm: Arm, joints: NDArray[np.float64], ticks: NDArray[np.int64]) -> None:
    """TickLimitError (nothing moves) when the recovery starts outside a servo's tick
    limits: its goals there cannot be sent; the joint has to be moved back by hand."""
    lo = np.array([s.min_tick for s in arm.servos])
    hi = np.array([s.max_tick for s in arm.servos])
    bad = (ticks < lo) | (ticks > hi)
    if bad.any():
        i, j = (int(v) for v in np.argwhere(bad)[0])
        spec = arm.joints[j]
        raise TickLimitError(
            f"joint {spec.name!r} at {math.degrees(joints[i, j]):.1f}° lies beyond its "
            f"servo's tick limits {spec.servo.min_tick}..{spec.servo.max_tick} (tick "
            f"{int(ticks[i, j])}): a recovery cannot command it; move it back by hand",
            sample=i, joint=spec.name, field="start_joints")


def with_recovery(arm: Arm, present: ArrayLike, plan: Callable[[tuple[float, ...]], Trajectory],
                  share: float = RECOVERY_SHARE) -> Recovered:
    """``plan`` the move from the ``present`` joints (k,) rad, with a recovery in front of
    it when the present is not acceptable as a start (:func:`start_problems`).

    ``plan`` takes the start joints (the present, or the recovered joints) and returns the
    move's trajectory; it is called before anything else, so its errors come first and
    nothing moves. The result's trajectory is the recovery's samples (sample 0 at the
    present, each period 1/rate of the move's rate) followed by the move's; its request is
    the move's (start_joints the recovered joints) and ``approach_samples`` counts the
    recovery with the move's own approach (both are joint-space motions before the path).
    """
    q = np.asarray(present, dtype=np.float64)
    problems = start_problems(arm, q)
    if not problems:
        return Recovered(plan(tuple(float(v) for v in q)), None)
    target = recovery_target(arm, q, problems)
    move = plan(tuple(float(v) for v in target))
    rate = move.rate_hz
    joints = recovery_joints(arm, q, target, rate, share)
    ticks = servo_units.radians_to_ticks(joints, arm.servos)
    _check_ticks(arm, joints, ticks)
    n = len(joints) - 1              # the recovery's last sample is the move's first
    all_joints = np.concatenate([joints[:-1], move.joints])
    # keep-out zones as on every plan, from where the arm is: a point already inside may
    # only leave, none may enter (KeepOutError before anything moves)
    keepout.check_joints(arm, all_joints, rate, field="start_joints")
    out = Trajectory(
        t=np.arange(len(all_joints)) / rate,
        poses=np.concatenate([user_pose(arm, joints[:-1]), move.poses]),
        joints=all_joints, ticks=np.concatenate([ticks[:-1], move.ticks]),
        joint_names=move.joint_names, servo_ids=move.servo_ids, rate_hz=rate,
        method=move.method, request=move.request, elbow=move.elbow,
        branch_switches=tuple(i + n for i in move.branch_switches),
        approach_samples=n + move.approach_samples, pose_keys=move.pose_keys)
    duration = n / rate
    moved = np.flatnonzero(target != q)
    recovery = Recovery(
        joints=tuple(JointRecovery(arm.joints[j].name, int(j), float(q[j]), float(target[j]),
                                   _PEAK_V * abs(float(target[j] - q[j])) / duration)
                     for j in moved),
        samples=n, duration_s=duration, share=share, problems=problems)
    return Recovered(out, recovery)


__all__ = ["RECOVERY_MARGIN", "RECOVERY_SHARE", "START_CHECKS", "JointRecovery", "Recovered",
           "Recovery", "StartProblem", "joint_limit_problems", "recovery_joints",
           "recovery_target", "start_problems", "with_recovery"]
