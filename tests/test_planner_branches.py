"""Issue 9: θ on a position-only arm, the elbow at a singular start, branch switches,
violations as data naming segment and branch."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from planner_helpers import (
    ARM2R,
    ARM3R,
    CONFIGS,
    WAYPOINTS_2R,
    WAYPOINTS_3R,
    check_trajectory,
    first_bad_row,
    variant,
)

from robodcn import kinematics
from robodcn.errors import (
    InputError,
    JointLimitError,
)
from robodcn.planner import Trajectory, plan

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
    a, b = (np.asarray(w[:2]) for w in WAYPOINTS_2R[:2])
    along = (b - a) / np.linalg.norm(b - a)
    r = base.poses[:n, :2] - a
    # the optimal law's joints are the C² interpolant of its dense IK samples (planner.optimal)
    # and the poses their FK: off the line by interpolation error only (~1e-8 m)
    np.testing.assert_allclose(r[:, 0] * along[1] - r[:, 1] * along[0], 0.0, atol=1e-8)
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


def _branches_sample_by_sample(q: np.ndarray) -> tuple[str | None, tuple[int, ...]]:
    """elbow_branches' rule written out per sample: the reference for its fast path."""
    from robodcn import kinematics

    tol = kinematics.SINGULAR_TOLERANCE
    sides = []
    for a in kinematics.wrap(q[:, 1]).tolist():
        singular = abs(a) < tol or math.pi - abs(a) < tol
        sides.append(0 if singular else (-1 if a < 0.0 else 1))
    switches, last = [], 0
    for i, side in enumerate(sides):
        if side != 0:
            if last != 0 and side != last:
                switches.append(i)
            last = side
    return {-1: "up", 1: "down", 0: None}[sides[0]], tuple(switches)


@given(st.lists(st.one_of(st.floats(-7.0, 7.0),
                          st.sampled_from([0.0, 1e-6, -1e-6, 2e-6, -math.pi, math.pi,
                                           math.pi - 1e-6, -math.pi + 2e-6, 1e-7])),
                min_size=1, max_size=30))
def test_elbow_branches_fast_path_is_the_per_sample_rule(q2: list[float]) -> None:
    from robodcn.planner import validate

    q = np.column_stack([np.zeros(len(q2)), q2, np.zeros(len(q2))])
    assert validate.elbow_branches(q) == _branches_sample_by_sample(q)
