"""Tool-space limits (issue 30): tool_speed, tool_angular_speed, tool_acceleration.

Each plan is checked by the finite differences of its own poses (the FK of its joints) at
the stream rate, as a user measuring the tool would: the speed |Δp|·rate, the rate of θ (of
pitch and yaw on the omx) and the acceleration along the path (the second difference of the
arc length), at rest before and after. The oracle is toppra on the same joint path with the
tool's arc length as an extra coordinate (bench/bench_tool.py).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import ARM2R, ARM3R, CONFIGS
from http_helpers import call, error_of
from workflow_helpers import ARM3R as ARM3R_PATH
from workflow_helpers import run_cli

from robodcn.config import arm_from_dict, load_arm
from robodcn.errors import ConfigError, InputError, ToolLimitError
from robodcn.planner import Trajectory, plan

pytest_plugins = ["http_helpers"]     # fixtures: planner_server

OMX = load_arm(CONFIGS / "omx.toml")
ARMS = {"arm2r": ARM2R, "arm3r": ARM3R, "omx": OMX}
#: three waypoints per arm (one via: a stop, or a blend)
PATHS = {
    "arm3r": [(0.25, 0.10, 0.0), (0.20, 0.20, 0.6), (0.12, 0.24, 1.0)],
    "arm2r": [(0.22, 0.10), (0.18, 0.15), (0.10, 0.22)],
    "omx": [(0.25, 0.0, 0.10, 0.0), (0.18, 0.12, 0.15, 0.0), (0.05, 0.22, 0.10, -0.2)],
}
METHODS = ("sclerp", "kenlerp", "seplerp", "dlb")
SPEED, TURN, ACCEL = 0.1, 1.0, 0.8
#: float noise of the finite differences (m/s, rad/s, m/s²)
NOISE = 1e-9


def positions(traj: Trajectory) -> np.ndarray:
    """The tool point of every sample: (x, y), or (x, y, z) on the omx."""
    return traj.poses[:, :3] if len(traj.pose_keys) == 4 else traj.poses[:, :2]


def measured(traj: Trajectory) -> dict[str, np.ndarray]:
    """Speed, orientation rate and acceleration along the path, by finite differences of the
    plan's poses at its rate (at rest before t = 0 and after the end)."""
    rate = traj.rate_hz
    p = positions(traj)
    p = np.concatenate([p[:1], p, p[-1:]])
    step = np.linalg.norm(np.diff(p, axis=0), axis=1)
    if len(traj.pose_keys) == 4:  # pitch, and the yaw of (x, y)
        angles = np.column_stack([traj.poses[:, 3],
                                  np.arctan2(traj.poses[:, 1], traj.poses[:, 0])])
    else:
        angles = traj.poses[:, 2:3]
    turn = np.abs(np.diff(np.unwrap(angles, axis=0), axis=0)).max(axis=1) * rate
    return {"speed": step * rate, "accel": np.abs(np.diff(step)) * rate * rate, "turn": turn}


def cases() -> list[Any]:
    out = []
    for name in ARMS:
        for method in METHODS:
            out.append(pytest.param(name, method, False, "optimal", id=f"{name}-{method}"))
        for method in ("sclerp", "seplerp"):
            out.append(pytest.param(name, method, True, "optimal",
                                    id=f"{name}-{method}-blend"))
    for name, profile in (("arm3r", "quintic"), ("arm3r", "trapezoid"), ("omx", "quintic"),
                          ("arm2r", "trapezoid")):
        out.append(pytest.param(name, "sclerp", False, profile, id=f"{name}-{profile}"))
    return out


@pytest.mark.parametrize(("name", "method", "blend", "profile"), cases())
def test_the_tool_stays_within_its_limits(name: str, method: str, blend: bool,
                                          profile: str) -> None:
    arm = ARMS[name]
    angular = None if arm.dof == 2 else TURN  # a position-only arm: θ is free
    traj = plan(arm, PATHS[name], method=method, beta=0.5 if method == "kenlerp" else 1.0,
                blend=blend, profile=profile,
                tool_speed=SPEED, tool_angular_speed=angular, tool_acceleration=ACCEL)
    got = measured(traj)
    assert got["speed"].max() <= SPEED + NOISE
    assert got["accel"].max() <= ACCEL + NOISE
    if angular is not None:
        assert got["turn"].max() <= angular + NOISE
    # the limit binds: the tool reaches most of the speed it is allowed somewhere
    assert got["speed"].max() >= 0.5 * SPEED
    assert traj.request.tool_speed == SPEED


