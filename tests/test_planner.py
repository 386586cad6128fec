"""The planner: trajectories for both arms, failures at the right sample, auto timing,
blending, approach segments, JSON/CSV round trips, input errors."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import robodcn
from robodcn import kinematics, servo_units, timing
from robodcn.config import Arm, arm_from_dict, load_arm
from robodcn.errors import (
    AccelerationLimitError,
    InputError,
    JerkLimitError,
    JointLimitError,
    PlanError,
    TickLimitError,
    UnreachableError,
    VelocityLimitError,
)
from robodcn.interpolate import interpolate
from robodcn.planner import PlanRequest, Trajectory, plan, plan_request

CONFIGS = Path(__file__).resolve().parent.parent / "configs"
ARM3R = load_arm(CONFIGS / "arm3r.toml")
ARM2R = load_arm(CONFIGS / "arm2r.toml")
WAYPOINTS_3R = [[0.25, 0.10, 0.0], [0.15, 0.20, 1.0], [0.0, 0.28, 1.5]]
WAYPOINTS_2R = [[0.18, 0.08, 0.0], [0.10, 0.15, 0.0], [-0.05, 0.2, 0.0]]


def variant(arm: Arm, only: int | None = None, **changes: Any) -> Arm:
    """The arm with every joint's (or servo's, keys 'servo_x') values replaced, or only
    joint ``only``'s."""
    data = arm.to_dict()
    for i, joint in enumerate(data["joints"]):
        if only is not None and i != only:
            continue
        for key, value in changes.items():
            if key.startswith("servo_"):
                joint["servo"][key.removeprefix("servo_")] = value
            else:
                joint[key] = value
    return arm_from_dict(data, source=arm.source)


def _jerk(arm: Arm, per_accel: float | None) -> Arm:
    """``arm`` with jerk limits per_accel × a per joint (None: no jerk limit)."""
    return dataclasses.replace(arm, joints=tuple(
        dataclasses.replace(j, max_jerk=None if per_accel is None
                            else per_accel * j.max_acceleration) for j in arm.joints))


# the example configs' recommended jerk limits (their commented max_jerk keys: 20 × a), built
# explicitly: the shipped configs leave them off
JERK3R = _jerk(ARM3R, 20.0)
JERK2R = _jerk(ARM2R, 20.0)


def unlimited(arm: Arm) -> Arm:
    """The arm with dynamic limits no servo has (built directly: the loader refuses them),
    so that only geometry decides."""
    joints = tuple(dataclasses.replace(j, max_velocity=1e4, max_acceleration=1e7, max_jerk=None)
                   for j in arm.joints)
    return dataclasses.replace(arm, joints=joints)


def check_trajectory(traj: Trajectory, arm: Arm, waypoints: Any, approach: bool = False) -> None:
    """Shapes, timing, FK consistency, ticks, and every limit, checked from the arrays."""
    wp = np.asarray(waypoints, dtype=float)
    n = traj.t.shape[0]
    assert traj.t[0] == 0.0
    np.testing.assert_allclose(np.diff(traj.t), 1.0 / traj.rate_hz, rtol=0, atol=1e-9)
    assert traj.poses.shape == (n, 3) and traj.joints.shape == traj.ticks.shape == (n, arm.dof)
    assert traj.ticks.dtype == np.int64
    assert traj.joint_names == arm.joint_names and traj.servo_ids == arm.servo_ids
    if not approach:
        np.testing.assert_allclose(traj.poses[0, :2], wp[0, :2], atol=1e-12)
    np.testing.assert_allclose(traj.poses[-1, :2], wp[-1, :2], atol=1e-12)
    fk = kinematics.fk(arm.links, traj.joints)
    np.testing.assert_allclose(fk[:, :2], traj.poses[:, :2], atol=1e-9)
    if arm.dof == 3:
        assert np.abs(kinematics.wrap(fk[:, 2] - traj.poses[:, 2])).max() < 1e-9
        assert abs(kinematics.wrap(traj.poses[-1, 2] - wp[-1, 2])) < 1e-12
    np.testing.assert_array_equal(traj.ticks, servo_units.radians_to_ticks(traj.joints,
                                                                           arm.servos))
    lo = np.array([j.min_angle for j in arm.joints])
    hi = np.array([j.max_angle for j in arm.joints])
    assert (traj.joints >= lo).all() and (traj.joints <= hi).all()
    v = np.array([j.max_velocity for j in arm.joints])
    a = np.array([j.max_acceleration for j in arm.joints])
    assert (np.abs(np.diff(traj.joints, axis=0)) * traj.rate_hz <= v * (1 + 1e-9)).all()
    assert (np.abs(np.diff(traj.joints, 2, axis=0)) * traj.rate_hz**2 <= a * (1 + 1e-9)).all()
    # the arm starts from and ends at rest: the first and last steps are accelerations too
    ends = np.abs(traj.joints[[1, -1]] - traj.joints[[0, -2]]) * traj.rate_hz**2
    assert (ends <= a * (1 + 1e-9)).all()


@pytest.mark.parametrize(("arm", "waypoints"), [(ARM3R, WAYPOINTS_3R), (ARM2R, WAYPOINTS_2R)],
                         ids=["arm3r", "arm2r"])
@pytest.mark.parametrize("profile", timing.PROFILES)
@pytest.mark.parametrize("blend", [False, True])
def test_plans_for_both_arms(arm: Arm, waypoints: Any, profile: str, blend: bool) -> None:
    traj = robodcn.plan(arm, waypoints, profile=profile, blend=blend, rate_hz=200)
    check_trajectory(traj, arm, waypoints)
    assert traj.method == "sclerp" and traj.request.arm is arm


def test_fixed_duration_and_per_segment_methods() -> None:
    traj = plan(ARM3R, WAYPOINTS_3R, profile="quintic", method=["seplerp", "kenlerp"], beta=0.5,
                turn=["shortest", "shortest"], duration=3.0, rate_hz=100)
    check_trajectory(traj, ARM3R, WAYPOINTS_3R)
    assert traj.duration == pytest.approx(3.0)
    assert traj.method == ["seplerp", "kenlerp"]
    # without blend, the arm stops at the via point: a sample sits on it at rest
    at = np.argmin(np.linalg.norm(traj.poses[:, :2] - WAYPOINTS_3R[1][:2], axis=1))
    np.testing.assert_allclose(traj.poses[at], WAYPOINTS_3R[1], atol=1e-12)
    steps = np.abs(np.diff(traj.joints, axis=0)).max(axis=1)
    assert steps[at] < 1e-3 * steps.max() and steps[at - 1] < 1e-3 * steps.max()
    # the first segment is SEP-LERP: a straight line in x, y
    first = traj.poses[: at + 1, :2]
    d = np.subtract(WAYPOINTS_3R[1][:2], WAYPOINTS_3R[0][:2])
    cross = (first[:, 0] - WAYPOINTS_3R[0][0]) * d[1] - (first[:, 1] - WAYPOINTS_3R[0][1]) * d[0]
    assert np.abs(cross).max() < 1e-12


