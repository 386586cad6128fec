"""robodcn.workflow.files and record as library functions (what HTTP handlers will call)."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest
from conftest import ARM3R

from robodcn import kinematics, servo_units
from robodcn.errors import InputError, PlanError
from robodcn.planner import Trajectory, plan
from robodcn.workflow import files
from robodcn.workflow.record import recording, recording_csv
from robodcn.workflow.teach import waypoints_toml

ARM = ARM3R


def _jt(q, t):
    return {"joint_names": list(ARM.joint_names),
            "points": [{"positions": list(map(float, qi)),
                        "time_from_start": {"sec": int(ti), "nanosec": round(ti % 1 * 1e9)}}
                       for qi, ti in zip(q, t, strict=True)]}


def test_joint_trajectory_passes_its_points_and_is_validated():
    q = np.radians([[0, -30, 10], [20, -50, 15], [35, -40, 0], [50, -20, -10]])
    t = [0.5, 1.5, 2.7, 4.0]
    traj = files.trajectory_from_data(_jt(q, t), ARM, 100.0)
    assert isinstance(traj, Trajectory) and traj.rate_hz == 100.0
    assert np.isclose(traj.duration, 3.5) and len(traj.t) == 351
    for qi, ti in zip(q, t, strict=True):        # time shifted: the first point is at 0
        i = round((ti - t[0]) * 100)
        assert np.allclose(traj.joints[i], qi, atol=1e-12)
    assert np.allclose(traj.poses, kinematics.fk(ARM.links, traj.joints))
    assert np.array_equal(traj.ticks, servo_units.radians_to_ticks(traj.joints, ARM.servos))
    with pytest.raises(PlanError, match=r"^body: points\[\d\] \(sample \d+, t=.*'shoulder'"):
        files.trajectory_from_data(_jt(q, [0.0, 1.0, 1.05, 3.0]), ARM, 100.0, source="body")


def test_saved_trajectory_round_trips_and_other_json_is_refused():
    traj = plan(ARM, [ARM.home, (0.12, 0.24, 1.0)])
    again = files.trajectory_from_data(json.loads(traj.to_json()), ARM, 50.0)
    assert np.array_equal(again.ticks, traj.ticks) and again.rate_hz == traj.rate_hz
    with pytest.raises(InputError, match="trajectory: must be"):
        files.trajectory_from_data({"waypoints": []}, ARM, 100.0)


def test_with_approach_starts_at_present_and_respects_limits():
    traj = files.trajectory_from_data(_jt(np.radians([[30, -60, 20], [40, -50, 20]]),
                                          [0, 1]), ARM, 100.0)
    present = np.radians([-20.0, 10.0, 0.0])
    out = files.with_approach(traj, ARM, present)
    assert np.allclose(out.joints[0], present)
    assert np.array_equal(out.joints[-len(traj.t):], traj.joints)
    files.check_joint_samples(ARM, out.joints, out.rate_hz, source="x",
                              point_of_sample=np.zeros(len(out.t), dtype=np.int64))
    assert files.with_approach(traj, ARM, traj.joints[0]) is traj


def test_waypoints_file_round_trip(tmp_path):
    poses = np.array([[0.25, 0.10, 0.0], [0.12, 0.24, 1.0], [-0.1, 0.22, 2.0]])
    path = tmp_path / "p.toml"
    path.write_text(waypoints_toml(poses, arm_name="arm3r", method=["kenlerp", "dlb"],
                                   turn="ccw", beta=0.25))
    wp = files.load_waypoints(path)
    assert np.allclose(wp.waypoints, poses, atol=1e-6)
    fields = wp.plan_fields(duration=3.0)
    assert fields["method"] == ("kenlerp", "dlb") and fields["turn"] == "ccw"
    assert fields["beta"] == 0.25 and fields["duration"] == 3.0
    traj = plan(ARM, **fields)
    assert traj.method == ["kenlerp", "dlb"]


def test_recording_as_json_and_csv():
    ticks = [(0.0, (2048, 2048, 2048)), (0.01, (2100, 2000, 2048))]
    data = recording(ARM, ticks)
    assert data["t"] == [0.0, 0.01] and data["ticks"][1] == [2100, 2000, 2048]
    assert np.allclose(data["joints"], servo_units.ticks_to_radians(
        np.array([t[1] for t in ticks]), ARM.servos))
    rows = list(csv.reader(io.StringIO(recording_csv(ARM, ticks))))
    # plan --format csv's columns: t, the pose, the joints, the ticks
    assert rows[0] == plan(ARM, [ARM.home, (0.12, 0.24, 1.0)]).to_csv().splitlines()[0] \
        .split(",") and len(rows) == 3
    assert rows[0][:5] == ["t_s", "x_m", "y_m", "theta_rad", "q_shoulder_rad"]
    assert [int(v) for v in rows[2][7:10]] == [2100, 2000, 2048]
    assert np.allclose(np.array(rows[2][1:4], dtype=float), data["poses"][1])
    assert recording(ARM, [])["ticks"] == []


def test_trajectory_summary_fractions_match_the_limits():
    from robodcn.cli.report_text import plan_summary
    from robodcn.workflow.summary import trajectory_summary

    traj = plan(ARM, [ARM.home, (0.12, 0.24, 1.0)])            # auto: the shortest feasible
    s = trajectory_summary(traj, ARM)
    assert s["samples"] == len(traj.t) and s["duration_s"] == traj.duration
    fractions = [max(j["velocity_fraction"], j["acceleration_fraction"]) for j in s["joints"]]
    assert max(fractions) <= 1.0 + 1e-9 and max(fractions) > 0.8   # some joint is near a limit
    slow = trajectory_summary(plan(ARM, [ARM.home, (0.12, 0.24, 1.0)],
                                   duration=2 * traj.duration), ARM)
    assert all(a["velocity_fraction"] < b["velocity_fraction"]
               for a, b in zip(slow["joints"], s["joints"], strict=True))
    text = plan_summary(traj, ARM)
    # a line per joint, and the tool point's peak speed
    assert "shoulder" in text and "of the limit" in text and len(text.splitlines()) == 6
    assert text.splitlines()[-1].strip().startswith("tool       peak")


def test_waypoint_beta_is_its_segments_and_plan_beta_the_default(tmp_path):
    path = tmp_path / "p.toml"
    text = ("[plan]\nmethod = \"kenlerp\"\n{plan}\n[[waypoints]]\nx = 0.25\ny = 0.1\n\n"
            "[[waypoints]]\nx = 0.2\ny = 0.2\ntheta_deg = 30\n\n"
            "[[waypoints]]\nx = 0.12\ny = 0.24\ntheta_deg = 60\nbeta = 1.5\n")
    path.write_text(text.format(plan="beta = 0.2\n"))
    fields = files.load_waypoints(path).plan_fields()
    assert fields["beta"] == (0.2, 1.5)        # segment 0 from [plan], segment 1 its own
    traj = plan(ARM, **fields)
    assert traj.request.beta == (0.2, 1.5)
    path.write_text(text.format(plan=""))      # no [plan] beta: the planner's default, 1
    assert files.load_waypoints(path).options["beta"] == (1.0, 1.5)
    path.write_text(text.format(plan="") + "\n[[waypoints]]\nx = 0.1\ny = 0.2\nbeta = 11\n")
    with pytest.raises(InputError, match=r"waypoints\[3\]\.beta: must be within 0\.\.10, "
                       "got 11"):
        files.load_waypoints(path)
    path.write_text(text.format(plan="beta = -1\n"))
    with pytest.raises(InputError, match=r"plan\.beta: must be within 0\.\.10"):
        files.load_waypoints(path)
    path.write_text(text.format(plan="").replace("x = 0.25\n", "x = 0.25\nbeta = 0.5\n"))
    with pytest.raises(InputError, match=r"waypoints\[0\]\.beta: the first waypoint starts "
                       "no segment"):
        files.load_waypoints(path)


def test_per_segment_beta_round_trips_through_the_file(tmp_path):
    poses = np.array([[0.25, 0.10, 0.0], [0.2, 0.2, 0.5], [0.12, 0.24, 1.0]])
    path = tmp_path / "p.toml"
    path.write_text(waypoints_toml(poses, arm_name="arm3r", method="kenlerp",
                                   beta=[0.2, 1.5]))
    assert files.load_waypoints(path).plan_fields()["beta"] == (0.2, 1.5)


def test_waypoints_plan_fields_are_checked_by_the_contract(tmp_path):
    """[plan] takes what a plan request takes (robodcn.contract), the error naming file and
    key: the optimal profile, the contract's rate range, blend a boolean."""
    path = tmp_path / "p.toml"
    rows = "[[waypoints]]\nx = 0.25\ny = 0.1\n\n[[waypoints]]\nx = 0.12\ny = 0.24\n"
    path.write_text("[plan]\nprofile = \"optimal\"\nrate_hz = 250\n" + rows)
    assert files.load_waypoints(path).options == {"profile": "optimal", "rate_hz": 250.0}
    for plan_line, needle in (("rate_hz = 5000", "plan.rate_hz: must be within 1..1000 Hz, "
                                                 "got 5000"),
                              ("blend = 1", "plan.blend: must be true or false, got 1"),
                              ("profile = \"fast\"", "plan.profile: must be one of optimal, "),
                              ("duration = -1", "plan.duration: must be greater than 0")):
        path.write_text(f"[plan]\n{plan_line}\n" + rows)
        with pytest.raises(InputError) as exc:
            files.load_waypoints(path)
        assert str(exc.value).startswith(f"{path}: {needle}"), exc.value
        assert not hasattr(exc.value, "reason")      # the CLI prints it as is, file named