def jerky(arm):
    """``arm`` with a jerk limit of 20 a on every joint (the bench's)."""
    return dataclasses.replace(arm, joints=tuple(
        dataclasses.replace(j, max_jerk=20.0 * j.max_acceleration) for j in arm.joints))


@pytest.mark.parametrize("name", ["arm3r", "omx"])
def test_jerk_limited_timing_keeps_the_tool_limits(name: str) -> None:
    arm = jerky(ARMS[name])
    traj = plan(arm, PATHS[name], method="seplerp", tool_speed=SPEED, tool_acceleration=ACCEL)
    got = measured(traj)
    assert got["speed"].max() <= SPEED + NOISE
    assert got["accel"].max() <= ACCEL + NOISE


@pytest.mark.parametrize(("method", "beta"), [("seplerp", 1.0), ("kenlerp", 0.0)])
def test_a_straight_line_runs_at_the_commanded_speed(method: str, beta: float) -> None:
    from bench.bench_tool import line_cruise

    start, end = (0.25, 0.10, 0.0), (0.15, 0.20, 0.0)
    traj = plan(ARM3R, [start, end], method=method, beta=beta, tool_speed=0.05,
                tool_acceleration=0.5)
    # a straight chord: every sample on the line from start to end
    p = positions(traj) - start[:2]
    d = np.subtract(end[:2], start[:2])
    cross = p[:, 0] * d[1] - p[:, 1] * d[0]
    assert np.abs(cross).max() / np.linalg.norm(d) < 1e-6
    cruise = line_cruise(traj, 0.05, 0.5)
    assert cruise.shape[0] > 0.8 * traj.t.shape[0]
    assert np.abs(cruise / 0.05 - 1.0).max() <= 0.005
    # ramps at the commanded acceleration at both ends (UR's movel): the ramp's time is v/a
    got = measured(traj)
    assert 0.9 * 0.5 <= got["accel"].max() <= 0.5 + NOISE
    length = float(np.linalg.norm(d))
    assert traj.duration == pytest.approx(length / 0.05 + 0.05 / 0.5, abs=0.03)


def test_the_optimal_tool_timing_matches_toppra() -> None:
    pytest.importorskip("toppra")
    from bench.bench_tool import CASES, arm_named, joint_path, ours, toppra_tool_timing

    for arm_name, _, waypoints, method, speed, accel in CASES:
        arm = arm_named(arm_name)
        s, q = joint_path(arm, waypoints, method)
        theirs, _ = toppra_tool_timing(arm, s, q, speed, accel)
        assert ours(arm, s, q, speed, accel) <= 1.02 * theirs
        traj = plan(arm, waypoints, method=method, beta=0.0 if method == "kenlerp" else 1.0,
                    rate_hz=100.0, tool_speed=speed, tool_acceleration=accel)
        assert traj.duration <= 1.02 * theirs + 1.0 / traj.rate_hz


def test_without_a_tool_limit_nothing_changes() -> None:
    a = plan(ARM3R, PATHS["arm3r"])
    b = plan(ARM3R, PATHS["arm3r"], tool_speed=None)
    assert a.request.tool_speed is None and not a.request.tool_limited
    np.testing.assert_array_equal(a.joints, b.joints)
    # a limit far above the plan's own speed changes nothing either
    fast = plan(ARM3R, PATHS["arm3r"], tool_speed=50.0)
    assert fast.t.shape == a.t.shape


def test_a_fixed_duration_too_short_names_the_field_the_sample_and_the_speed() -> None:
    with pytest.raises(ToolLimitError) as exc:
        plan(ARM3R, PATHS["arm3r"][:2], method="seplerp", duration=2.0, tool_speed=0.05)
    v = exc.value.violation
    assert v is not None and v.quantity == "tool_speed" and v.field == "tool_speed"
    assert v.value > 0.05 and v.limit == 0.05 and v.unit == "m/s"
    assert f"sample {v.sample}" in str(exc.value) and "tool_speed 0.05 m/s" in str(exc.value)
    # the uniform profiles too; and a duration that is long enough passes
    with pytest.raises(ToolLimitError):
        plan(ARM3R, PATHS["arm3r"][:2], profile="quintic", duration=2.0, tool_speed=0.05)
    assert plan(ARM3R, PATHS["arm3r"][:2], method="seplerp", duration=4.0,
                tool_speed=0.05).duration == pytest.approx(4.0)


@pytest.mark.parametrize(("field", "value"), [("tool_speed", -0.1), ("tool_speed", 0.0),
                                               ("tool_speed", math.nan),
                                               ("tool_acceleration", 0.0),
                                               ("tool_angular_speed", -1.0)])