def test_single_segment_matches_interpolate_under_the_profile() -> None:
    traj = plan(ARM3R, WAYPOINTS_3R[:2], method="kenlerp", beta=1.7, duration=1.5,
                profile="trapezoid", rate_hz=100)
    n = traj.t.shape[0] - 1
    poses = traj.poses
    # the profile is a trapezoid with some acceleration fraction: recover s from the
    # interpolation itself (its θ is linear in s) and check the positions agree
    s = (poses[:, 2] - WAYPOINTS_3R[0][2]) / (WAYPOINTS_3R[1][2] - WAYPOINTS_3R[0][2])
    expected = interpolate(WAYPOINTS_3R[0], WAYPOINTS_3R[1], s, method="kenlerp", beta=1.7)
    np.testing.assert_allclose(poses, expected, atol=1e-12)
    assert n == 150
    speed = np.diff(s)
    assert speed.max() == pytest.approx(speed[n // 2], rel=1e-9)  # cruising in the middle


# -- failures at the right sample ---------------------------------------------------------------

def test_unreachable_sample_is_named() -> None:
    """The tool point stays put while θ swings the long way through ±π: the wrist point
    (l3 behind the tool) leaves the workspace in the middle, both ends are reachable."""
    arm = unlimited(ARM3R)
    start, end = [0.32, 0.0, -2.0], [0.32, 0.0, 2.0]
    rate, duration = 100, 4.0
    with pytest.raises(UnreachableError) as info:
        plan(arm, [start, end], duration=duration, rate_hz=rate)
    n = round(duration * rate)
    theta = -2.0 + timing.quintic(np.arange(n + 1) / n) * (4.0 - 2 * math.pi)  # shortest: cw
    wrist = np.hypot(0.32 - arm.links[2] * np.cos(theta), -arm.links[2] * np.sin(theta))
    expected = int(np.argmax(wrist > sum(arm.links[:2]) + kinematics.REACH_TOLERANCE))
    err = info.value
    assert err.sample == expected > 0
    assert err.t == pytest.approx(expected / rate)
    np.testing.assert_allclose(err.pose, [0.32, 0.0, theta[expected]], atol=1e-12)
    assert f"sample {expected}" in str(err) and "out of reach" in str(err)
    assert err.to_dict()["sample"] == expected
    # "auto" cannot time a path with a gap: it reports the gap, not the speeds before it
    with pytest.raises(UnreachableError) as info:
        plan(ARM3R, [start, end], rate_hz=rate)
    assert wrist_radius_at(info.value.pose) > sum(arm.links[:2])


def wrist_radius_at(pose: Any) -> float:
    return float(kinematics.wrist_radius(ARM3R.links, [pose])[0])


def test_unreachable_waypoint_is_named() -> None:
    wps = [*WAYPOINTS_3R, [0.6, 0.1, 0.0]]
    with pytest.raises(UnreachableError) as info:
        plan(ARM3R, wps)
    assert info.value.field == "waypoints[3]"
    assert "waypoints[3]" in str(info.value) and "0.35" in str(info.value)


def first_bad_row(bad: np.ndarray) -> int:
    rows = bad.any(axis=1)
    assert rows.any()
    return int(np.argmax(rows))


def test_joint_limit_sample_is_named() -> None:
    # rotate the whole arm about the base (pole at the origin): the shoulder sweeps ~80°
    wps = [[0.28 * math.cos(0.2), 0.28 * math.sin(0.2), 0.2],
           [0.28 * math.cos(1.6), 0.28 * math.sin(1.6), 1.6]]
    free = plan(ARM3R, wps, profile="quintic", duration=3.0, rate_hz=100)
    shoulder = free.joints[:, 0]
    limit = 0.5 * (np.abs(shoulder).min() + np.abs(shoulder).max())
    narrow = variant(ARM3R, only=0, min=-limit, max=limit)
    expected = first_bad_row(np.abs(free.joints[:, :1]) > limit)
    with pytest.raises(JointLimitError) as info:
        plan(narrow, wps, profile="quintic", duration=3.0, rate_hz=100)
    err = info.value
    assert err.sample == expected and err.joint == "shoulder"
    np.testing.assert_allclose(err.pose, free.poses[expected], atol=1e-12)
    assert err.t == pytest.approx(free.t[expected])
    assert "'shoulder'" in str(err) and f"sample {expected} " in str(err)


def test_waypoint_outside_the_limits_is_named() -> None:
    free = plan(ARM3R, WAYPOINTS_3R, profile="quintic", duration=3.0, rate_hz=100)
    limit = abs(free.joints[0, 0]) * 0.9  # the first waypoint's shoulder is beyond it
    narrow = variant(ARM3R, only=0, min=-limit, max=limit)
    with pytest.raises(JointLimitError) as info:
        plan(narrow, WAYPOINTS_3R, profile="quintic", duration=3.0, rate_hz=100)
    assert info.value.sample == 0 and info.value.field == "waypoints[0]"
    assert "waypoints[0]" in str(info.value)


def test_tick_limit_sample_is_named() -> None:
    free = plan(ARM3R, WAYPOINTS_3R, profile="quintic", duration=4.0, rate_hz=100)
    narrow = variant(ARM3R, servo_min_tick=1500, servo_max_tick=2600)
    expected = first_bad_row((free.ticks < 1500) | (free.ticks > 2600))
    with pytest.raises(TickLimitError) as info:
        plan(narrow, WAYPOINTS_3R, duration=4.0, rate_hz=100)
    assert info.value.sample == expected
    assert info.value.value == free.ticks[expected][
        ARM3R.joint_names.index(info.value.joint)]


@pytest.mark.parametrize("profile", ["quintic", "trapezoid"])
def test_too_fast_duration_fails_at_the_first_fast_sample(profile: str) -> None:
    wps = WAYPOINTS_3R[:2]
    fast = unlimited(ARM3R)
    # trapezoid shape depends on the limits: compare against the quintic only
    loose = plan(fast, wps, duration=0.3, rate_hz=100, profile="quintic")
    q = loose.joints
    v = np.array([j.max_velocity for j in ARM3R.joints])
    a = np.array([j.max_acceleration for j in ARM3R.joints])
    vel = np.zeros_like(q)
    vel[1:] = np.abs(np.diff(q, axis=0)) * 100
    acc = np.zeros_like(q)
    acc[2:] = np.abs(np.diff(q, 2, axis=0)) * 100**2
    # the recommended jerk limits too: the third difference from rest, charged to its last sample
    j = np.array([jt.max_jerk for jt in JERK3R.joints])
    jerk = np.zeros_like(q)
    jerk[1:] = np.abs(np.diff(np.concatenate([q[:1], q[:1], q]), 3, axis=0)) * 100**3
    with pytest.raises((VelocityLimitError, AccelerationLimitError, JerkLimitError)) as info:
        plan(JERK3R, wps, duration=0.3, rate_hz=100, profile=profile)
    err = info.value
    assert err.field == "duration" and err.joint in ARM3R.joint_names
    assert f"sample {err.sample} " in str(err) and "rad/s" in str(err)
    if profile == "quintic":
        first_v = first_bad_row(vel > v) if (vel > v).any() else len(q)
        first_a = first_bad_row(acc > a) if (acc > a).any() else len(q)
        first_j = first_bad_row(jerk > j) if (jerk > j).any() else len(q)
        expected = min(first_v, first_a, first_j)
        assert err.sample == expected
        kind = (VelocityLimitError if first_v == expected else
                AccelerationLimitError if first_a == expected else JerkLimitError)
        assert isinstance(err, kind)
        np.testing.assert_allclose(err.pose, loose.poses[expected], atol=1e-12)


# -- auto timing --------------------------------------------------------------------------------

@pytest.mark.parametrize(("arm", "waypoints"), [(JERK3R, WAYPOINTS_3R[:2]),
                                                (JERK2R, WAYPOINTS_2R[:2])], ids=["3r", "2r"])
@pytest.mark.parametrize("profile", timing.UNIFORM_PROFILES)
def test_auto_is_feasible_and_minimal(arm: Arm, waypoints: Any, profile: str) -> None:
    """With the recommended jerk limits too: auto passes, the plan re-run with its own duration
    is the same plan, and one period less fails — for the quintic (smooth: jerk ∝ 1/T³)
    under the jerk limit; the linear and trapezoid laws step in velocity/acceleration, so
    their sampled jerk is not monotone in T (timing docstring) and their minimality is
    checked without a jerk limit."""
    assert all(j.max_jerk is not None for j in arm.joints)
    rate = 500
    for a in (arm, _jerk(arm, None)):
        traj = plan(a, waypoints, profile=profile, rate_hz=rate)
        check_trajectory(traj, a, waypoints)
        assert fd_ratio(traj, a) <= 1 + 1e-9
        total = traj.duration
        assert total * rate > 100  # so that 0.99·T drops at least one sample period
        again = plan(a, waypoints, profile=profile, rate_hz=rate, duration=total)
        np.testing.assert_allclose(again.joints, traj.joints, atol=1e-12)
        if profile == "quintic" or a is not arm:
            with pytest.raises((VelocityLimitError, AccelerationLimitError, JerkLimitError)):
                plan(a, waypoints, profile=profile, rate_hz=rate, duration=0.99 * total)


def test_linear_profile_starts_from_rest() -> None:
    """The velocity step at t = 0 is an acceleration from a standing arm, named at sample 1."""
    wps = WAYPOINTS_3R[:2]
    rate = 100
    auto = plan(ARM3R, wps, profile="linear", rate_hz=rate)
    check_trajectory(auto, ARM3R, wps)
    # A duration whose constant velocity is within every limit but whose first step is not:
    q = auto.joints
    a = np.array([j.max_acceleration for j in ARM3R.joints])
    v = np.array([j.max_velocity for j in ARM3R.joints])
    travel = np.abs(q[-1] - q[0])
    fast = float(np.max(travel / v)) * 1.2  # about 80 % of the velocity limit
    first_step = travel / (fast * rate)
    assert (first_step * rate**2 > a).any()  # the premise of the test
    with pytest.raises(AccelerationLimitError) as info:
        plan(ARM3R, wps, profile="linear", rate_hz=rate, duration=fast)
    assert info.value.sample == 1


def test_auto_blended_is_minimal() -> None:
    rate = 500
    traj = plan(ARM3R, WAYPOINTS_3R, profile="quintic", blend=True, rate_hz=rate)
    check_trajectory(traj, ARM3R, WAYPOINTS_3R)
    with pytest.raises((VelocityLimitError, AccelerationLimitError, JerkLimitError)):
        plan(ARM3R, WAYPOINTS_3R, profile="quintic", blend=True, rate_hz=rate,
             duration=0.99 * traj.duration)


def test_auto_closed_form_matches_the_search() -> None:
    """At a high rate the finite-difference auto duration tends to the closed form, with the
    jerk term ∛(max|d³q/dτ³| / j) where the arm sets jerk limits (and without them)."""
    wps = WAYPOINTS_3R[:2]
    dense = 20000
    tau = np.arange(dense + 1) / dense
    poses = interpolate(wps[0], wps[1], timing.quintic(tau))
    q = kinematics.ik_path(ARM3R.links, poses, elbow=ARM3R.elbow)
    d1 = np.gradient(q, tau, axis=0)
    d2 = np.gradient(d1, tau, axis=0)
    d3 = np.gradient(d2, tau, axis=0)
    v = [j.max_velocity for j in ARM3R.joints]
    a = [j.max_acceleration for j in ARM3R.joints]
    jerk = [j.max_jerk for j in JERK3R.joints]
    closed = timing.auto_duration(d1, d2, v, a, d3, jerk)
    free = timing.auto_duration(d1, d2, v, a)
    assert closed > free  # the jerk limit binds on this move
    assert plan(JERK3R, wps, profile="quintic", rate_hz=1000).duration == pytest.approx(
        closed, rel=5e-3)
    assert plan(ARM3R, wps, profile="quintic", rate_hz=1000).duration == \
        pytest.approx(free, rel=5e-3)


# -- blending -----------------------------------------------------------------------------------

def max_velocity_jump(traj: Trajectory) -> float:
    v = np.diff(traj.poses[:, :2], axis=0) * traj.rate_hz
    return float(np.linalg.norm(np.diff(v, axis=0), axis=1).max())


def test_blended_via_points_have_continuous_velocity() -> None:
    corner = [[0.25, 0.0, 0.0], [0.25, 0.2, 0.5], [0.05, 0.25, 1.0]]
    slow = [plan(ARM3R, corner, profile="quintic", blend=True, duration=3.0, rate_hz=r)
            for r in (100, 1000)]
    # continuous velocity: the largest step in velocity shrinks with the sample period
    assert max_velocity_jump(slow[1]) < 0.2 * max_velocity_jump(slow[0])
    traj = slow[1]
    dist = np.linalg.norm(traj.poses[:, :2] - corner[1][:2], axis=1)
    at = int(np.argmin(dist))
    speed = np.linalg.norm(np.diff(traj.poses[:, :2], axis=0), axis=1) * traj.rate_hz
    assert dist[at] <= speed.max() / traj.rate_hz  # passes through the via point
    assert speed[at] > 0.3 * speed.max()  # without stopping there
    stop = plan(ARM3R, corner, blend=False, duration=3.0, rate_hz=1000)
    stop_speed = np.linalg.norm(np.diff(stop.poses[:, :2], axis=0), axis=1) * 1000
    at_stop = int(np.argmin(np.linalg.norm(stop.poses[:, :2] - corner[1][:2], axis=1)))
    assert stop_speed[at_stop] < 1e-3 * stop_speed.max()


# -- approach -----------------------------------------------------------------------------------

def test_approach_segment_from_present_joints() -> None:
    present = np.array([0.1, -0.3, 0.2])
    traj = plan(ARM3R, WAYPOINTS_3R, start_joints=present, rate_hz=200)
    check_trajectory(traj, ARM3R, WAYPOINTS_3R, approach=True)
    np.testing.assert_array_equal(traj.joints[0], present)
    check_steps = np.abs(np.diff(traj.joints, axis=0)).max()
    assert check_steps * 200 <= max(j.max_velocity for j in ARM3R.joints)
    # the path proper starts where the approach ends
    direct = plan(ARM3R, WAYPOINTS_3R, rate_hz=200)
    assert traj.t.shape[0] > direct.t.shape[0]
    hit = np.flatnonzero(np.linalg.norm(traj.poses - WAYPOINTS_3R[0], axis=1) < 1e-12)
    assert hit.size and hit[0] > 0
    np.testing.assert_allclose(traj.joints[hit[0]:], direct.joints, atol=1e-9)
    # the approach is data: its length, in samples and seconds, survives JSON
    assert traj.approach_samples == hit[0] and direct.approach_samples == 0
    assert traj.approach_duration == pytest.approx(hit[0] / 200)
    assert Trajectory.from_json(traj.to_json()).approach_samples == hit[0]


def test_no_approach_when_already_there_and_replan() -> None:
    direct = plan(ARM3R, WAYPOINTS_3R, rate_hz=100)
    same = plan(ARM3R, WAYPOINTS_3R, rate_hz=100, start_joints=direct.joints[0] + 1e-5)
    assert same.t.shape == direct.t.shape and same.approach_samples == 0
    # the streamer's re-plan: same request, new present joints
    again = plan_request(dataclasses.replace(direct.request,
                                             start_joints=tuple(direct.joints[0] - 0.2)))
    np.testing.assert_allclose(again.joints[0], direct.joints[0] - 0.2, atol=1e-15)
    np.testing.assert_allclose(again.joints[-1], direct.joints[-1], atol=1e-9)


def test_approach_turns_the_long_way_inside_the_limits() -> None:
    """The nearest turn of the first pose's shoulder angle lies beyond the +170° limit, so
    the approach swings the shoulder the long way round instead of into the limit."""
    target = np.array([-2.9, -0.8, 0.5])
    pose = kinematics.fk(ARM3R.links, target[None])[0]
    wps = [pose, pose + np.array([0.0, 0.01, 0.0])]
    present = np.array([2.9, -0.8, 0.5])
    traj = plan(ARM3R, wps, start_joints=present, rate_hz=100)
    check_trajectory(traj, ARM3R, wps, approach=True)
    reached = np.flatnonzero(np.linalg.norm(traj.poses - pose, axis=1) < 1e-12)[0]
    np.testing.assert_allclose(traj.joints[reached], target, atol=1e-9)
    assert traj.joints[:, 0].max() == pytest.approx(2.9) and traj.joints[:, 0].min() < -2.8


def test_start_joints_pick_the_branch() -> None:
    direct = plan(ARM3R, WAYPOINTS_3R, rate_hz=100)  # the arm's preferred elbow: up
    down = kinematics.ik_branches(ARM3R.links, [WAYPOINTS_3R[0]])[1]
    traj = plan(ARM3R, WAYPOINTS_3R, rate_hz=100, start_joints=down[0])
    np.testing.assert_allclose(traj.joints[0], down[0], atol=1e-12)  # no approach needed
    assert (traj.joints[:, 1] >= 0).all() and (direct.joints[:, 1] <= 0).all()


# -- serialisation ------------------------------------------------------------------------------

def test_json_round_trip() -> None:
    traj = plan(ARM3R, WAYPOINTS_3R, method=["sclerp", "dlb"], blend=True, rate_hz=50,
                start_joints=[0.0, -1.0, 0.5])
    text = traj.to_json()
    data = json.loads(text)
    assert {"t", "poses", "joints", "ticks", "joint_names", "servo_ids", "rate_hz",
            "method"} <= set(data)
    back = Trajectory.from_json(text)
    for name in ("t", "poses", "joints", "ticks"):
        np.testing.assert_array_equal(getattr(back, name), getattr(traj, name))
    assert back.ticks.dtype == np.int64
    assert (back.joint_names, back.servo_ids, back.rate_hz, back.method) == (
        traj.joint_names, traj.servo_ids, traj.rate_hz, traj.method)
    assert back.request == traj.request
    with_arm = Trajectory.from_json(text, arm=ARM3R)
    assert with_arm.request.arm is ARM3R
    # the rebuilt request plans the same trajectory
    np.testing.assert_array_equal(plan_request(back.request).joints, traj.joints)


@pytest.mark.parametrize(("edit", "field"), [
    (lambda d: d.pop("ticks"), "ticks"),
    (lambda d: d.__setitem__("poses", [p[:2] for p in d["poses"]]), "poses"),
    (lambda d: d.__setitem__("joints", d["joints"][:-1]), "joints"),
    (lambda d: d.__setitem__("t", [x * 2 for x in d["t"]]), "t"),
    (lambda d: d.__setitem__("servo_ids", [1]), "servo_ids"),
    (lambda d: d.__setitem__("rate_hz", 0), "rate_hz"),
])
def test_from_json_checks_shapes(edit: Any, field: str) -> None:
    data = json.loads(plan(ARM3R, WAYPOINTS_3R[:2], rate_hz=50).to_json())
    data["request"] = None
    edit(data)
    with pytest.raises(InputError) as info:
        Trajectory.from_json(json.dumps(data))
    assert info.value.field == field


def test_csv_matches_the_arrays() -> None:
    traj = plan(ARM2R, WAYPOINTS_2R, rate_hz=50)
    rows = list(csv.reader(io.StringIO(traj.to_csv())))
    assert rows[0] == ["t", "x", "y", "theta", "q_shoulder", "q_elbow", "tick_1", "tick_2"]
    body = np.array(rows[1:], dtype=float)
    np.testing.assert_array_equal(body[:, 0], traj.t)
    np.testing.assert_array_equal(body[:, 1:4], traj.poses)
    np.testing.assert_array_equal(body[:, 4:6], traj.joints)
    np.testing.assert_array_equal(body[:, 6:], traj.ticks)


# -- input errors -------------------------------------------------------------------------------

@pytest.mark.parametrize(("kwargs", "field"), [
    ({"waypoints": [[0.25, 0.1, 0.0]]}, "waypoints"),
    ({"waypoints": [[0.25, 0.1], [0.2, 0.1]]}, "waypoints[0]"),
    ({"waypoints": [[0.25, 0.1, 0.0], [0.2, math.nan, 0.0]]}, "waypoints[1][1]"),
    ({"method": "cubic"}, "method"),
    ({"method": ["sclerp"]}, "method"),
    ({"turn": ["shortest", "left"]}, "turn[1]"),
    ({"beta": math.inf}, "beta"),
    ({"rate_hz": 0.5}, "rate_hz"),
    ({"rate_hz": 1001}, "rate_hz"),
    ({"duration": -1.0}, "duration"),
    ({"duration": "fast"}, "duration"),
    ({"duration": 2000.0, "rate_hz": 1000}, "duration"),
    ({"duration": 0.01, "rate_hz": 100}, "duration"),
    ({"profile": "cubic"}, "profile"),
    ({"blend": "yes"}, "blend"),
    ({"start_joints": [0.0, 0.0]}, "start_joints"),
])
def test_bad_requests_name_the_field(kwargs: dict[str, Any], field: str) -> None:
    args = {"waypoints": WAYPOINTS_3R, **kwargs}
    with pytest.raises(InputError) as info:
        plan(ARM3R, **args)
    assert info.value.field == field
    assert not isinstance(info.value, PlanError)


def test_auto_plan_over_the_sample_limit_is_an_input_error() -> None:
    crawl = variant(ARM3R, max_velocity=1e-3, max_acceleration=1e-3)
    with pytest.raises(InputError) as info:
        plan(crawl, WAYPOINTS_3R[:2], profile="quintic", rate_hz=1000)
    assert info.value.field == "duration"


def test_request_is_immutable_and_normalised() -> None:
    req = PlanRequest(arm=ARM3R, waypoints=np.array(WAYPOINTS_3R), method=["sclerp", "dlb"],
                      rate_hz=100)
    assert req.waypoints == tuple(tuple(w) for w in WAYPOINTS_3R)
    assert req.method == ("sclerp", "dlb")
    with pytest.raises(dataclasses.FrozenInstanceError):
        req.rate_hz = 5  # type: ignore[misc]
    assert PlanRequest.from_dict(json.loads(json.dumps(req.to_dict()))) == req


# -- property: any reachable request either plans cleanly or fails with a PlanError -------------

@pytest.mark.parametrize("arm", [ARM3R, ARM2R], ids=["3r", "2r"])
@given(data=st.data())
@settings(max_examples=40, deadline=None)
def test_random_requests_plan_or_fail_cleanly(arm: Arm, data: st.DataObject) -> None:
    m = data.draw(st.integers(2, 4), label="waypoints")
    limits = [(j.min_angle * 0.9, j.max_angle * 0.9) for j in arm.joints]
    q = np.array([[data.draw(st.floats(lo, hi)) for lo, hi in limits] for _ in range(m)])
    # Waypoints on the straight/folded elbow make the linear profile's auto time grow with
    # the rate (a √ singularity met at speed): keep the elbow bent for a fast test.
    q[:, 1] = np.sign(q[:, 1] + 1e-300) * np.clip(np.abs(q[:, 1]), 0.2, 2.5)
    wps = kinematics.fk(arm.links, q)
    kwargs = {
        "method": data.draw(st.sampled_from(["sclerp", "kenlerp", "seplerp", "dlb"])),
        "beta": data.draw(st.floats(0.0, 2.0)),
        "profile": data.draw(st.sampled_from(timing.PROFILES)),
        "blend": data.draw(st.booleans()),
        "rate_hz": data.draw(st.sampled_from([20, 100, 250])),
        "duration": data.draw(st.one_of(st.just("auto"), st.floats(0.5, 5.0))),
    }
    if data.draw(st.booleans(), label="start_joints"):
        kwargs["start_joints"] = [data.draw(st.floats(lo, hi)) for lo, hi in limits]
    try:
        traj = plan(arm, wps, **kwargs)
    except PlanError as err:
        assert err.sample is None or 0 <= err.sample < 10**6
        assert str(err)
        if kwargs["duration"] == "auto":
            # auto never fails on the limits it chose the duration for
            assert not isinstance(err, VelocityLimitError | AccelerationLimitError)
        return
    except InputError as err:  # only the 10⁶-sample cap may refuse a well-formed request
        assert err.field == "duration" and "more than 1000000" in str(err)
        return
    check_trajectory(traj, arm, wps, approach="start_joints" in kwargs)


# -- issue 9: θ on a position-only arm, the elbow at a singular start, violations as data -----

def test_theta_plays_no_part_on_a_2r_arm() -> None:
    """Path, duration and feasibility of a 2R plan do not depend on the θ given."""
    base = plan(ARM2R, WAYPOINTS_2R)
    for thetas in ([0.0, 3.0, -2.0], [1.5, 1.5, 1.5], [0.0, -3.1, 3.1]):
        wps = [[x, y, th] for (x, y, _), th in zip(WAYPOINTS_2R, thetas, strict=True)]
        other = plan(ARM2R, wps, method="kenlerp", beta=0.3)
        assert other.duration == base.duration
        np.testing.assert_allclose(other.joints, base.joints, atol=1e-12)
    # the position path is the straight line between the waypoints
    n = int(np.argmin(np.linalg.norm(base.poses[:, :2] - WAYPOINTS_2R[1][:2], axis=1))) + 1
    assert n > 10
    d = np.diff(base.poses[:n, :2], axis=0)
    r = base.poses[1:n, :2] - base.poses[0, :2]
    # the optimal law's joints are the C² interpolant of its dense IK samples (planner.optimal)
    # and the poses their FK: off the line by interpolation error only (~1e-10 m)
    np.testing.assert_allclose(d[:, 0] * r[:, 1] - d[:, 1] * r[:, 0], 0.0, atol=1e-10)
    # θ reported is the arm's own (FK), as the simulator would read it back
    fk = kinematics.fk(ARM2R.links, base.joints)
    np.testing.assert_allclose(base.poses[:, 2], fk[:, 2], atol=1e-12)


def test_2r_waypoints_may_be_positions() -> None:
    xy = [w[:2] for w in WAYPOINTS_2R]
    a = plan(ARM2R, xy)
    b = plan(ARM2R, WAYPOINTS_2R)
    np.testing.assert_array_equal(a.joints, b.joints)
    with pytest.raises(InputError) as info:
        plan(ARM3R, [w[:2] for w in WAYPOINTS_3R])
    assert info.value.field == "waypoints[0]"


def test_2r_plan_from_home_pose_equals_plan_from_home_joints() -> None:
    """``plan`` starts from the home pose, ``sim`` from the FK of the home joints: the same."""
    home_joints = kinematics.ik(ARM2R.links, [ARM2R.home], elbow=ARM2R.elbow)[0]
    start_pose = kinematics.fk(ARM2R.links, [home_joints])[0]
    target = [0.05, 0.2, 1.0]
    from_pose = plan(ARM2R, [list(ARM2R.home), target])
    from_joints = plan(ARM2R, [start_pose, target], start_joints=home_joints)
    assert from_pose.duration == from_joints.duration
    np.testing.assert_allclose(from_pose.joints, from_joints.joints, atol=1e-9)


STRETCHED = [[0.4, 0.0, 0.0], [0.12, 0.24, math.radians(60)]]


@pytest.mark.parametrize("start", [None, [0.0, 0.0, 0.0]], ids=["pose", "fresh-sim-joints"])
def test_configured_elbow_breaks_the_tie_at_a_stretched_start(start: Any) -> None:
    up = plan(ARM3R, STRETCHED, start_joints=start)
    assert ARM3R.elbow == "up"
    assert (up.joints[1:, 1] < 0).all() and up.elbow is None and up.branch_switches == ()
    down = plan(ARM3R, STRETCHED, start_joints=start, elbow="down")
    assert (down.joints[1:, 1] > 0).all()
    check_trajectory(down, ARM3R, STRETCHED)


def test_elbow_request_picks_the_branch() -> None:
    for elbow, sign in (("up", -1), ("down", 1)):
        traj = plan(ARM3R, WAYPOINTS_3R, elbow=elbow)
        assert traj.elbow == elbow and (sign * traj.joints[:, 1] > 0).all()
        assert traj.request.elbow == elbow
        assert Trajectory.from_json(traj.to_json()).elbow == elbow


def test_branch_switch_is_reported() -> None:
    """Through the stretched-out pose (radius out to full reach and back, the path
    continuing past it) the branch may change: it is data and a warning, never silent."""
    from robodcn.planner import validate

    q = np.column_stack([np.zeros(5), [-0.2, -0.1, 0.0, 0.1, 0.2], np.zeros(5)])
    assert validate.elbow_branches(q) == ("up", (3,))
    assert validate.elbow_branches(q[:3]) == ("up", ())
    assert validate.elbow_branches(q[2:]) == (None, ())


def test_violation_is_data_and_names_segment_and_branch() -> None:
    free = plan(ARM3R, WAYPOINTS_3R, profile="quintic", duration=3.0, rate_hz=100)
    # a shoulder limit the path crosses in its second segment only
    limit = float(np.abs(free.joints[:, 0]).max()) * 0.97
    narrow = variant(ARM3R, only=0, min=-limit, max=limit)
    with pytest.raises(JointLimitError) as info:
        plan(narrow, WAYPOINTS_3R, profile="quintic", duration=3.0, rate_hz=100)
    v = info.value.violation
    assert v is not None and v.quantity == "position" and v.joint == "shoulder"
    assert v.joint_index == 0 and v.unit == "rad"
    assert abs(v.limit) == pytest.approx(limit) and abs(v.value) > limit
    assert v.sample == info.value.sample and v.t == pytest.approx(v.sample / 100)
    assert v.segment is not None and v.segment[1] == v.segment[0] + 1
    bad = np.abs(free.joints[:, 0]) > limit
    assert v.sample == first_bad_row(bad[:, None])
    assert isinstance(v.other_branch_ok, bool)
    assert "segment waypoint" in str(info.value) and "elbow branch" in str(info.value)


def test_auto_timing_reads_violations_not_exceptions(monkeypatch: pytest.MonkeyPatch) -> None:
    """The linear profile's velocity steps at the joins are fixed by reading the Violation
    the validation returns; no PlanError is raised and caught on the way."""
    from robodcn import errors

    raised: list[str] = []
    original = errors.PlanError.__init__

    def spy(self: Any, *args: Any, **kwargs: Any) -> None:
        raised.append(type(self).__name__)
        original(self, *args, **kwargs)

    monkeypatch.setattr(errors.PlanError, "__init__", spy)
    traj = plan(ARM3R, WAYPOINTS_3R, profile="linear")
    check_trajectory(traj, ARM3R, WAYPOINTS_3R)
    assert raised == []


@pytest.mark.parametrize(("kwargs", "field", "cls"), [
    ({"duration": 1e308}, "duration", InputError),
    ({"duration": 1e5, "rate_hz": 1000}, "duration", robodcn.TooLargeError
     if hasattr(robodcn, "TooLargeError") else InputError),
    ({"start_joints": [0.0, 3.0, 0.0]}, "start_joints[1]", InputError),
    ({"start_joints": [1e308, 0.0, 0.0]}, "start_joints[0]", InputError),
    ({"beta": -0.5, "method": "kenlerp"}, "beta", InputError),
])
def test_range_checks_before_planning(kwargs: dict[str, Any], field: str, cls: type) -> None:
    with pytest.raises(cls) as info:
        plan(ARM3R, WAYPOINTS_3R, **kwargs)
    assert info.value.field == field


def test_waypoint_cap_is_checked_first_and_names_waypoints() -> None:
    import time

    from robodcn.contract import MAX_WAYPOINTS
    from robodcn.errors import TooLargeError

    wps = np.tile(WAYPOINTS_3R[:2], (30_000, 1))
    t0 = time.perf_counter()
    with pytest.raises(TooLargeError) as info:
        plan(ARM3R, wps)
    assert time.perf_counter() - t0 < 1.0
    assert info.value.field == "waypoints" and str(MAX_WAYPOINTS) in str(info.value)


def test_beta_with_a_method_that_ignores_it_warns() -> None:
    from robodcn.errors import BetaIgnoredWarning

    with pytest.warns(BetaIgnoredWarning) as record:
        plan(ARM3R, WAYPOINTS_3R, method="sclerp", beta=0.5)
    assert record[0].message.field == "beta"
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", BetaIgnoredWarning)
        plan(ARM3R, WAYPOINTS_3R, method=["sclerp", "kenlerp"], beta=0.5)
        plan(ARM3R, WAYPOINTS_3R, method="sclerp")
        # β > 1 extrapolates past ScLERP (KenLERP's definition): allowed
        plan(ARM3R, WAYPOINTS_3R, method="kenlerp", beta=1.5)


def jerk_arm(jerk: float) -> Arm:
    data = ARM3R.to_dict()
    for joint in data["joints"]:
        joint["max_jerk"] = jerk
    return arm_from_dict(data, source=ARM3R.source)


def test_jerk_limit_is_respected_by_auto_timing_and_checked() -> None:
    free = plan(ARM3R, WAYPOINTS_3R[:2], profile="quintic")
    jerk3 = np.abs(np.diff(np.concatenate([free.joints[:1]] * 2 + [free.joints]
                                          + [free.joints[-1:]] * 2), 3, axis=0)).max()
    limit = 0.5 * jerk3 * free.rate_hz**3
    arm = jerk_arm(limit)
    slow = plan(arm, WAYPOINTS_3R[:2], profile="quintic")
    assert slow.duration > free.duration
    q = np.concatenate([slow.joints[:1]] * 3 + [slow.joints] + [slow.joints[-1:]] * 2)
    assert (np.abs(np.diff(q, 3, axis=0)) * slow.rate_hz**3 <= limit * (1 + 1e-9)).all()
    from robodcn.errors import JerkLimitError

    with pytest.raises(JerkLimitError) as info:
        plan(arm, WAYPOINTS_3R[:2], profile="quintic", duration=free.duration)
    v = info.value.violation
    assert v.quantity == "jerk" and v.unit == "rad/s^3" and v.value > v.limit == limit
    assert info.value.field == "duration"


def test_joint_limit_error_says_the_other_branch_would_pass() -> None:
    # the elbow may only bend "down" (q2 ≥ −0.05): the configured "up" branch fails
    arm = variant(ARM3R, only=1, min=-0.05, max=2.8)
    with pytest.raises(JointLimitError) as info:
        plan(arm, WAYPOINTS_3R, profile="quintic")
    v = info.value.violation
    assert v.joint == "elbow" and v.other_branch_ok is True and v.sample == 0
    assert v.waypoint == 0 and info.value.field == "waypoints[0]"
    assert "other elbow branch would pass" in str(info.value)
    traj = plan(arm, WAYPOINTS_3R, profile="quintic", elbow="down")
    check_trajectory(traj, arm, WAYPOINTS_3R)


def test_issue_command_ends_elbow_up() -> None:
    """``robodcn plan --from 0.4,0,0 --to 0.12,0.24,60`` on arm3r (elbow = "up")."""
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-m", "robodcn", "plan", "--arm",
                          str(CONFIGS / "arm3r.toml"), "--from", "0.4,0,0", "--to",
                          "0.12,0.24,60", "--format", "json"], capture_output=True, text=True,
                         check=True, timeout=60)
    joints = np.array(json.loads(out.stdout)["joints"])
    assert (joints[1:, 1] < 0).all()


