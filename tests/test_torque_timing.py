"""Torque limits in the optimal timing (issue 19): τ = a s̈ + b ṡ² + c as reachability rows.

Oracles: the `toppra` package's torque-limited optimum (JointTorqueConstraint with our
inverse dynamics) on the same joint path; MuJoCo's mj_inverse of the test's own OM-X model
(tests/omx_mujoco.py, rotor inertia as armature) on the planned samples' finite
differences; the plans of arms without torque limits.
"""

from __future__ import annotations

import dataclasses
import functools
import logging

import mujoco
import numpy as np
import pytest
from conftest import CONFIGS
from omx_mujoco import omx_model
from omx_numbers import OMX, OMX_ARM

from robodcn.config import load_arm, rigid_chain
from robodcn.dynamics import inverse_dynamics
from robodcn.errors import PlanError, TorqueLimitError
from robodcn.path_timing import JointLimits, time_optimal
from robodcn.planner import plan

toppra = pytest.importorskip("toppra")
from toppra import algorithm, constraint  # noqa: E402

logging.getLogger("toppra").setLevel(logging.ERROR)

RATE = 100.0


def variant(arm, **changes):
    """The arm with every joint's fields changed (e.g. higher acceleration limits, so the
    torque binds; lower torque limits)."""
    return dataclasses.replace(arm, joints=tuple(dataclasses.replace(j, **changes)
                                                 for j in arm.joints))


#: The OM-X with acceleration and velocity limits its servos' torque cannot always deliver
FAST = variant(OMX_ARM, max_acceleration=60.0, max_velocity=4.0)
#: joint paths (start, goal) of the OM-X, joints yaw, shoulder, elbow, wrist (rad)
JOINT_PATHS = [
    (np.array([0.0, -1.0, 0.3, 0.7]), np.array([1.5, 1.2, -1.0, 1.5])),
    (np.array([-1.2, 0.4, -0.6, 0.0]), np.array([1.0, -0.8, 0.9, -1.0])),
    (np.array([0.3, 1.3, -1.2, 1.2]), np.array([-0.3, -0.2, 0.5, -0.4])),
]


def cubic_path(q0, q1, n=400):
    """q(s) = q0 + (q1 − q0)(3s² − 2s³): a cubic, so toppra's cubic spline through the
    samples is the same path."""
    s = np.linspace(0.0, 1.0, n)
    h = s * s * (3.0 - 2.0 * s)
    return s, q0 + (q1 - q0) * h[:, None]


def toppra_duration(arm, s, q, payload, torque=True):
    lim = JointLimits.of(arm, payload)
    chain = rigid_chain(arm)
    path = toppra.SplineInterpolator(s, q)
    interp = constraint.DiscretizationType.Interpolation
    cons = [constraint.JointVelocityConstraint(np.stack([-lim.v, lim.v], axis=1)),
            constraint.JointAccelerationConstraint(np.stack([-lim.a, lim.a], axis=1),
                                                   discretization_scheme=interp)]
    if torque:
        tau = np.array(arm.max_torques, dtype=float)
        cons.append(constraint.JointTorqueConstraint(
            lambda qq, vv, aa: inverse_dynamics(chain, qq, vv, aa, payload),
            np.stack([-tau, tau], axis=1), np.zeros(q.shape[1]),
            discretization_scheme=interp))
    inst = algorithm.TOPPRA(cons, path, gridpoints=np.linspace(0.0, 1.0, 1001),
                            parametrizer="ParametrizeConstAccel")
    return inst.compute_trajectory(0.0, 0.0).duration


@pytest.mark.parametrize("payload", [0.0, 0.5])
@pytest.mark.parametrize("which", range(len(JOINT_PATHS)))
def test_duration_within_2_percent_of_toppra_torque_limited(payload, which):
    s, q = cubic_path(*JOINT_PATHS[which])
    lim = JointLimits.of(FAST, payload)
    ours = time_optimal(q, s, lim.v, lim.a, torque=lim.torque).duration
    theirs = toppra_duration(FAST, s, q, payload)
    assert abs(ours / theirs - 1.0) <= 0.02, (ours, theirs)


