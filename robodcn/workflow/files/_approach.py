"""A joint-space approach from the present joints to a saved trajectory's first sample."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from robodcn.config import Arm
from robodcn.errors import AccelerationLimitError, VelocityLimitError
from robodcn.planner import Trajectory
from robodcn.workflow.files._samples import check_joint_samples, joint_samples_trajectory

#: Quintic s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ peaks at ds/dτ = 15/8 and |d²s/dτ²| = 10/√3.
_QUINTIC_PEAK_V = 15.0 / 8.0
_QUINTIC_PEAK_A = 10.0 / math.sqrt(3.0)


def with_approach(traj: Trajectory, arm: Arm, present: NDArray[np.float64]) -> Trajectory:
    """``traj`` with a joint-space quintic from the ``present`` joints to its first sample
    prepended (when they differ by more than half a tick), timed within the joint limits.

    T = max_j max(15/8·|Δq_j|/v_j, √(10/√3·|Δq_j|/a_j)), rounded up to whole sample periods
    and lengthened until the finite-difference checks pass.
    """
    present = np.asarray(present, dtype=np.float64)
    delta = traj.joints[0] - present
    tolerance = min(math.pi / j.servo.ticks_per_turn for j in arm.joints)
    if np.abs(delta).max() <= tolerance:
        return traj
    vmax = np.array([j.max_velocity for j in arm.joints])
    amax = np.array([j.max_acceleration for j in arm.joints])
    need = max(float(np.max(_QUINTIC_PEAK_V * np.abs(delta) / vmax)),
               float(np.max(np.sqrt(_QUINTIC_PEAK_A * np.abs(delta) / amax))))
    rate = traj.rate_hz
    intervals = max(2, math.ceil(need * rate))
    while True:
        tau = np.arange(intervals + 1) / intervals
        s = 10 * tau ** 3 - 15 * tau ** 4 + 6 * tau ** 5
        # The approach ends exactly on the first sample (s = 1 up to rounding).
        joints = np.concatenate([present + np.outer(s[:-1], delta), traj.joints])
        marks = np.concatenate([np.zeros(intervals + 1, dtype=np.int64),
                                np.arange(1, len(traj.t))])
        try:
            ticks = check_joint_samples(arm, joints, rate, source="approach",
                                        point_of_sample=marks)
            break
        except (VelocityLimitError, AccelerationLimitError) as exc:
            if exc.sample is not None and exc.sample > intervals + 1:
                raise
            intervals = math.ceil(intervals * 1.1)
    method = traj.method if isinstance(traj.method, str) else "joint_trajectory"
    out = joint_samples_trajectory(arm, joints, rate, ticks, method)
    out.request = traj.request
    return out