# -- issue 10: profile "optimal" (time-optimal, jerk-limited) and planning from a moving start ----

ISSUE_VIAS = [[0.25, 0.10, 0.0], [0.2, 0.15, math.radians(20)], [0.15, 0.2, math.radians(40)],
              [0.12, 0.24, math.radians(60)], [0.05, 0.25, math.radians(80)]]


def fd_ratio(traj: Trajectory, arm: Arm, history: np.ndarray | None = None) -> float:
    """Worst finite-difference velocity/acceleration/jerk over its limit (rest or history
    before, rest after), computed here from the samples."""
    q = traj.joints
    worst = 0.0
    for order, limit in ((1, [j.max_velocity for j in arm.joints]),
                         (2, [j.max_acceleration for j in arm.joints]),
                         (3, [j.max_jerk or math.inf for j in arm.joints])):
        pre = np.repeat(q[:1], order, axis=0) if history is None else history[-order:]
        p = np.concatenate([pre, q, np.repeat(q[-1:], order, axis=0)])
        d = np.abs(np.diff(p, order, axis=0)) * traj.rate_hz ** order
        worst = max(worst, float((d / np.asarray(limit)).max()))
    return worst


def test_optimal_is_the_default_profile() -> None:
    assert PlanRequest(arm=ARM3R, waypoints=WAYPOINTS_3R).profile == "optimal"
    assert timing.PROFILES[0] == "optimal" and set(timing.UNIFORM_PROFILES) < set(
        timing.PROFILES)