def test_torque_binds_on_the_loaded_fast_paths():
    """The comparison above is about torque: without the torque rows both would be faster."""
    slower = 0
    for q0, q1 in JOINT_PATHS:
        s, q = cubic_path(q0, q1)
        lim = JointLimits.of(FAST, 0.5)
        with_t = time_optimal(q, s, lim.v, lim.a, torque=lim.torque).duration
        without = time_optimal(q, s, lim.v, lim.a).duration
        assert with_t >= without * (1 - 1e-12)
        slower += with_t > 1.03 * without
        assert abs(toppra_duration(FAST, s, q, 0.5, torque=False) / without - 1) <= 0.02
    assert slower >= 2


def test_loaded_move_slower_only_where_torque_binds():
    """A path that stops at s = 0.5: a fast shoulder/elbow swing (torque binds with 0.5 kg),
    then a small wrist motion (it does not): the second part takes the same time."""
    s = np.linspace(0.0, 1.0, 801)
    first = np.minimum(s / 0.5, 1.0)
    second = np.clip((s - 0.5) / 0.5, 0.0, 1.0)
    h1, h2 = (x * x * (3 - 2 * x) for x in (first, second))
    q = np.stack([0.0 * s, 1.0 - 2.2 * h1, -0.8 + 1.6 * h1, 0.2 + 0.3 * h2], axis=1)
    laws = {}
    for payload in (0.0, 0.5):
        lim = JointLimits.of(FAST, payload)
        laws[payload] = time_optimal(q, s, lim.v, lim.a, stops=[0.5], torque=lim.torque)
    parts = {}
    for payload, law in laws.items():
        # the law's own breakpoints (t, s, ṡ): the stop is one, at rest
        i = int(np.argmin(np.abs(law._sb - 0.5)))
        assert law._vb[i] == 0.0
        parts[payload] = (law._tb[i], law.duration - law._tb[i])
    assert parts[0.5][0] > 1.02 * parts[0.0][0]          # the swing: torque binds
    assert parts[0.5][1] == pytest.approx(parts[0.0][1], rel=1e-12)  # the wrist: it doesn't


@functools.cache
def mj(payload):
    return omx_model(OMX, payload)


def mujoco_torques(joints, payload, rate=RATE):
    """mj_inverse of every sample with its central differences (at rest before and after),
    charged like the acceleration to the next sample."""
    padded = np.concatenate([joints[:1], joints[:1], joints, joints[-1:]])
    mid = padded[1:-1]
    qd = (padded[2:] - padded[:-2]) * rate / 2.0
    qdd = (padded[2:] - 2 * mid + padded[:-2]) * rate ** 2
    m = mj(payload)
    d = mujoco.MjData(m)
    out = np.empty_like(mid)
    for i in range(mid.shape[0]):
        d.qpos[:], d.qvel[:], d.qacc[:] = mid[i], qd[i], qdd[i]
        mujoco.mj_inverse(m, d)
        out[i] = d.qfrc_inverse
    return out


WAYPOINTS = [
    [[0.25, 0.0, 0.05, 0.0], [0.0, 0.25, 0.15, 0.0]],
    [[0.12, -0.15, 0.22, 0.0], [0.26, 0.05, 0.04, -0.3]],
]


@pytest.mark.parametrize("arm_name", ["omx", "fast"])
@pytest.mark.parametrize("payload", [0.0, 0.5])
@pytest.mark.parametrize("which", range(len(WAYPOINTS)))
def test_every_sample_within_max_torque_by_mujoco(arm_name, payload, which):
    arm = OMX_ARM if arm_name == "omx" else FAST
    tr = plan(arm, WAYPOINTS[which], payload_kg=payload, rate_hz=RATE)
    tau = mujoco_torques(np.asarray(tr.joints), payload)
    limit = np.array(arm.max_torques)
    assert (np.abs(tau) <= limit * (1 + 1e-6)).all(), np.abs(tau).max(axis=0)


