"""The command line on the packaged OpenMANIPULATOR-X (``--arm omx``): poses of four numbers
(x, y, z, pitch) everywhere a pose goes in or out — the options, ``pose`` and ``teach`` on
the wire (firmware_sim), waypoint files, the plan's table and CSV, the plots."""

from __future__ import annotations

import csv
import io
import math
import tomllib

import numpy as np
import pytest
from conftest import CONFIGS
from workflow_helpers import backdrive, run_cli

from firmware_sim.bus import SimBus
from robodcn import kinematics, servo_units
from robodcn.cli import parse_pose
from robodcn.cli.report_text import plan_csv, plan_table
from robodcn.config import load_arm
from robodcn.errors import InputError
from robodcn.planner import Trajectory
from robodcn.workflow import files
from robodcn.workflow.teach import waypoints_toml

OMX = load_arm(CONFIGS / "omx.toml")
#: Joint angles (yaw, shoulder, elbow, wrist) in degrees a hand puts the arm in.
TAUGHT = [(0.0, -60.0, 20.0, 40.0), (30.0, -20.0, 10.0, 60.0), (-45.0, 10.0, -30.0, 50.0)]


def ticks_of(q_deg) -> dict[int, int]:
    ticks = servo_units.radians_to_ticks(np.radians(q_deg), OMX.servos)
    return dict(zip(OMX.servo_ids, (int(t) for t in ticks), strict=True))


@pytest.fixture
def omx_bus():
    """The omx's five servos (ids 11–15), kinematic, at tick 2048, torque off."""
    with SimBus((11, 12, 13, 14, 15), timing="fast", log=False) as bus:
        yield bus
    assert not bus.errors, bus.errors


# -- options ------------------------------------------------------------------------------------

def test_a_yawed_pose_is_four_numbers():
    assert parse_pose("0.2,0.1,0.15,-30", "--to", yawed=True) == pytest.approx(
        (0.2, 0.1, 0.15, math.radians(-30)))
    assert parse_pose("0.2, 0.1, 0.15, 0.5", "--to", yawed=True, radians=True) == \
        (0.2, 0.1, 0.15, 0.5)
    for bad in ("0.2,0.1,0", "0.2,0.1,0.15,0,1", "a,b,c,d", "0.2,nan,0.1,0"):
        with pytest.raises(InputError) as info:
            parse_pose(bad, "--via 2", yawed=True)
        assert info.value.field == "via 2"
        assert "x,y,z,pitch" in info.value.message
        assert "pose keys are x, y, z, pitch" in info.value.message


@pytest.mark.parametrize("option", ["--to", "--from", "--via"])
def test_a_wrong_count_names_the_option_and_the_pose_keys(option, monkeypatch, capsys):
    args = ["plan", "--arm", "omx", "--to", "0.2,0,0.15,0"]
    args += [option, "0.2,0.1,0"] if option != "--to" else []
    if option == "--to":
        args[4] = "0.2,0.1,0"
    assert run_cli(monkeypatch, args) == 2
    err = capsys.readouterr().err
    name = "--via 1" if option == "--via" else option
    assert f"robodcn: {name} must be a pose x,y,z,pitch" in err
    assert "this arm's pose keys are x, y, z, pitch" in err and "(3 numbers)" in err


def test_a_planar_arm_keeps_three_numbers(monkeypatch, capsys):
    assert run_cli(monkeypatch, ["plan", "--arm", "arm3r", "--to", "0.2,0.1,0.15,0"]) == 2
    assert "--to must be a pose x,y,θ (metres, degrees), got" in capsys.readouterr().err


# -- pose and teach on the wire ------------------------------------------------------------------

def test_pose_prints_x_y_z_pitch(omx_bus, monkeypatch, capsys):
    backdrive(omx_bus, ticks_of(TAUGHT[1]))
    assert run_cli(monkeypatch, ["pose", "--arm", "omx", "--device", omx_bus.port_path]) == 0
    line = capsys.readouterr().out
    q = servo_units.ticks_to_radians(list(ticks_of(TAUGHT[1]).values()), OMX.servos)
    x, y, z, pitch = kinematics.fk_yawed(OMX.chain, q[None])[0]
    assert line.startswith(f"x={x:.4f} m, y={y:.4f} m, z={z:.4f} m, "
                           f"pitch={math.degrees(pitch):.2f}°  |  yaw ")
    assert run_cli(monkeypatch, ["pose", "--arm", "omx", "--device", omx_bus.port_path,
                                 "--json"]) == 0
    import json
    assert np.allclose(json.loads(capsys.readouterr().out)["pose"], [x, y, z, pitch])