@pytest.mark.parametrize("per_accel", [None, 20.0], ids=["no-jerk", "jerk"])
@pytest.mark.parametrize("blend", [False, True])
@pytest.mark.parametrize(("arm", "waypoints"), [(ARM3R, ISSUE_VIAS), (ARM2R, WAYPOINTS_2R)],
                         ids=["arm3r", "arm2r"])
def test_optimal_keeps_every_limit_and_beats_quintic(arm: Arm, waypoints: Any, blend: bool,
                                                     per_accel: float | None) -> None:
    a = _jerk(arm, per_accel)
    traj = plan(a, waypoints, blend=blend, rate_hz=1000)
    check_trajectory(traj, a, waypoints)
    assert fd_ratio(traj, a) <= 1 + 1e-9
    quintic = plan(a, waypoints, blend=blend, rate_hz=1000, profile="quintic")
    assert traj.duration <= quintic.duration


@pytest.mark.parametrize("per_accel", [None, 20.0], ids=["no-jerk", "jerk"])
def test_blend_is_never_slower_than_stopping(per_accel: float | None) -> None:
    """The issue's example: through three vias blended vs stopping at each."""
    a = _jerk(ARM3R, per_accel)
    stop = plan(a, ISSUE_VIAS, rate_hz=1000)
    blend = plan(a, ISSUE_VIAS, blend=True, rate_hz=1000)
    assert blend.duration <= stop.duration
    # stopping: a sample sits on every via, at rest (the steps either side are at most an
    # acceleration from rest within its limit: |Δq| ≤ a Δt²)
    acc = np.array([j.max_acceleration for j in a.joints])
    for via in ISSUE_VIAS[1:-1]:
        i = int(np.argmin(np.linalg.norm(stop.poses[:, :2] - via[:2], axis=1)))
        np.testing.assert_allclose(stop.poses[i, :2], via[:2], atol=1e-9)
        for step in (stop.joints[i + 1] - stop.joints[i], stop.joints[i] - stop.joints[i - 1]):
            assert (np.abs(step) <= acc / 1000 ** 2 * (1 + 1e-9)).all()
    # blending: the arm never rests in between
    speed = np.abs(np.diff(blend.joints, axis=0)).max(axis=1)
    assert speed[5:-5].min() > 0