def test_fast_loaded_plan_rides_the_torque_limit():
    """Not vacuous: the loaded fast plan needs (nearly) the whole torque of some joint,
    and is slower than the unloaded one."""
    loaded = plan(FAST, WAYPOINTS[0], payload_kg=0.5, rate_hz=RATE)
    empty = plan(FAST, WAYPOINTS[0], payload_kg=0.0, rate_hz=RATE)
    tau = np.abs(mujoco_torques(np.asarray(loaded.joints), 0.5))
    assert (tau / np.array(FAST.max_torques)).max() > 0.97
    assert loaded.t[-1] > empty.t[-1]


def test_unbound_path_same_duration_loaded_or_not():
    """The packaged limits: torque does not bind on this move, loaded or not, so the plan
    is the same (though the loaded one needs more torque)."""
    a = plan(OMX_ARM, WAYPOINTS[0], payload_kg=0.0, rate_hz=RATE)
    b = plan(OMX_ARM, WAYPOINTS[0], payload_kg=0.5, rate_hz=RATE)
    assert a.t.shape == b.t.shape
    np.testing.assert_array_equal(np.asarray(a.joints), np.asarray(b.joints))
    ta, tb = (np.abs(mujoco_torques(np.asarray(x.joints), p)).max() for x, p in
              ((a, 0.0), (b, 0.5)))
    assert tb > ta * 1.5


def test_planar_arm_plans_bit_identical_with_unbinding_torque_limits():
    """A planar arm without max_torque_nm has no torque rows; with limits that never bind
    the rows change nothing: the same plan bit for bit (so the rows' algebra does not
    perturb the reachability sets)."""
    arm = load_arm(CONFIGS / "arm3r.toml")
    assert JointLimits.of(arm).torque is None
    loose = variant(arm, max_torque=1e6)
    assert JointLimits.of(loose).torque is not None
    for wps in ([[0.4, 0.0, 0.0], [0.12, 0.24, 1.0]], [[0.3, 0.1, 0.5], [0.1, 0.3, 1.2],
                                                         [-0.2, 0.25, 2.0]]):
        for blend in (False, True):
            a = plan(arm, wps, blend=blend)
            b = plan(loose, wps, blend=blend)
            np.testing.assert_array_equal(np.asarray(a.joints), np.asarray(b.joints))
            np.testing.assert_array_equal(a.t, b.t)


def test_fixed_duration_too_short_names_the_first_torque_sample():
    """Acceleration limits out of the way: a short fixed duration fails on torque first;
    the violation names the first sample (by MuJoCo) and its joint."""
    arm = variant(OMX_ARM, max_acceleration=1000.0, max_velocity=50.0)
    auto = plan(arm, WAYPOINTS[0], payload_kg=0.5, rate_hz=RATE)
    short = (auto.t.shape[0] - 1) * 0.7 / RATE
    with pytest.raises(TorqueLimitError) as info:
        plan(arm, WAYPOINTS[0], payload_kg=0.5, rate_hz=RATE, duration=short)
    v = info.value.violation
    assert v.quantity == "torque" and v.unit == "N*m" and v.field == "duration"
    assert info.value.exit_code == 3 and info.value.http_status == 422
    assert isinstance(info.value, PlanError)
    assert v.joint == arm.joint_names[v.joint_index]
    assert v.limit == arm.max_torques[v.joint_index]
    assert v.value > v.limit
    assert "torque" in info.value.message and v.joint in info.value.message


def test_gravity_overload_names_the_payload():
    """A shoulder that cannot hold the arm: no duration helps; the field is payload_kg."""
    weak = dataclasses.replace(OMX_ARM, joints=tuple(
        dataclasses.replace(j, max_torque=0.2) if j.name == "shoulder" else j
        for j in OMX_ARM.joints))
    with pytest.raises(TorqueLimitError) as info:
        plan(weak, WAYPOINTS[0], payload_kg=0.5, rate_hz=RATE)
    v = info.value.violation
    assert v.joint == "shoulder" and v.field == "payload_kg"
    g = mujoco_torques(np.zeros((1, 4)) + np.asarray(plan(
        OMX_ARM, WAYPOINTS[0], rate_hz=RATE).joints)[:1], 0.5)
    assert abs(g[0, 1]) > 0.2  # MuJoCo agrees that the start pose needs more than 0.2


