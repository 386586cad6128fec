"""Planning a yawed arm (issue 18 §1): the packaged OpenMANIPULATOR-X, waypoints (x, y, z,
pitch), the interpolation in the arm's plane with the yaw on the same path parameter, all
joints timed together, refusals naming the waypoint, the Trajectory JSON."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import robodcn
from robodcn import kinematics, timing
from robodcn.errors import InputError, UnreachableError, VelocityLimitError
from robodcn.interpolate import METHODS, interpolate
from robodcn.messages import describe
from robodcn.planner import StartState, Trajectory, plan

ARM = robodcn.load_arm("configs/omx.toml")
CHAIN = ARM.chain
HOME = list(ARM.home)
#: Reachable poses to the left and right of home, the tool pitched down.
LEFT = [0.20, 0.10, 0.15, math.radians(-30.0)]
RIGHT = [0.15, -0.12, 0.20, 0.0]
V_MAX = np.array([j.max_velocity for j in ARM.joints])


def plane_path(a, b, s, method="sclerp", beta=1.0):
    """The interpolated path between user poses a, b at path parameters s, computed here
    from the definition: ScLERP & co. on (r, z, pitch), the yaw linear in s."""
    pa, pb = kinematics.to_plane(np.array([a, b]))
    yaw1 = pa[0] + math.remainder(pb[0] - pa[0], 2 * math.pi)
    out = np.empty((s.shape[0], 4))
    out[:, 1:] = interpolate(pa[1:], pb[1:], s, method=method, beta=beta)
    out[:, 0] = pa[0] + s * (yaw1 - pa[0])
    return kinematics.from_plane(out)


@pytest.mark.parametrize("method", METHODS)
def test_every_method_plans_on_its_path_quintic(method: str) -> None:
    t = plan(ARM, [HOME, LEFT], method=method, beta=0.5, profile="quintic")
    assert t.poses.shape == (t.t.shape[0], 4) and t.pose_keys == ("x", "y", "z", "pitch")
    fk = kinematics.fk_yawed(CHAIN, t.joints)
    n = t.t.shape[0] - 1
    expected = plane_path(HOME, LEFT, timing.quintic(np.arange(n + 1) / n), method, 0.5)
    assert np.abs(fk - expected).max() < 1e-9  # the joints' FK lies on the path, sample by sample
    assert np.abs(t.poses - expected).max() < 1e-9
    assert np.abs(t.poses[-1] - LEFT).max() < 1e-12


@pytest.mark.parametrize("method", METHODS)
def test_every_method_plans_on_its_path_optimal(method: str) -> None:
    t = plan(ARM, [HOME, LEFT], method=method, beta=0.5)
    fk = kinematics.fk_yawed(CHAIN, t.joints)
    # the yaw is linear in the path parameter: it tells each sample's s
    yaw = t.joints[:, 0]
    s = (yaw - yaw[0]) / (yaw[-1] - yaw[0])
    assert np.all(np.diff(s) >= -1e-12) and s[0] == 0.0 and abs(s[-1] - 1.0) < 1e-12
    expected = plane_path(HOME, LEFT, s, method, 0.5)
    assert np.abs(fk - expected).max() < 1e-5
    assert np.abs(fk[-1] - LEFT).max() < 1e-9
    assert np.abs(t.poses - fk).max() < 1e-9


@pytest.mark.parametrize("profile", ["optimal", "quintic", "trapezoid"])
def test_yaw_and_chain_arrive_together_within_every_limit(profile: str) -> None:
    t = plan(ARM, [HOME, LEFT, RIGHT], profile=profile)
    end = kinematics.ik_yawed(CHAIN, np.array([RIGHT]))[0]
    assert np.abs(t.joints[-1] - end).max() < 1e-9
    speed = np.abs(np.diff(t.joints, axis=0)).max(axis=0) * t.rate_hz
    assert np.all(speed <= V_MAX * (1 + 1e-9))
    # every joint still moves until the last period: none arrives ahead of the others
    moving = np.abs(t.joints[-2] - t.joints[-1]) > 0.0
    assert moving.all()
    # the yaw moves at all (a real 3-D move) and leads the timing somewhere
    assert np.ptp(t.joints[:, 0]) > 0.5


def test_a_yaw_only_move_keeps_the_chain_still() -> None:
    turned = [HOME[0] * math.cos(1.0), HOME[0] * math.sin(1.0), HOME[2], HOME[3]]
    t = plan(ARM, [HOME, turned])
    assert np.ptp(t.joints[:, 1:], axis=0).max() < 1e-12
    assert t.joints[0, 0] == pytest.approx(0.0, abs=1e-12)
    assert t.joints[-1, 0] == pytest.approx(1.0, abs=1e-12)
    assert np.ptp(np.hypot(t.poses[:, 0], t.poses[:, 1])) < 1e-12  # r constant
    assert np.ptp(t.poses[:, 2:], axis=0).max() < 1e-12  # z and pitch constant
    # the yaw alone sets the time: its limits, not the chain's
    speed = np.abs(np.diff(t.joints[:, 0])).max() * t.rate_hz
    assert speed <= ARM.joints[0].max_velocity * (1 + 1e-9)
    assert speed > 0.5 * ARM.joints[0].max_velocity


def test_a_yaw_across_the_back_goes_round_inside_its_limits() -> None:
    def at(deg: float) -> list[float]:
        y = math.radians(deg)
        return [0.2 * math.cos(y), 0.2 * math.sin(y), 0.15, 0.0]

    # 170° → −170°: the short way passes ±180°, outside the yaw's ±3.14 rad
    t = plan(ARM, [at(170.0), at(-170.0)], profile="quintic")
    assert math.degrees(t.joints[0, 0]) == pytest.approx(170.0)
    assert math.degrees(t.joints[-1, 0]) == pytest.approx(-170.0)
    assert np.abs(t.joints[:, 0]).max() <= ARM.joints[0].max_angle


@pytest.mark.parametrize(("pose", "why"), [
    ([0.2, 0.0, 0.15, math.radians(120.0)], "over the base"),
    ([0.0, 0.0, 0.3, 0.0], "yaw axis"),
    ([0.5, 0.0, 0.1, 0.0], "out of reach"),
])
def test_a_pose_behind_the_base_is_refused_naming_the_waypoint(pose, why: str) -> None:
    with pytest.raises(UnreachableError) as info:
        plan(ARM, [HOME, LEFT, pose])
    err = info.value
    assert err.field == "waypoints[2]" and err.waypoint == 2
    assert why in str(err) and "waypoints[2]" in str(err) and "pitch=" in str(err)
    names = ["--from", "--via #1", "--to"]
    assert describe(err, "cli", names).endswith("(--to)")


def test_trajectory_json_round_trip() -> None:
    t = plan(ARM, [HOME, LEFT], payload_kg=0.2)
    for arm in (None, ARM):
        back = Trajectory.from_json(t.to_json(), arm)
        assert np.array_equal(back.poses, t.poses) and np.array_equal(back.ticks, t.ticks)
        assert back.pose_keys == ("x", "y", "z", "pitch")
        assert back.request.waypoints == t.request.waypoints
        assert back.request.payload_kg == 0.2
    data = t.to_dict()
    assert data["pose_keys"] == ["x", "y", "z", "pitch"] and len(data["poses"][0]) == 4
    assert t.to_csv().splitlines()[0].startswith("t_s,x_m,y_m,z_m,pitch_rad,q_yaw_rad,")
    planar = robodcn.load_arm("configs/arm3r.toml")
    with pytest.raises(InputError) as info:
        Trajectory.from_json(t.to_json(), planar)
    assert info.value.field == "servo_ids"
    data["poses"] = [p[:3] for p in data["poses"]]
    data["request"] = None
    with pytest.raises(InputError) as info:
        Trajectory.from_json(__import__("json").dumps(data), ARM)
    assert info.value.field == "poses"


def test_a_limit_violation_names_the_users_pose() -> None:
    with pytest.raises(VelocityLimitError) as info:
        plan(ARM, [HOME, LEFT], duration=0.05)
    v = info.value.violation
    assert len(v.pose) == 4
    fk = kinematics.fk_yawed(CHAIN, kinematics.ik_yawed(CHAIN, np.array([v.pose])))[0]
    assert np.abs(fk - v.pose).max() < 1e-9  # a pose the arm reaches, in its base frame
    assert "z=" in describe(info.value, "cli") and "pitch=" in describe(info.value, "cli")


@pytest.mark.parametrize("profile", ["optimal", "quintic"])
def test_an_approach_from_start_joints(profile: str) -> None:
    q0 = kinematics.ik_yawed(CHAIN, np.array([HOME]))[0] + np.array([0.3, 0.1, -0.1, 0.1])
    t = plan(ARM, [HOME, LEFT], start_joints=q0, profile=profile)
    assert t.approach_samples > 0
    assert np.abs(t.joints[0] - q0).max() < 1e-12
    assert np.abs(kinematics.fk_yawed(CHAIN, t.joints[-1:])[0] - LEFT).max() < 1e-9


def test_a_moving_start_and_one_waypoint_from_the_start() -> None:
    q0 = kinematics.ik_yawed(CHAIN, np.array([HOME]))[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        moving = plan(ARM, [LEFT], start_state=StartState(q0, [0.3, 0.1, 0.0, 0.0]))
        still = plan(ARM, [LEFT], start_joints=q0)
    assert np.array_equal(moving.joints[0], q0)
    # the yaw carries on at its start velocity, changed by at most a_max over one period
    v1 = (moving.joints[1, 0] - q0[0]) * moving.rate_hz
    assert abs(v1 - 0.3) <= ARM.joints[0].max_acceleration / moving.rate_hz + 1e-9
    assert still.approach_samples == 0  # from the present pose itself: no approach
    for t in (moving, still):
        assert np.abs(kinematics.fk_yawed(CHAIN, t.joints[-1:])[0] - LEFT).max() < 1e-9


def test_one_waypoint_without_a_start_is_refused_naming_the_field() -> None:
    with pytest.raises(InputError) as info:
        plan(ARM, [LEFT])
    assert info.value.field == "waypoints"
    assert "start_joints" in str(info.value) and "at least 2" in str(info.value)