def test_optimal_is_within_two_percent_of_toppra() -> None:
    toppra = pytest.importorskip("toppra")  # the bench extra
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    from robodcn.planner import optimal

    toppra.setup_logging("WARNING")
    free = _jerk(ARM3R, None)
    for waypoints, blend in ((ISSUE_VIAS[:2], False), (ISSUE_VIAS, False), (ISSUE_VIAS, True)):
        traj = plan(free, waypoints, blend=blend, rate_hz=1000)
        v = np.array([j.max_velocity for j in free.joints])
        acc = np.array([j.max_acceleration for j in free.joints])
        pieces, _ = optimal.build_pieces(traj.request)
        ref = 0.0
        for piece in pieces:
            path = toppra.SplineInterpolator(piece.s, piece.q)
            solved = algo.TOPPRA([constraint.JointVelocityConstraint(v),
                                  constraint.JointAccelerationConstraint(acc)], path,
                                 parametrizer="ParametrizeConstAccel").compute_trajectory(0, 0)
            ref += solved.duration
        assert traj.duration <= 1.02 * ref
        assert traj.duration >= 0.98 * ref  # and not faster than the optimum: same problem


def test_fixed_duration_stretches_the_optimal_law() -> None:
    free = _jerk(ARM3R, None)
    auto = plan(free, ISSUE_VIAS, rate_hz=100)
    slow = plan(free, ISSUE_VIAS, rate_hz=100, duration=2.5)
    assert slow.duration == pytest.approx(2.5)
    check_trajectory(slow, free, ISSUE_VIAS)
    # the same path: every auto pose lies on the slow plan's poses (a stretch, not a new path)
    d = np.linalg.norm(auto.poses[:, None, :2] - slow.poses[None, :, :2], axis=2).min(axis=1)
    assert d.max() < 0.01
    # shorter than the optimum: compressed, and the first sample past a limit is named
    with pytest.raises((VelocityLimitError, AccelerationLimitError)) as info:
        plan(free, ISSUE_VIAS, rate_hz=100, duration=0.5 * auto.duration)
    assert info.value.field == "duration" and info.value.sample > 0