def test_teach_records_x_y_z_pitch_and_the_file_reads_back(omx_bus, monkeypatch, tmp_path,
                                                           capsys):
    out = tmp_path / "omx.toml"

    def at(q_deg):
        def step():
            backdrive(omx_bus, ticks_of(q_deg))
            return ""
        return step

    # --yes: torque off lets the omx fall (the kinematic servos here do not)
    code = run_cli(monkeypatch, ["teach", "--arm", "omx", "--device", omx_bus.port_path,
                                 "--out", str(out), "--yes"], [at(q) for q in TAUGHT] + ["q"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "waypoint 1: x=" in err and "z=" in err and "pitch=" in err
    data = tomllib.loads(out.read_text())
    assert set(data["waypoints"][0]) == {"x", "y", "z", "pitch_deg"}
    got = np.array([[w["x"], w["y"], w["z"], math.radians(w["pitch_deg"])]
                    for w in data["waypoints"]])
    q = servo_units.ticks_to_radians(np.array([list(ticks_of(t).values()) for t in TAUGHT]),
                                     OMX.servos)
    want = kinematics.fk_yawed(OMX.chain, q)
    assert np.allclose(got, want, atol=1e-5)
    wp = files.load_waypoints(out, OMX)
    assert wp.keys == ("x", "y", "z", "pitch") and np.allclose(wp.waypoints, want, atol=1e-5)


# -- waypoint files -------------------------------------------------------------------------------

ROWS = ("[[waypoints]]\nx = 0.2\ny = 0.0\nz = 0.15\npitch_deg = 0\n\n"
        "[[waypoints]]\nx = 0.15\ny = 0.1\nz = 0.1\npitch = -0.5\n")


def test_waypoint_file_round_trip_with_four_keys(tmp_path):
    poses = np.array([[0.2, 0.0, 0.15, 0.0], [0.15, 0.1, 0.1, -0.5], [0.1, -0.1, 0.2, 0.3]])
    path = tmp_path / "w.toml"
    path.write_text(waypoints_toml(poses, arm_name="omx", keys=OMX.pose_keys, method="dlb"))
    wp = files.load_waypoints(path, OMX)
    assert np.allclose(wp.waypoints, poses, atol=1e-6)
    assert files.load_waypoints(path).keys == OMX.pose_keys      # told by the keys it uses
    path.write_text(ROWS)
    assert np.allclose(files.load_waypoints(path, OMX).waypoints[1], [0.15, 0.1, 0.1, -0.5])


@pytest.mark.parametrize("edit, where, words", [
    (("z = 0.15\n", ""), "waypoints[0].z", "missing (arm 'omx' takes x, y, z, pitch_deg)"),
    (("pitch = -0.5\n", ""), "waypoints[1].pitch_deg", "missing (give pitch_deg in degrees"),
    (("pitch = -0.5\n", "pitch = -0.5\npitch_deg = 3\n"), "waypoints[1].pitch_deg",
     "give pitch_deg or pitch, not both"),
    (("pitch_deg = 0\n", "theta_deg = 0\n"), "waypoints[0].theta_deg",
     "unknown key on arm 'omx' (allowed: x, y, z, pitch_deg or pitch, method"),
    (("z = 0.1\n", "z = \"high\"\n"), "waypoints[1].z", "must be a number"),
])
def test_bad_waypoint_names_the_waypoint_and_the_field(tmp_path, edit, where, words):
    path = tmp_path / "w.toml"
    path.write_text(ROWS.replace(*edit))
    with pytest.raises(InputError) as info:
        files.load_waypoints(path, OMX)
    assert info.value.field == where and f"{path}: {where}: {words}" in info.value.message


def test_a_planar_file_on_the_omx_is_refused_naming_the_missing_key(tmp_path):
    path = tmp_path / "w.toml"
    path.write_text("[[waypoints]]\nx = 0.2\ny = 0.1\n\n[[waypoints]]\nx = 0.1\ny = 0.2\n")
    with pytest.raises(InputError, match=r"waypoints\[0\]\.z: missing"):
        files.load_waypoints(path, OMX)


# -- plan output and plots ----------------------------------------------------------------------

def _yawed_trajectory(n: int = 60) -> Trajectory:
    """A joint-space motion of the omx with its FK poses (n, 4): what a plan holds."""
    q0 = np.radians(TAUGHT[0])
    q1 = np.radians(TAUGHT[2])
    s = np.linspace(0.0, 1.0, n)[:, None]
    q = q0 + (3 * s ** 2 - 2 * s ** 3) * (q1 - q0)
    return Trajectory(np.arange(n) / 100.0, kinematics.fk_yawed(OMX.chain, q), q,
                      servo_units.radians_to_ticks(q, OMX.servos), OMX.joint_names,
                      OMX.servo_ids, 100.0, "joint")


def test_plan_table_and_csv_have_x_y_z_pitch_columns():
    traj = _yawed_trajectory()
    table = plan_table(traj).splitlines()
    assert table[1].split()[:10] == ["t", "[s]", "x", "[m]", "y", "[m]", "z", "[m]", "pitch",
                                     "[°]"]
    first = table[2].split()
    assert [float(v) for v in first[1:5]] == pytest.approx(
        [*traj.poses[0, :3], math.degrees(traj.poses[0, 3])], abs=1e-2)
    rows = list(csv.reader(io.StringIO(plan_csv(traj))))
    assert rows[0][:5] == ["t_s", "x_m", "y_m", "z_m", "pitch_rad"]
    assert np.allclose([float(v) for v in rows[1][1:5]], traj.poses[0])
    assert len(rows) == len(traj.t) + 1


def test_plot_motion_draws_the_side_and_top_views(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    from robodcn.plots import plane_points, plot_motion

    figures = []
    monkeypatch.setattr(plt, "close", figures.append)
    traj = _yawed_trajectory()
    ticks = [(float(t), tuple(int(v) for v in k)) for t, k in zip(traj.t, traj.ticks,
                                                                  strict=True)]
    png = tmp_path / "omx.png"
    plot_motion(str(png), OMX, traj, samples=ticks[::5],
                waypoints=traj.poses[[0, -1]], stop={"t": 0.3, "reason": "stopped"})
    assert png.read_bytes()[:4] == b"\x89PNG"
    side, top = figures[0].axes[:2]
    assert side.get_xlabel().startswith("r [m]") and side.get_ylabel() == "z [m]"
    assert top.get_xlabel() == "x [m]" and top.get_ylabel() == "y [m]"
    planned = next(line for line in side.lines if line.get_label() == "planned path")
    assert np.allclose(planned.get_xdata(), np.hypot(*traj.poses[:, :2].T))
    assert np.allclose(planned.get_ydata(), traj.poses[:, 2])
    # The arm drawn at the end ends at the tool point plane_fk puts it.
    end = next(line for line in side.lines if line.get_label() == "arm at end")
    tip = plane_points(OMX, traj.joints[-1])[-1]
    assert np.allclose([end.get_xdata()[-1], end.get_ydata()[-1]], tip)
    assert np.allclose(tip, kinematics.plane_fk(OMX.chain, traj.joints[-1:, 1:])[0, :2])


def test_check_config_omx_draws_the_workspace_in_the_arms_plane(tmp_path, monkeypatch,
                                                                capsys):
    import matplotlib.pyplot as plt

    figures = []
    monkeypatch.setattr(plt, "close", figures.append)
    png = tmp_path / "ws.png"
    assert run_cli(monkeypatch, ["check-config", "omx", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "poses x, y, z, pitch" in out and "home: x=0.1218 m, y=0.0000 m, z=0.2409 m" in out
    ax = figures[0].axes[0]
    assert ax.get_xlabel().startswith("r [m]") and "vertical plane" in ax.get_title()
    home = next(line for line in ax.lines if line.get_label() == "arm at home")
    assert np.allclose([home.get_xdata()[-1], home.get_ydata()[-1]],
                       [OMX.home[0], OMX.home[2]], atol=1e-6)


# -- gripper --------------------------------------------------------------------------------------

def test_gripper_close_on_an_object_holds_it_on_the_wire(monkeypatch, capsys):
    import json

    with SimBus(arm=CONFIGS / "omx.toml", dynamics=True, timing="fast") as sim:
        sim.servo(15).set_obstacle(-20.0)                 # an object in the jaws
        assert run_cli(monkeypatch, ["gripper", "close", "--arm", "omx", "--device",
                                     sim.port_path, "--json"]) == 0
        result = json.loads(capsys.readouterr().out)
        assert result["blocked"] and result["settled"] and result["command"] == "close"
        assert result["final_width_m"] > OMX.gripper.closed_width + 0.005
        servo = sim.servo(15)
        assert servo.operating_mode == 5 and servo.hardware_error == 0
        assert run_cli(monkeypatch, ["gripper", "60", "--arm", "omx", "--device",
                                     sim.port_path]) == 0
        line = capsys.readouterr().out
        assert line.startswith("gripper width (goal 60.0 mm): jaws at ")
        assert float(line.split("jaws at ")[1].split(" mm")[0]) == pytest.approx(60.0, abs=1.0)
    assert not sim.errors, sim.errors


@pytest.mark.parametrize("argv, words", [
    (["gripper", "90", "--arm", "omx", "--sim"],
     "WIDTH_MM 90 mm is outside the gripper's stroke 20..75 mm"),
    (["gripper", "squeeze", "--arm", "omx", "--sim"], "COMMAND must be open, close or a jaw"),
    (["gripper", "open", "--arm", "arm3r", "--sim"], "arm 'arm3r' has no [gripper] table"),
])
def test_bad_gripper_commands_are_refused_before_the_bus(argv, words, monkeypatch, capsys):
    assert run_cli(monkeypatch, argv) == 2
    assert words in capsys.readouterr().err


# -- README ---------------------------------------------------------------------------------------

def test_readme_omx_commands_run(tmp_path):
    """Every command of the "Your OpenMANIPULATOR-X" sh block runs as written (none needs a
    device), redirects and plots included."""
    import subprocess
    import sys

    readme = (CONFIGS.parent / "README.md").read_text()
    block = readme.split("## Your OpenMANIPULATOR-X", 1)[1].split("```sh\n", 1)[1]
    commands = [line.split("  #")[0].strip() for line in block.split("```")[0].splitlines()]
    commands = [c for c in commands if c]
    assert any("--payload" in c for c in commands) and any("gripper" in c for c in commands)
    assert any(c.startswith("robodcn sim --arm omx --to ") for c in commands)
    for command in commands:
        args, _, redirect = command.removeprefix("robodcn ").partition(" > ")
        out = subprocess.run([sys.executable, "-m", "robodcn", *args.split()],
                             capture_output=True, text=True, cwd=tmp_path, timeout=120)
        # sim: 5 when the loaded test machine made the stream skip samples (the report says so)
        assert out.returncode in ((0, 5) if args.startswith("sim ") else (0,)), (
            command, out.stderr)
        if redirect:
            (tmp_path / redirect).write_text(out.stdout)
    assert load_arm(tmp_path / "omx.toml").name == "omx"
    assert (tmp_path / "omx-workspace.png").stat().st_size > 0


def test_a_move_from_outside_the_joint_limits_recovers_first_and_says_so(omx_bus, monkeypatch,
                                                                       capsys):
    """An arm left with torque off has fallen onto its elbow's end stop, 3° past the
    limit: the move opens with a slow recovery of that joint back into its range,
    announced on stderr (issue 26 §4; it was refused, naming the present joints)."""
    backdrive(omx_bus, {12: 1364, 13: 2995, 14: 2504})      # the elbow at 83.2°
    assert run_cli(monkeypatch, ["move", "--arm", "omx", "--device", omx_bus.port_path,
                                 "--to", "0.18,0.065,0.15,-20", "--compensation", "off"]
                   ) in (0, 5)
    err = capsys.readouterr().err
    assert "robodcn: recovery: elbow 83.2° → 79.2°" in err
    elbow = OMX.joints[2]
    at = servo_units.ticks_to_radians(np.array([omx_bus.servo(13).present_position]),
                                      (elbow.servo,))[0]
    assert elbow.min_angle <= at <= elbow.max_angle