@pytest.mark.parametrize("goal", [[0.2, -0.1, 0.2, 0.0], [0.25, 0.0, 0.05, 0.0]])
def test_moving_start_brakes_within_max_torque(goal):
    """A retarget from the middle of a torque-bound loaded move (goal ahead, and back to
    where it came from): the brake and the blend keep every joint within max_torque_nm,
    by MuJoCo across t = 0 (the samples before it continue the given state)."""
    from robodcn.contract.request import StartState
    from robodcn.planner.validate import start_history

    first = plan(FAST, WAYPOINTS[0], payload_kg=0.5, rate_hz=RATE)
    q = np.asarray(first.joints)
    k = q.shape[0] // 3
    qd = (q[k + 1] - q[k - 1]) * RATE / 2
    qdd = (q[k + 1] - 2 * q[k] + q[k - 1]) * RATE ** 2
    state = StartState(tuple(q[k]), tuple(qd), tuple(qdd))
    tr = plan(FAST, [WAYPOINTS[0][0], goal], payload_kg=0.5, rate_hz=RATE, start_state=state)
    history = start_history(q[k], qd, qdd, RATE)
    joints = np.concatenate([history, np.asarray(tr.joints)])
    tau = mujoco_torques(joints, 0.5)[history.shape[0]:]
    assert (np.abs(tau) <= np.array(FAST.max_torques) * (1 + 1e-6)).all(), \
        np.abs(tau).max(axis=0)


@pytest.mark.parametrize("which", [0, 1])
def test_a_uniform_quintic_under_a_tight_jerk_limit_keeps_the_torque_limits(which):
    """Under a jerk limit tight enough that the uniform quintic beats the box-filtered
    optimum (path_timing.quintic_law), the quintic is timed within the torque rows too: on
    the fast OM-X with 80 % of its torque, 0.5 kg and jerk 1 a/s the torque slows it (≥ 4 %
    longer than without torque limits), and inverse dynamics of its samples at 1 kHz stay
    within every joint's torque."""
    from robodcn.path_timing.quintic_law import QuinticTiming

    arm = dataclasses.replace(FAST, joints=tuple(
        dataclasses.replace(j, max_torque=0.8 * j.max_torque) for j in FAST.joints))
    q0, q1 = JOINT_PATHS[which]
    s, q = cubic_path(q0, q1)
    lim = JointLimits.of(arm, 0.5)
    tight = 1.0 * lim.a  # rad/s³: full acceleration in a second
    law = time_optimal(q, s, lim.v, lim.a, tight, torque=lim.torque, rate_hz=1000.0)
    assert isinstance(law, QuinticTiming), law
    free = time_optimal(q, s, lim.v, lim.a, tight, rate_hz=1000.0)
    assert law.duration >= 1.04 * free.duration, "the torque binds"
    m = law.sample(1000.0)
    h = m.s * m.s * (3.0 - 2.0 * m.s)
    dh, ddh = 6.0 * m.s * (1.0 - m.s), 6.0 - 12.0 * m.s
    joints = q0 + (q1 - q0) * h[:, None]
    qd = (q1 - q0) * (dh * m.sd)[:, None]
    qdd = (q1 - q0) * (ddh * m.sd ** 2 + dh * m.sdd)[:, None]
    tau = inverse_dynamics(rigid_chain(arm), joints, qd, qdd, 0.5)
    limit = np.array(arm.max_torques)
    assert (np.abs(tau) <= limit * (1 + 1e-3)).all(), (np.abs(tau) / limit).max(axis=0)
    assert (np.abs(tau) / limit).max() > 0.97, "it rides the limit"