def _moving_state(arm: Arm, at: float = 0.4) -> tuple[Trajectory, int, robodcn.StartState]:
    run = plan(arm, ISSUE_VIAS[:1] + ISSUE_VIAS[-1:], rate_hz=1000)
    i = int(at * run.t.shape[0])
    q = run.joints
    state = robodcn.StartState(q[i], (q[i + 1] - q[i - 1]) * 500.0,
                               (q[i + 1] - 2 * q[i] + q[i - 1]) * 1e6)
    return run, i, state


@pytest.mark.parametrize("goal", [ISSUE_VIAS[-1], [0.0, 0.28, 1.9], [0.22, 0.05, -0.3]],
                         ids=["same-goal", "further", "back"])
def test_moving_start_is_matched_and_within_limits(goal: list[float]) -> None:
    free = _jerk(ARM3R, None)
    run, i, state = _moving_state(free)
    here = [float(x) for x in run.poses[i]]
    traj = plan(free, [here, goal], rate_hz=1000, start_state=state)
    assert traj.start_state == state
    np.testing.assert_array_equal(traj.joints[0], state.joints)
    q0, v0, a0 = state.arrays()
    from robodcn.planner.validate import start_history

    history = start_history(q0, v0, a0, 1000.0)
    assert fd_ratio(traj, free, history) <= 1 + 1e-9
    # velocity continuous across the start: the first step is v0 Δt within one sample of
    # maximum acceleration
    a = np.array([j.max_acceleration for j in free.joints])
    step = (traj.joints[1] - traj.joints[0]) * 1000 - v0
    assert (np.abs(step) <= a / 1000 * (1 + 1e-9)).all()
    np.testing.assert_allclose(traj.poses[-1, :2], goal[:2], atol=1e-9)
    if goal is ISSUE_VIAS[-1]:
        # retargeting to the goal it was heading for: no slower than the rest of that move
        assert traj.duration <= run.duration - i / 1000 + 2e-3


