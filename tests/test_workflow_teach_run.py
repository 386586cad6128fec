"""robodcn teach and robodcn run end to end against firmware_sim over a pty (real
dynamixel-sdk): taught poses by backdrive, replayed through the planner; saved Trajectory
JSON and JointTrajectory JSON played; bad files refused before the bus is opened."""

from __future__ import annotations

import json
import math
import tomllib

import numpy as np
import pytest
from workflow_helpers import ARM3R, NO_DEVICE, backdrive, run_cli

from robodcn import kinematics, servo_units
from robodcn.config import load_arm
from robodcn.workflow import files

pytest_plugins = ["workflow_fixtures"]     # fixtures: sim, physics_sim
ARM = load_arm(ARM3R)
#: Joint angles (degrees) of the poses taught by hand.
TAUGHT = [(10.0, -60.0, 40.0), (40.0, -80.0, 30.0), (70.0, -50.0, 0.0), (90.0, -30.0, 10.0)]


def ticks_of(q_deg) -> dict[int, int]:
    ticks = servo_units.radians_to_ticks(np.radians(q_deg), ARM.servos)
    return dict(zip(ARM.servo_ids, (int(t) for t in ticks), strict=True))


def present(bus) -> list[int]:
    return [bus.servo(i).present_position for i in ARM.servo_ids]


def test_teach_records_poses_with_undo_then_run_replays_them(physics_sim, monkeypatch,
                                                             tmp_path, capsys):
    """Taught by hand on the physics sim and replayed with compensation (the defaults a
    real arm gets)."""
    sim = physics_sim
    out = tmp_path / "poses.toml"

    def at(q_deg, line=""):
        def step():
            backdrive(sim, ticks_of(q_deg))
            return line
        return step

    steps = [at(TAUGHT[0]), at(TAUGHT[1]), at((0.0, 0.0, 0.0)), "u", at(TAUGHT[2]), "x",
             at(TAUGHT[3]), "q"]
    code = run_cli(monkeypatch, ["teach", "--arm", ARM3R, "--device", sim.port_path, "--out",
                                 str(out), "--method", "sclerp,kenlerp,seplerp", "--beta",
                                 "0.5"], steps)
    err = capsys.readouterr().err
    assert code == 0, err
    assert "undone" in err and "unknown answer 'x'" in err
    data = tomllib.loads(out.read_text())
    got = np.array([[w["x"], w["y"], math.radians(w["theta_deg"])] for w in data["waypoints"]])
    # What the servos report: the taught angles to the nearest tick.
    q_ticks = [servo_units.ticks_to_radians(list(ticks_of(q).values()), ARM.servos)
               for q in TAUGHT]
    want = kinematics.fk(ARM.links, np.array(q_ticks))
    assert np.allclose(got, want, atol=1e-5)
    assert [w.get("method") for w in data["waypoints"]] == [None, "sclerp", "kenlerp",
                                                            "seplerp"]
    assert data["plan"]["beta"] == 0.5
    wp = files.load_waypoints(out)
    assert wp.options["method"] == ("sclerp", "kenlerp", "seplerp")

    # Replay: the arm is at the last taught pose; it approaches the first and runs through.
    code = run_cli(monkeypatch, ["run", str(out), "--arm", ARM3R, "--device", sim.port_path,
                                 "--json"])
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    # 5: completed with samples skipped (a loaded machine), and the report says so.
    assert code == {"done": 0, "degraded": 5}.get(report["outcome"]), report["headline"]
    # The approach was planned into the trajectory: the streamer inserted none.
    assert report["stop_reason"] == "completed" and report["approach"] is None
    # Compensated, the motors follow the plan (issue 11: max ≤ 0.5° a joint) and come to
    # rest on it, not a friction dead band short of it. A skipped sample (loaded machine)
    # is a goal jump the motor lags behind, so the bound holds for a run that sent all.
    assert report["compensation"] is True
    if report["outcome"] == "done":
        assert max(report["tracking_error_max_rad"]) <= math.radians(0.5), report
    # At rest within one encoder count: which side of the last tick Coulomb friction holds
    # a motor on depends on the timing of its final approach (seen ±1 on a loaded machine);
    # uncompensated, the same sim rests several ticks short (`robodcn sim --compensation off`).
    assert max(abs(e) for e in report["final_error_ticks"]) <= 1, report
    end = servo_units.ticks_to_radians(present(sim), ARM.servos)
    assert np.allclose(kinematics.fk(ARM.links, end[None])[0], want[-1], atol=2e-3)


