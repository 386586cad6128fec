"""Issue 17 §1 under a jerk limit: the default profile is never slower than quintic ``auto``
(+ one period) and meets a fixed duration the quintic meets, however tight the limit.

The jerk pass's box filter costs about one window a piece, which under a tight limit (full
acceleration in 0.2–0.5 s) made the optimal profile up to 1.5× the quintic's duration on the
bench's paths; the planner now keeps the faster of the two time laws on the same geometry
(planner.build) and the timing core tries the fastest uniform quintic per piece
(path_timing.quintic_law).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import ARM2R, ARM3R

import robodcn

D = math.radians
SINGLE = [[0.25, 0.10, 0.0], [0.05, 0.28, D(90)]]
VIAS = [[0.25, 0.10, 0.0], [0.2, 0.15, D(20)], [0.12, 0.24, D(60)], [0.05, 0.25, D(80)]]
SINGLE2 = [[0.18, 0.08], [-0.05, 0.2]]
VIAS2 = [[0.18, 0.08], [0.12, 0.14], [0.02, 0.2], [-0.1, 0.15]]
PATHS = {"arm3r single": (ARM3R, SINGLE, False), "arm3r stops": (ARM3R, VIAS, False),
         "arm3r blend": (ARM3R, VIAS, True), "arm2r single": (ARM2R, SINGLE2, False),
         "arm2r blend": (ARM2R, VIAS2, True)}
METHODS = [("sclerp", 1.0), ("kenlerp", 2.0), ("seplerp", 1.0), ("dlb", 1.0)]


def jerk_arm(per_accel: float, arm: robodcn.Arm = ARM3R) -> robodcn.Arm:
    """``arm`` with a jerk limit of ``per_accel`` × each joint's acceleration limit (1/s)."""
    return dataclasses.replace(arm, joints=tuple(
        dataclasses.replace(j, max_jerk=per_accel * j.max_acceleration) for j in arm.joints))


@pytest.mark.parametrize("rate", [100.0, 1000.0])
@pytest.mark.parametrize("per_accel", [2.0, 5.0, 20.0])
@pytest.mark.parametrize("method, beta", METHODS, ids=[m for m, _ in METHODS])
@pytest.mark.parametrize("path", list(PATHS))
def test_optimal_is_never_slower_than_quintic_under_a_jerk_limit(rate, per_accel, method,
                                                                  beta, path):
    base, waypoints, blend = PATHS[path]
    arm = jerk_arm(per_accel, base)
    kw = dict(rate_hz=rate, blend=blend, method=method, beta=beta)
    optimal = robodcn.plan(arm, waypoints, **kw)
    quintic = robodcn.plan(arm, waypoints, profile="quintic", **kw)
    assert optimal.duration <= quintic.duration + 1.0 / rate, (optimal.duration,
                                                                quintic.duration)
    assert optimal.request.profile == "optimal"
    # every sample within the limits, jerk included (finite differences at the rate)
    q = np.asarray(optimal.joints)
    v = np.array([j.max_velocity for j in arm.joints])
    a = np.array([j.max_acceleration for j in arm.joints])
    j = np.array([jt.max_jerk for jt in arm.joints])
    tol = 1e-6
    assert (np.abs(np.diff(q, axis=0)) * rate <= v * (1 + tol)).all()
    assert (np.abs(np.diff(q, 2, axis=0)) * rate ** 2 <= a * (1 + tol)).all()
    assert (np.abs(np.diff(q, 3, axis=0)) * rate ** 3 <= j * (1 + tol)).all()


def test_a_fixed_duration_the_quintic_meets_is_met_under_a_tight_jerk_limit():
    arm = jerk_arm(2.0)
    quintic = robodcn.plan(arm, SINGLE, profile="quintic", rate_hz=100.0)
    fixed = robodcn.plan(arm, SINGLE, duration=quintic.duration, rate_hz=100.0)
    assert fixed.duration == pytest.approx(quintic.duration, abs=1e-9)
    assert fixed.request.profile == "optimal"
    end = robodcn.kinematics.fk(arm.links, np.asarray(fixed.joints)[-1:])[0]
    assert np.allclose(end[:2], SINGLE[-1][:2], atol=1e-6)
