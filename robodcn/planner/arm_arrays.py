"""The per-arm arrays of the planner's hot path, built once per :class:`~robodcn.config.Arm`.

An Arm is frozen (its joints and servos too), so the arrays every plan reads off it — the
joint and tick limits of validation, the tick conversion's columns, the joint limits of
the timing laws (:class:`~robodcn.path_timing.JointLimits`) — are the same for every plan of
that arm; a small plan spent ~10 µs building them again (issue 17 §5). They are kept per
Arm object, keyed by its identity (an Arm holds a dict, so it does not hash) and held by a
weak reference (a dropped arm's entry goes with it); the arrays are read-only, so no caller
can change what the next plan reads.
"""

from __future__ import annotations

import dataclasses
import weakref
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from robodcn import servo_units
from robodcn.config import Arm
from robodcn.path_timing.limits import JointLimits

__all__ = ["ArmArrays", "arrays_of", "limits_of"]

#: Slack on joint position limits (rad), float rounding only (validate.ANGLE_SLACK).
ANGLE_SLACK = 1e-9


def _frozen(values: list[float] | list[int], dtype: type) -> NDArray:
    a = np.array(values, dtype=dtype)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class ArmArrays:
    """An arm's constant arrays (k,) in joint order.

    links : the link lengths as a tuple of floats (kinematics' unchecked functions)
    angle_limits : (min_angle, max_angle) per joint
    lo, hi : the joint limits widened by :data:`ANGLE_SLACK`
    tmin, tmax : the servos' tick limits
    v, a, jerk : velocity, acceleration and jerk limits (``inf`` where no jerk limit)
    jerk_limited : whether any joint sets a jerk limit
    tick_scale, tick_offset : tick = tick_offset + round(angle · tick_scale), tick_scale =
        direction · ticks_per_turn / 2π (:func:`robodcn.servo_units.ticks_unchecked`)
    torque_limited : whether any joint sets ``max_torque_nm``
    joint_names, servo_ids : the arm's (its properties build them on every read)
    """

    links: tuple[float, ...]
    angle_limits: tuple[tuple[float, float], ...]
    lo: NDArray[np.float64]
    hi: NDArray[np.float64]
    tmin: NDArray[np.int64]
    tmax: NDArray[np.int64]
    v: NDArray[np.float64]
    a: NDArray[np.float64]
    jerk: NDArray[np.float64]
    jerk_limited: bool
    tick_scale: NDArray[np.float64]
    tick_offset: NDArray[np.int64]
    torque_limited: bool = False
    joint_names: tuple[str, ...] = ()
    servo_ids: tuple[int, ...] = ()
    #: (lo, hi, tmin, tmax, v, a, jerk) as lists of Python numbers (comparisons of k
    #: numbers: plain floats beat numpy calls)
    bounds: tuple[list, ...] = ()
    #: JointLimits.of(arm, payload, torque=…) by (payload, torque)
    _limits: dict[tuple[float | None, bool], JointLimits] = field(
        default_factory=dict, repr=False, compare=False)


def _build(arm: Arm) -> ArmArrays:
    joints = arm.joints
    servos = [j.servo for j in joints]
    kinematic = JointLimits.of(arm, torque=False)
    scale, offset = servo_units.tick_columns(servos)
    arrays = ArmArrays(
        links=tuple(float(v) for v in arm.links),
        angle_limits=tuple((j.min_angle, j.max_angle) for j in joints),
        lo=_frozen([j.min_angle - ANGLE_SLACK for j in joints], np.float64),
        hi=_frozen([j.max_angle + ANGLE_SLACK for j in joints], np.float64),
        tmin=_frozen([s.min_tick for s in servos], np.int64),
        tmax=_frozen([s.max_tick for s in servos], np.int64),
        v=_frozen(kinematic.v.tolist(), np.float64),
        a=_frozen(kinematic.a.tolist(), np.float64),
        jerk=_frozen(kinematic.jerk.tolist(), np.float64),
        jerk_limited=kinematic.j is not None,
        tick_scale=_frozen(scale.tolist(), np.float64),
        tick_offset=_frozen(offset.tolist(), np.int64),
        joint_names=arm.joint_names, servo_ids=arm.servo_ids,
        torque_limited=any(t is not None for t in arm.max_torques))
    bounds = tuple(x.tolist() for x in (arrays.lo, arrays.hi, arrays.tmin, arrays.tmax,
                                         arrays.v, arrays.a, arrays.jerk))
    return dataclasses.replace(arrays, bounds=bounds)


#: id(arm) → (weak reference to the arm, its arrays)
_CACHE: dict[int, tuple[weakref.ref, ArmArrays]] = {}


def arrays_of(arm: Arm) -> ArmArrays:
    """The arm's :class:`ArmArrays`, built on its first plan."""
    key = id(arm)
    hit = _CACHE.get(key)
    if hit is not None and hit[0]() is arm:
        return hit[1]
    arrays = _build(arm)
    _CACHE[key] = (weakref.ref(arm, lambda _, key=key: _CACHE.pop(key, None)), arrays)
    return arrays


def limits_of(arm: Arm, payload_kg: float | None = None, *, torque: bool = True
              ) -> JointLimits:
    """``JointLimits.of(arm, payload_kg, torque=torque)``, built once per arm and payload
    (its arrays read-only)."""
    table = arrays_of(arm)._limits
    key = (None if payload_kg is None else float(payload_kg), torque)
    lim = table.get(key)
    if lim is None:
        lim = JointLimits.of(arm, payload_kg, torque=torque)
        for a in (lim.v, lim.a, lim.j):
            if a is not None:
                a.setflags(write=False)
        table[key] = lim
    return lim