def test_bad_values_are_refused_naming_the_field(field: str, value: float) -> None:
    with pytest.raises(InputError) as exc:
        plan(ARM3R, PATHS["arm3r"], **{field: value})
    assert exc.value.field == field


def tool_arm(tmp_path: Path, table: str) -> Path:
    """arm3r's file with a ``[tool]`` table appended."""
    path = tmp_path / "arm3r_tool.toml"
    path.write_text(Path(ARM3R_PATH).read_text() + "\n[tool]\n" + table)
    return path


def test_the_arm_file_sets_defaults_and_ceilings(tmp_path: Path) -> None:
    arm = load_arm(tool_arm(tmp_path, "speed = 0.05\nmax_speed = 0.5\n"
                                      "angular_speed_deg_s = 90\nmax_acceleration = 2.0\n"))
    assert arm.tool.speed == 0.05 and arm.tool.angular_speed == pytest.approx(math.pi / 2)
    traj = plan(arm, PATHS["arm3r"][:2], method="seplerp")
    assert traj.request.tool_speed == 0.05
    assert measured(traj)["speed"].max() <= 0.05 + NOISE
    assert plan(arm, PATHS["arm3r"][:2], tool_speed=0.4).request.tool_speed == 0.4
    with pytest.raises(InputError) as exc:
        plan(arm, PATHS["arm3r"][:2], tool_speed=0.8)
    assert exc.value.field == "tool_speed" and "max_speed 0.5" in str(exc.value)
    with pytest.raises(InputError) as exc:
        plan(arm, PATHS["arm3r"][:2], tool_acceleration=3.0)
    assert exc.value.field == "tool_acceleration"
    # the arm round-trips through its dict (a trajectory's embedded arm)
    assert arm_from_dict(arm.to_dict()).tool == arm.tool
    for bad in ("speed = 0.0\n", "speed = 0.6\nmax_speed = 0.5\n", "spead = 0.1\n"):
        with pytest.raises(ConfigError):
            load_arm(tool_arm(tmp_path, bad))


PLAN = ("plan", "--arm", ARM3R_PATH, "--to", "0.12,0.24,60", "--method", "seplerp", "-q")


@pytest.mark.parametrize("args", [["--tool-speed", "-1"], ["--tool-speed", "0"],
                                  ["--tool-speed", "nan"], ["--tool-acceleration", "0"],
                                  ["--tool-angular-speed", "-5"]])
def test_cli_refuses_bad_values_naming_the_option(monkeypatch, capsys, args) -> None:
    with pytest.raises(SystemExit) as exc:
        run_cli(monkeypatch, [*PLAN, *args])
    assert exc.value.code == 2
    assert args[0] in capsys.readouterr().err


def test_cli_plans_and_refuses_above_the_arms_ceiling(monkeypatch, capsys,
                                                      tmp_path: Path) -> None:
    assert run_cli(monkeypatch, [*PLAN, "--tool-speed", "0.05", "--format", "json"]) == 0
    out = capsys.readouterr().out
    assert '"tool_speed": 0.05' in out
    path = str(tool_arm(tmp_path, "max_speed = 0.2\nmax_angular_speed_deg_s = 90\n"))
    argv = ["plan", "--arm", path, "--to", "0.12,0.24,60", "-q"]
    assert run_cli(monkeypatch, [*argv, "--tool-speed", "0.3"]) == 2
    err = capsys.readouterr().err
    assert "--tool-speed 0.3 m/s is above the arm's [tool] max_speed, 0.2 m/s" in err
    assert run_cli(monkeypatch, [*argv, "--tool-angular-speed", "120"]) == 2
    assert "90 deg/s" in capsys.readouterr().err
    # a fixed duration the tool limit cannot keep: exit 3, naming the option
    assert run_cli(monkeypatch, [*PLAN, "--tool-speed", "0.05", "--duration", "2"]) == 3
    err = capsys.readouterr().err
    assert "--tool-speed 0.05 m/s" in err and "sample" in err