def test_start_state_rules_and_json() -> None:
    free = _jerk(ARM3R, None)
    run, i, state = _moving_state(free)
    here = [float(x) for x in run.poses[i]]
    with pytest.raises(InputError) as info:
        plan(free, [here, ISSUE_VIAS[-1]], rate_hz=1000, start_state=state, duration=3.0)
    assert info.value.field == "duration"
    with pytest.raises(InputError) as info:
        plan(free, [here, ISSUE_VIAS[-1]], rate_hz=1000, start_state=state, profile="quintic")
    assert info.value.field == "start_state"
    with pytest.raises(InputError) as info:
        plan(free, [here, ISSUE_VIAS[-1]], start_state=state, start_joints=state.joints)
    assert info.value.field == "start_state"
    too_fast = robodcn.StartState(state.joints, [10.0, 0.0, 0.0])
    with pytest.raises(InputError) as info:
        plan(free, [here, ISSUE_VIAS[-1]], start_state=too_fast)
    assert info.value.field == "start_state.velocities[0]"
    traj = plan(free, [here, ISSUE_VIAS[-1]], rate_hz=1000, start_state=state)
    back = Trajectory.from_json(traj.to_json(), free)
    assert back.start_state == traj.start_state
    np.testing.assert_array_equal(back.joints, traj.joints)
    # a body gives it as an object
    from robodcn import contract

    req = contract.parse_request({"waypoints": [here, ISSUE_VIAS[-1]], "rate_hz": 1000,
                                  "start_state": state.to_dict()}, free)
    assert req.start_state == state


def test_moving_start_from_a_pose_off_the_first_waypoint_goes_there_first() -> None:
    """With a start state the path runs from FK(joints) through every waypoint."""
    free = _jerk(ARM3R, None)
    _, _, state = _moving_state(free)
    traj = plan(free, [ISSUE_VIAS[2], ISSUE_VIAS[-1]], rate_hz=1000, start_state=state)
    d = np.linalg.norm(traj.poses[:, :2] - ISSUE_VIAS[2][:2], axis=1)
    assert d.min() < 1e-9  # stops there (no blend) and goes on
    np.testing.assert_allclose(traj.poses[-1, :2], ISSUE_VIAS[-1][:2], atol=1e-9)