def test_teach_with_fewer_than_two_poses_writes_nothing(sim, monkeypatch, tmp_path, capsys):
    out = tmp_path / "poses.toml"
    code = run_cli(monkeypatch, ["teach", "--arm", ARM3R, "--device", sim.port_path, "--out",
                                 str(out)], ["", "q"])
    assert code == 2 and "recorded 1 waypoint" in capsys.readouterr().err
    assert not out.exists()


def test_teach_bad_method_is_refused_before_the_bus(monkeypatch, tmp_path, capsys):
    code = run_cli(monkeypatch, ["teach", "--arm", ARM3R, "--device", NO_DEVICE, "--out",
                                 str(tmp_path / "p.toml"), "--method", "sclerp,spline"])
    assert code == 2 and "--method: 'spline'" in capsys.readouterr().err


def test_run_saved_trajectory_json(sim, monkeypatch, tmp_path, capsys):
    plan = tmp_path / "plan.json"
    assert run_cli(monkeypatch, ["plan", "--arm", ARM3R, "--via", "0.12,0.24,60", "--to",
                                 "-0.10,0.22,120", "--format", "json", "--out",
                                 str(plan)]) == 0
    capsys.readouterr()
    png = tmp_path / "run.png"
    # Kinematic servos reach each goal at once: without compensation the goals sent are
    # the saved samples themselves.
    code = run_cli(monkeypatch, ["run", str(plan), "--arm", ARM3R, "--device", sim.port_path,
                                 "--json", "--plot", str(png), "--compensation", "off"])
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    # 5: completed with samples skipped (a loaded machine), and the report says so.
    assert code == {"done": 0, "degraded": 5}.get(report["outcome"]), report["headline"]
    saved = json.loads(plan.read_text())["ticks"]
    # The servos start stretched out (tick 2048): a joint-space approach to the plan's first
    # sample comes first, then every saved sample as saved.
    assert report["stop_reason"] == "completed"
    assert report["samples_total"] > len(saved)
    # The last goals sent are the saved samples in order (a late sample may be skipped).
    sent = sim.goal_history(1)[-(len(saved) - report["samples_skipped"]):]
    column = iter(t[0] for t in saved)
    assert all(any(goal == s for s in column) for goal in sent)
    assert sent[-1] == saved[-1][0]
    assert present(sim) == saved[-1]
    assert png.read_bytes()[:4] == b"\x89PNG"


def _joint_trajectory(points, names=("shoulder", "elbow", "wrist")) -> dict:
    return {"joint_names": list(names), "points": points}


def _point(q, t, v=None, a=None) -> dict:
    p = {"positions": [float(x) for x in q], "time_from_start": {"sec": int(t),
                                                   "nanosec": round((t % 1) * 1e9)}}
    if v is not None:
        p["velocities"] = [float(x) for x in v]
    if a is not None:
        p["accelerations"] = [float(x) for x in a]
    return p