def test_http_takes_the_fields_and_refuses_bad_ones(planner_server: Any) -> None:
    body = {"waypoints": [list(w) for w in PATHS["arm3r"][:2]], "method": "seplerp",
            "tool_speed": 0.05, "tool_acceleration": 0.5, "tool_angular_speed": 1.0}
    status, _, data = call(planner_server, "POST", "/v1/trajectories", body)
    assert status == 200, data
    assert data["request"]["tool_speed"] == 0.05
    traj = Trajectory.from_json(__import__("json").dumps(data))
    assert measured(traj)["speed"].max() <= 0.05 + NOISE
    for field, value in (("tool_speed", 0), ("tool_speed", -1.0), ("tool_acceleration", 1e9),
                         ("tool_angular_speed", "fast")):
        status, _, data = call(planner_server, "POST", "/v1/trajectories",
                               {**body, field: value})
        assert status == 422, (field, value, data)
        assert error_of(data)["field"] == field
    status, _, data = call(planner_server, "POST", "/v1/trajectories",
                           {**body, "duration": 2.0, "tool_acceleration": None})
    assert status == 422
    err = error_of(data)
    assert err["code"] == "tool_limit" and "above tool_speed 0.05 m/s" in err["message"]


# -- where it is reported: the plan summary, --plot, GET /v1/moves/{id} -----------------------

def test_the_plan_summary_names_the_peak_tool_speed_and_where_it_binds(monkeypatch,
                                                                        capsys) -> None:
    argv = ["plan", "--arm", ARM3R_PATH, "--from", "0.25,0.10,0", "--to", "0.15,0.20,0",
            "--method", "seplerp", "--format", "json"]
    assert run_cli(monkeypatch, [*argv, "--tool-speed", "0.05"]) == 0
    err = capsys.readouterr().err
    line = next(x for x in err.splitlines() if x.strip().startswith("tool"))
    assert "peak 0.0500 m/s" in line and "100% of --tool-speed 0.05 m/s" in line
    assert "binds 0." in line
    # without a limit: the peak alone (the tool is far faster than 0.05 m/s)
    assert run_cli(monkeypatch, argv) == 0
    line = next(x for x in capsys.readouterr().err.splitlines()
                if x.strip().startswith("tool"))
    assert "of --tool-speed" not in line
    assert float(line.split("peak ")[1].split(" m/s")[0]) > 0.2


def test_plot_draws_the_tool_speed_against_its_limit(tmp_path: Path, monkeypatch) -> None:
    import matplotlib.pyplot as plt

    from robodcn.plots import plot_motion

    figures: list[Any] = []
    monkeypatch.setattr(plt, "close", figures.append)
    traj = plan(ARM3R, PATHS["arm3r"][:2], method="seplerp", tool_speed=0.05,
                tool_acceleration=0.5)
    plot_motion(str(tmp_path / "tool.png"), ARM3R, traj)
    by_label = {ax.get_ylabel(): ax for ax in figures[0].axes}
    panel = by_label["tool speed [m/s]"]
    speed = panel.lines[0].get_ydata()
    assert np.max(speed) == pytest.approx(0.05, rel=0.002)
    levels = [line.get_ydata()[0] for line in panel.lines if line.get_linestyle() == ":"]
    assert 0.05 in levels
    assert (tmp_path / "tool.png").stat().st_size > 0


def test_a_moves_status_names_its_peak_tool_speed(arm_server) -> None:
    from http_helpers import run_move

    server, _ = arm_server
    done = run_move(server, {"waypoints": [[0.2, 0.15, 0.0]], "method": "seplerp",
                             "tool_speed": 0.2, "tool_acceleration": 2.0})
    tool = done["tool"]
    assert tool["speed_limit"] == 0.2 and tool["acceleration_limit"] == 2.0
    assert tool["peak_speed"] <= 0.2 + NOISE and tool["peak_acceleration"] <= 2.0 + NOISE
    assert tool["binds_from"] is not None and 0.0 < tool["binding_share"] <= 1.0
    status, _, again = call(server, "GET", f"/v1/moves/{done['id']}")
    assert status == 200 and again["tool"] == tool


def test_a_waypoints_file_carries_the_tool_limits(tmp_path: Path, monkeypatch) -> None:
    from robodcn.workflow import files

    path = tmp_path / "line.toml"
    path.write_text('[plan]\nmethod = "seplerp"\ntool_speed = 0.05\ntool_acceleration = 0.5\n'
                    "\n[[waypoints]]\nx = 0.25\ny = 0.10\ntheta_deg = 0\n"
                    "\n[[waypoints]]\nx = 0.15\ny = 0.20\ntheta_deg = 0\n")
    fields = files.load_waypoints(path, ARM3R).plan_fields()
    assert fields["tool_speed"] == 0.05 and fields["tool_acceleration"] == 0.5
    traj = plan(ARM3R, **fields)
    assert measured(traj)["speed"].max() <= 0.05 + NOISE
    path.write_text(path.read_text().replace("tool_speed = 0.05", "tool_speed = -1"))
    with pytest.raises(InputError) as exc:
        files.load_waypoints(path, ARM3R)
    assert "tool_speed" in str(exc.value)