@pytest.mark.parametrize("goal", [ISSUE_VIAS[-1], [0.22, 0.05, -0.3]], ids=["same", "back"])
def test_moving_start_with_jerk_limits_keeps_every_limit(goal: list[float]) -> None:
    arm = _jerk(ARM3R, 20.0)
    run, i, state = _moving_state(arm)
    here = [float(x) for x in run.poses[i]]
    traj = plan(arm, [here, goal], rate_hz=1000, start_state=state)
    np.testing.assert_array_equal(traj.joints[0], state.joints)
    from robodcn.planner.validate import start_history

    history = start_history(*state.arrays(), 1000.0)
    assert fd_ratio(traj, arm, history) <= 1 + 1e-9
    np.testing.assert_allclose(traj.poses[-1, :2], goal[:2], atol=1e-9)


def test_blended_path_is_c2_through_every_via() -> None:
    """The blend's quintic corrections match dP/du and d²P/du² at every knot (finite jerk)."""
    from robodcn.planner.path import blended_path, segments_of

    req = PlanRequest(arm=ARM3R, waypoints=ISSUE_VIAS, blend=True)
    path = blended_path(req, segments_of(req), None)
    h = 1e-4
    for knot in path.knots[1:-1]:
        # one-sided second-order differences from each side of the knot
        left = path(knot - h * np.arange(4.0))
        right = path(knot + h * np.arange(4.0))
        d1_l = (3 * left[0] - 4 * left[1] + left[2]) / (2 * h)
        d1_r = (-3 * right[0] + 4 * right[1] - right[2]) / (2 * h)
        d2_l = (2 * left[0] - 5 * left[1] + 4 * left[2] - left[3]) / h ** 2
        d2_r = (2 * right[0] - 5 * right[1] + 4 * right[2] - right[3]) / h ** 2
        np.testing.assert_allclose(d1_l, d1_r, atol=1e-3 * max(1.0, np.abs(d1_l).max()))
        np.testing.assert_allclose(d2_l, d2_r, atol=1e-2 * max(1.0, np.abs(d2_l).max()))
        np.testing.assert_allclose(path(np.array([knot]))[0], ISSUE_VIAS[
            list(path.knots).index(knot)], atol=1e-12)


@pytest.mark.parametrize("goal", [[0.07, 0.30, math.radians(100)], [0.22, 0.05, -0.3]],
                         ids=["3cm-10deg-off", "back"])
@pytest.mark.parametrize("at", [0.2, 0.4, 0.6])
def test_retarget_to_another_goal_beats_braking_then_going(goal: list[float], at: float
                                                           ) -> None:
    """A retarget from a moving state is no slower than braking to rest along its velocity
    at the acceleration limits and then the from-rest optimal plan from there (the bound any
    decent retarget must beat; before, a goal 3 cm / 10° off took twice that), keeps every
    limit and starts at the given velocity."""
    free = _jerk(ARM3R, None)
    run, i, state = _moving_state(free, at)
    here = [float(x) for x in run.poses[i]]
    traj = plan(free, [here, goal], rate_hz=1000, start_state=state)
    q0, v0, a0 = state.arrays()
    from robodcn.planner.validate import start_history

    assert fd_ratio(traj, free, start_history(q0, v0, a0, 1000.0)) <= 1 + 1e-9
    a = np.array([j.max_acceleration for j in free.joints])
    step = (traj.joints[1] - traj.joints[0]) * 1000 - v0
    assert (np.abs(step) <= a / 1000 * (1 + 1e-9)).all()
    np.testing.assert_allclose(traj.poses[-1, :2], goal[:2], atol=1e-9)
    t0 = float(np.max(np.abs(v0) / (2 * a)))  # braking on the line q0 + v0 t: 2 t0 to rest
    q_stop = q0 + v0 * t0
    stop_pose = [float(x) for x in kinematics.fk(free.links, q_stop[None, :])[0]]
    go = plan(free, [stop_pose, goal], rate_hz=1000, start_joints=list(q_stop))
    assert traj.duration <= 1.02 * (2 * t0 + go.duration) + 2e-3


def _multi_waypoints(count: int, seed: int) -> list[list[list[float]]]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        wps = []
        for _ in range(int(rng.integers(3, 5))):
            r, a = rng.uniform(0.12, 0.36), rng.uniform(-2.5, 2.5)
            wps.append([r * math.cos(a), r * math.sin(a), rng.uniform(-2.0, 2.0)])
        out.append(wps)
    return out


@pytest.mark.parametrize("method", ["dlb", "sclerp"])
def test_blend_is_never_slower_than_stopping_on_random_paths(method: str) -> None:
    """Issue 17 §4: a blend took 1.024 s where stopping at the via took 1.014 s. Over many
    multi-waypoint paths (some where the blended curve alone is slower) blend ≤ stop."""
    planned = 0
    for wps in _multi_waypoints(120, seed=5):
        try:
            stop = plan(ARM3R, wps, method=method)
            blend = plan(ARM3R, wps, method=method, blend=True)
        except PlanError:
            continue
        planned += 1
        assert blend.duration <= stop.duration, wps
        check_trajectory(blend, ARM3R, wps)
    assert planned >= 8


@pytest.mark.parametrize("profile", ["quintic", "trapezoid", "linear"])
def test_uniform_blend_is_never_slower_than_stopping_on_random_dlb_paths(profile: str
                                                                          ) -> None:
    """Issue 17 §4 for the uniform laws: one law over the whole blended curve ran as slowly
    as its hardest stretch (blend slower than stop on 12 of 13 of these DLB paths with the
    quintic). Stopping at the vias is taken when it takes fewer periods; a blend that wins
    stays blended (not every plan turns into stops)."""
    planned = blended = 0
    for wps in _multi_waypoints(120, seed=5):
        try:
            stop = plan(ARM3R, wps, method="dlb", profile=profile)
            blend = plan(ARM3R, wps, method="dlb", profile=profile, blend=True)
        except PlanError:
            continue
        planned += 1
        assert blend.duration <= stop.duration, wps
        check_trajectory(blend, ARM3R, wps)
        blended += blend.duration < stop.duration
    assert planned >= 10
    if profile == "linear":  # its velocity steps at stops cost more than a blend's detour
        assert blended >= 1


def test_replan_from_the_end_of_a_brake_is_finite() -> None:
    """Issue 17 §7: a replace during a braking pause or stop (q̇ = 0 or nearly, q̈ at the
    limit) plans without a numpy warning or a non-finite sample (the brake from such a state,
    which divided by T₀ = 0, is test_path_timing's test_brake_without_velocity_is_no_brake)."""
    from robodcn.planner import StartState

    arm = ARM3R
    q0 = np.array([0.3, -1.0, 0.5])
    a = np.array([j.max_acceleration for j in arm.joints])
    here = kinematics.fk(arm.links, q0[None])[0].tolist()
    planned = 0
    for qd in ([0.0, 0.0, 0.0], [1e-13, 0.0, 0.0], [1e-300, -1e-300, 0.0]):
        for signs in ([-1, 1, 0], [1, 1, 1], [0, 0, 0]):
            state = StartState(tuple(q0), tuple(qd), tuple(0.99 * a * np.array(signs)))
            for goal in ([0.1, 0.25, 1.0], here):
                with np.errstate(divide="raise", invalid="raise", over="raise"), \
                        warnings.catch_warnings():
                    warnings.simplefilter("error", RuntimeWarning)
                    traj = plan(arm, [here, goal], start_state=state)
                assert np.isfinite(traj.joints).all()
                np.testing.assert_array_equal(traj.joints[0], q0)
                planned += 1
    assert planned == 18