@pytest.mark.parametrize("derivatives", ["positions", "velocities", "accelerations"])
def test_run_joint_trajectory_json(sim, monkeypatch, tmp_path, capsys, derivatives):
    q = np.radians([[0.0, -20.0, 10.0], [30.0, -60.0, 20.0], [60.0, -40.0, 0.0]])
    v = [[0, 0, 0], [0.5, 0.0, -0.2], [0, 0, 0]] if derivatives != "positions" else [None] * 3
    a = [[0, 0, 0]] * 3 if derivatives == "accelerations" else [None] * 3
    # Joint names in another order than the arm's: columns are matched by name.
    order = [2, 0, 1]
    names = [ARM.joint_names[i] for i in order]
    points = [_point(q[k][order], 1.5 * k + 0.25,
                     None if v[k] is None else np.array(v[k])[order],
                     None if a[k] is None else np.array(a[k])[order]) for k in range(3)]
    path = tmp_path / "jt.json"
    path.write_text(json.dumps(_joint_trajectory(points, names)))
    code = run_cli(monkeypatch, ["run", str(path), "--arm", ARM3R, "--device", sim.port_path,
                                 "--json", "--rate", "50", "--compensation", "off"])
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    # 5: completed with samples skipped (a loaded machine), and the report says so.
    assert code == {"done": 0, "degraded": 5}.get(report["outcome"]), report["headline"]
    assert report["stop_reason"] == "completed" and report["rate_hz"] == 50
    assert report["compensation"] is False
    assert present(sim) == servo_units.radians_to_ticks(q[-1], ARM.servos).tolist()


@pytest.mark.parametrize(("mutate", "needle"), [
    (lambda d: d.update(joint_names=["shoulder", "elbow", "hand"]), "joint_names"),
    (lambda d: d["points"][1].update(positions=[0.1, 0.2]), "points[1].positions"),
    (lambda d: d["points"][2].update(time_from_start={"sec": 0, "nanosec": 5}),
     "points[2].time_from_start"),
    (lambda d: d["points"][1].update(time_from_start={"sec": 1, "nanosec": 2_000_000_000}),
     "points[1].time_from_start.nanosec"),
    (lambda d: d["points"][1].update(velocities=[0, 0, 0]), "points[0].velocities"),
    (lambda d: d["points"][2].update(positions=[0.0, 3.0, 0.0]), "points[2].positions[1]"),
])
def test_bad_joint_trajectory_names_file_point_and_field(monkeypatch, tmp_path, capsys, mutate,
                                                         needle):
    """Malformed: exit 2; a point outside the joint limits: infeasible, exit 3."""
    data = _joint_trajectory([_point([0, 0, 0], 0), _point([0.2, -0.2, 0], 2),
                              _point([0.3, -0.3, 0.1], 4)])
    mutate(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    code = run_cli(monkeypatch, ["run", str(path), "--arm", ARM3R, "--device", NO_DEVICE])
    err = capsys.readouterr().err
    assert code == (3 if needle == "points[2].positions[1]" else 2), err
    assert str(path) in err and needle in err and len(err.strip().splitlines()) == 1


def test_too_fast_joint_trajectory_is_infeasible_before_the_bus(monkeypatch, tmp_path, capsys):
    path = tmp_path / "fast.json"
    path.write_text(json.dumps(_joint_trajectory([_point([0, 0, 0], 0),
                                                  _point([1.5, 0, 0], 0.2)])))
    code = run_cli(monkeypatch, ["run", str(path), "--arm", ARM3R, "--device", NO_DEVICE])
    err = capsys.readouterr().err
    assert code == 3, err
    assert str(path) in err and "points[1]" in err and "'shoulder'" in err and "°/s" in err


def test_bad_run_arguments_are_refused_before_the_bus(monkeypatch, tmp_path, capsys):
    plan = tmp_path / "plan.json"
    run_cli(monkeypatch, ["plan", "--arm", ARM3R, "--to", "0.12,0.24,60", "--format", "json",
                          "--out", str(plan)])
    capsys.readouterr()
    cases = [
        (["run", str(plan), "--method", "dlb"], "--method applies to waypoints files"),
        (["run", str(plan), "--rate", "50"], "--rate 50"),
        (["run", str(tmp_path / "nope.toml")], "cannot read"),
        (["run", str(plan), "--arm", "configs/arm2r.toml"], "servo_ids"),
    ]
    for argv, needle in cases:
        code = run_cli(monkeypatch, [*argv, "--device", NO_DEVICE])
        err = capsys.readouterr().err
        assert code == 2 and needle in err, (argv, err)
    poses = tmp_path / "poses.toml"
    poses.write_text("[[waypoints]]\nx = 0.25\ny = 0.1\n\n[[waypoints]]\nx = 0.2\ny = 0.1\n"
                     "turn = \"sideways\"\n")
    code = run_cli(monkeypatch, ["run", str(poses), "--device", NO_DEVICE])
    err = capsys.readouterr().err
    assert code == 2 and "waypoints[1].turn" in err and "'sideways'" in err


def test_trajectory_planned_for_another_calibration_is_refused(tmp_path):
    plan_text = None
    from robodcn.planner import plan

    traj = plan(ARM, [ARM.home, (0.12, 0.24, 1.0)])
    other = tmp_path / "arm.toml"
    other.write_text(open(ARM3R).read().replace("zero_offset = 2048", "zero_offset = 2000", 1))
    plan_text = traj.to_json()
    with pytest.raises(Exception, match=r"ticks\[0\]\[0\].*plan it again"):
        files.load_trajectory("saved.json", load_arm(other), text=plan_text)


def test_hermite_reproduces_polynomials_it_can_represent():
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.2, 1.0, 6))
    ts = np.linspace(t[0], t[-1], 200)
    c = rng.normal(size=(6, 2))        # quintic coefficients per joint column
    powers = np.arange(6)

    def poly(x, d=0):
        x = np.asarray(x)[:, None]
        out = np.zeros((x.shape[0], 2))
        for n in powers[d:]:
            out += c[n] * math.perm(n, d) * x ** (n - d)
        return out

    cubic = c.copy()
    c[4:] = 0.0                        # a cubic: the cubic Hermite is exact
    assert np.allclose(files.hermite(t, poly(t), poly(t, 1), None, ts), poly(ts), atol=1e-9)
    c[:] = cubic                       # a quintic: the quintic Hermite is exact
    assert np.allclose(files.hermite(t, poly(t), poly(t, 1), poly(t, 2), ts), poly(ts),
                       atol=1e-9)


