"""A follow session's targets: checked, turned into joints, given a velocity.

A target is joints (k,) rad or a pose in the arm's pose axes ((x, y, θ); (x, y, z, pitch) on
a yawed arm), with an optional joint velocity (k,) rad/s to pass it with. Joints must lie
within every joint's limits and their servos' tick limits and keep the arm out of its
keep-out zones (else a :class:`~robodcn.errors.KeepOutError`); a pose must be reachable (the
arm's branch-continuous IK, :func:`robodcn.planner.path.joints_of`, nearest the previous
target's joints) — else an :class:`~robodcn.errors.InputError` naming ``joints``, ``pose`` or
``velocity`` and the offending value, and the session goes on to the previous target.

Consecutive targets within :data:`STALE_S` of each other are a stream: the arm follows the
reference they describe one target period behind (:mod:`robodcn.stream.following.reference`:
the cubic through the last four targets, or Hermite where velocities are given), so a
target that moves steadily is tracked without stopping between targets. A target alone
(the first, or after a longer gap) is reached as fast as the limits allow, at rest or with
its given velocity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodcn import servo_units
from robodcn.config import Arm
from robodcn.errors import InputError
from robodcn.planner import ANGLE_SLACK, keepout
from robodcn.planner.path import joints_of, yawed
from robodcn.stream.following.reference import Segment

#: a gap between targets longer than this (s) is no stream: the newer is a target alone
STALE_S = 0.5
#: targets of a stream its reference interpolates (a cubic: four)
POINTS = 4
#: the spaces a session takes its targets in
SPACES = ("joints", "pose")


@dataclass(frozen=True)
class Target:
    """One accepted target: joints (k,) rad, the velocity (k,) rad/s it was given (None:
    none), the time it arrived (the stream's clock) and the reference segment that ends at
    it (None: not part of a stream)."""

    joints: NDArray[np.float64]
    velocity: NDArray[np.float64] | None
    at: float
    segment: Segment | None


def _vector(name: str, value: object, width: int) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a list of {width} numbers, got {value!r}",
                         field=name, value=value) from None
    if arr.shape != (width,) or not np.isfinite(arr).all():
        raise InputError(f"{name} must be a list of {width} finite numbers, got {value!r}",
                         field=name, value=value)
    return arr


class Targets:
    """The targets of one session on ``arm`` (bus order: ``arm.joints``)."""

    def __init__(self, arm: Arm, space: str) -> None:
        if space not in SPACES:
            raise InputError(f"space must be one of {', '.join(SPACES)}, got {space!r}",
                             field="space", value=space)
        self.arm = arm
        self.space = space
        self.k = len(arm.joints)
        self.lo = np.array([j.min_angle for j in arm.joints]) - ANGLE_SLACK
        self.hi = np.array([j.max_angle for j in arm.joints]) + ANGLE_SLACK
        self.last: Target | None = None
        #: (arrival, joints, given velocity) of the stream's last targets, oldest first
        self._stream: list[tuple[float, NDArray[np.float64], NDArray[np.float64] | None]] = []
        self._before: tuple[Target | None, list] = (None, [])

    def joints_of(self, joints: object = None, pose: object = None,
                  reference: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """The joints (k,) of a target given as joints or as a pose (exactly one, the
        session's space); InputError naming the field otherwise."""
        if (joints is None) == (pose is None):
            raise InputError(f"a target is either joints or a pose (this session follows "
                             f"{self.space}), got {'both' if joints is not None else 'neither'}",
                             field=self.space, value=None)
        given = "joints" if joints is not None else "pose"
        if given != self.space:
            raise InputError(f"this session follows {self.space}: send {self.space!r}, not "
                             f"{given!r}", field=given, value=joints if pose is None else pose)
        if joints is not None:
            q = _vector("joints", joints, self.k)
        else:
            q = self._ik(_vector("pose", pose, len(self.arm.pose_keys)), reference)
        self._check_limits(q, given, joints if pose is None else pose)
        return q

    def _ik(self, pose: NDArray[np.float64], reference: NDArray[np.float64] | None
            ) -> NDArray[np.float64]:
        arm = self.arm
        path = yawed.plane_waypoints(arm, pose[None, :], reference) if arm.yawed else \
            pose[None, :].copy()
        q, _ = joints_of(arm, path, reference, arm.elbow)
        if q is None:
            keys = ", ".join(f"{k}={v:.4g}" for k, v in zip(arm.pose_keys, pose, strict=True))
            raise InputError(f"pose ({keys}) is out of reach or needs a joint beyond its "
                             "limits", field="pose", value=pose.tolist())
        return q[0]

    def _check_limits(self, q: NDArray[np.float64], name: str, given: object) -> None:
        out = (q < self.lo) | (q > self.hi)
        if out.any():
            j = int(np.argmax(out))
            spec = self.arm.joints[j]
            raise InputError(
                f"{name}: joint {spec.name!r} at {math.degrees(q[j]):.1f}° is outside its "
                f"limits {math.degrees(spec.min_angle):.1f}..{math.degrees(spec.max_angle):.1f}°",
                field=name, value=given)
        ticks = servo_units.radians_to_ticks(q, self.arm.servos)
        for j, (t, s) in enumerate(zip(ticks, self.arm.servos, strict=True)):
            if not s.min_tick <= t <= s.max_tick:
                raise InputError(f"{name}: joint {self.arm.joints[j].name!r} needs tick {t}, "
                                 f"outside servo {s.id}'s tick limits "
                                 f"{s.min_tick}..{s.max_tick}", field=name, value=given)
        keepout.check_pose(self.arm, q, field=name)   # KeepOutError: inside a zone

    def take(self, q: NDArray[np.float64], velocity: object, now: float) -> Target:
        """The target at joints ``q`` arrived at ``now`` with ``velocity`` (checked; None:
        none): its reference segment when it continues a stream (module notes); it
        becomes :attr:`last`."""
        v = None if velocity is None else _vector("velocity", velocity, self.k)
        last = self.last
        self._before = (last, self._stream)
        if last is None or not 0.0 < now - last.at <= STALE_S:
            self._stream = []
        self._stream = [*self._stream[-(POINTS - 1):], (now, q, v)]
        segment = None
        if len(self._stream) >= 2:
            # a stream's targets are taken as evenly spaced by its mean gap: their arrival
            # times carry the sender's and the host's jitter, which a difference of the
            # targets over them would turn into velocity and acceleration noise
            m = len(self._stream)
            h = (now - self._stream[0][0]) / (m - 1)
            times = now + h * np.arange(1 - m, 1)
            joints = np.array([x for _, x, _ in self._stream])
            segment = Segment.through(times, joints, [w for _, _, w in self._stream])
        target = Target(q, v, now, segment)
        self.last = target
        return target


    def drop(self, target: Target) -> None:
        """Forget ``target``, the last one taken (refused after all: the torque check)."""
        if self.last is target:
            self.last, self._stream = self._before


__all__ = ["SPACES", "STALE_S", "Target", "Targets"]