@pytest.mark.parametrize("profile", ["quintic", "trapezoid"])
def test_a_uniform_law_is_stretched_piece_by_piece(profile: str) -> None:
    # a short first segment (1.4 mm) already within the tool speed, then a long one
    waypoints = [(0.25, 0.10, 0.0), (0.249, 0.101, 0.0), (0.12, 0.24, 1.0)]
    free = plan(ARM3R, waypoints, profile=profile)
    kept = plan(ARM3R, waypoints, profile=profile, tool_speed=0.1)

    def at_via(traj: Trajectory) -> int:
        return int(np.argmin(np.linalg.norm(traj.poses[:, :2] - waypoints[1][:2], axis=1)))

    assert measured(free)["speed"][:at_via(free) + 1].max() < 0.1
    assert at_via(kept) == at_via(free)          # the first piece is not slowed
    assert kept.duration > 3 * free.duration     # the second is
    assert measured(kept)["speed"].max() <= 0.1 + NOISE


def test_cli_names_the_angular_speed_in_degrees(monkeypatch, capsys) -> None:
    argv = ["plan", "--arm", ARM3R_PATH, "--to", "0.12,0.24,60", "-q",
            "--tool-angular-speed", "10"]
    assert run_cli(monkeypatch, [*argv, "--duration", "2"]) == 3
    err = capsys.readouterr().err
    assert "the tool turns at" in err and "above --tool-angular-speed 10 deg/s" in err
    assert run_cli(monkeypatch, [*argv, "--format", "json"]) == 0
    data = __import__("json").loads(capsys.readouterr().out)
    assert data["request"]["tool_angular_speed"] == pytest.approx(math.radians(10))
    theta = np.unwrap(np.asarray(data["poses"])[:, 2])
    assert np.abs(np.diff(theta)).max() * data["rate_hz"] <= math.radians(10) + NOISE


def test_run_plays_a_waypoints_file_at_the_commanded_tool_speed(monkeypatch, capsys,
                                                                 tmp_path: Path) -> None:
    path = tmp_path / "line.toml"
    path.write_text('[plan]\nmethod = "seplerp"\n'
                    "\n[[waypoints]]\nx = 0.25\ny = 0.10\ntheta_deg = 0\n"
                    "\n[[waypoints]]\nx = 0.15\ny = 0.20\ntheta_deg = 0\n")
    # the same plan run streams: its samples (the sim starts at home, the first waypoint)
    want = plan(ARM3R, [(0.25, 0.10, 0.0), (0.15, 0.20, 0.0)], method="seplerp",
                tool_speed=0.05, tool_acceleration=0.5)
    code = run_cli(monkeypatch, ["run", str(path), "--arm", ARM3R_PATH, "--sim",
                                 "--tool-speed", "0.05", "--tool-acceleration", "0.5"])
    seen = capsys.readouterr()
    assert code in (0, 5), seen.err
    text = seen.out + seen.err
    assert f"/{len(want.t)} in " in text, text  # "samples sent k/N in …": N the plan's
    # a JSON trajectory is already timed: the options are refused
    traj = tmp_path / "t.json"
    traj.write_text(plan(ARM3R, PATHS["arm3r"][:2]).to_json())
    assert run_cli(monkeypatch, ["run", str(traj), "--arm", ARM3R_PATH, "--sim",
                                 "--tool-speed", "0.05"]) == 2
    assert "--tool-speed applies to waypoints files" in capsys.readouterr().err


def test_sim_reports_the_planned_peak_tool_speed(monkeypatch, capsys) -> None:
    argv = ["sim", "--arm", ARM3R_PATH, "--to", "0.15,0.20,0", "--method", "seplerp",
            "--timing", "fast"]
    assert run_cli(monkeypatch, [*argv, "--tool-speed", "0.05", "--json"]) in (0, 5)
    data = __import__("json").loads(capsys.readouterr().out)
    assert data["tool"]["speed_limit"] == 0.05
    assert data["tool"]["peak_speed"] == pytest.approx(0.05, rel=0.005)
    assert run_cli(monkeypatch, [*argv, "--tool-speed", "0.05"]) in (0, 5)
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.strip().startswith("tool       peak") and "--tool-speed 0.05 m/s" in last
    # without a tool limit the report is as it was
    assert run_cli(monkeypatch, [*argv, "--json"]) in (0, 5)
    assert "tool" not in __import__("json").loads(capsys.readouterr().out)