def test_run_sim_ctrl_c_stops_holds_and_plots_the_stop(monkeypatch, tmp_path, capsys):
    import os
    import signal

    from robodcn.cli import motion_cmd

    q = np.radians([[0.0, -60.0, 20.0], [60.0, -30.0, 0.0]])
    path = tmp_path / "slow.json"
    path.write_text(json.dumps(_joint_trajectory([_point(q[0], 0), _point(q[1], 6.0)])))
    png = tmp_path / "stop.png"
    progress = motion_cmd._LiveProgress.__call__
    sent = []

    def ctrl_c_midway(self, p):          # the user presses Ctrl-C 50 samples in
        if p.sample >= 50 and not sent:
            sent.append(p.sample)
            os.kill(os.getpid(), signal.SIGINT)
        progress(self, p)

    monkeypatch.setattr(motion_cmd._LiveProgress, "__call__", ctrl_c_midway)
    code = run_cli(monkeypatch, ["run", str(path), "--arm", ARM3R, "--sim", "--json",
                                 "--plot", str(png)])
    captured = capsys.readouterr()
    assert code == 130, captured.err
    report = json.loads(captured.out)
    assert report["stop_reason"] == "stopped"
    assert 0 < report["samples_sent"] < report["samples_total"]
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_unreachable_waypoint_in_a_file_is_named_before_the_bus(monkeypatch, tmp_path, capsys):
    poses = tmp_path / "poses.toml"
    poses.write_text("[[waypoints]]\nx = 0.25\ny = 0.1\ntheta_deg = 0\n\n"
                     "[[waypoints]]\nx = 0.6\ny = 0.5\ntheta_deg = 0\n")
    code = run_cli(monkeypatch, ["run", str(poses), "--arm", ARM3R, "--device", NO_DEVICE])
    err = capsys.readouterr().err
    assert code == 3 and err.startswith(f"robodcn: {poses}: ") and "waypoints[1]" in err
    assert "out of reach" in err
