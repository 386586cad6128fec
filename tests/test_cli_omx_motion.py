"""Moving the packaged OpenMANIPULATOR-X from the command line, on the wire (firmware_sim's
physics omx under gravity): ``sim``/``plan``/``move`` with four-number poses, torque off that
asks ``--yes`` on an arm that would fall (``torque off``, ``--release``), lowering to the
rest pose first."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from omx_helpers import OMX, joints_of, pose_of
from workflow_helpers import ARM3R, COMPLETED, run_cli

from robodcn import kinematics, servo_units

pytest_plugins = ["omx_helpers"]     # fixtures: held_omx

#: A reachable goal in front of the arm, turned 20° to the left: x, y, z (m), pitch (deg).
GOAL = (0.18, 0.065, 0.15, -20.0)
GOAL_ARG = ",".join(f"{v:g}" for v in GOAL)


def near_goal(pose, goal=GOAL, tol_m=0.004, tol_deg=1.5) -> bool:
    x, y, z, pitch = pose
    return (np.allclose((x, y, z), goal[:3], atol=tol_m)
            and abs(math.degrees(pitch) - goal[3]) < tol_deg)


# -- task: sim, plan and move with four numbers --------------------------------------------------

def test_sim_and_plan_take_x_y_z_pitch(monkeypatch, capsys):
    assert run_cli(monkeypatch, ["sim", "--arm", "omx", "--to", GOAL_ARG, "--timing", "fast",
                                 "--json"]) in COMPLETED
    report = json.loads(capsys.readouterr().out)
    assert report["stop_reason"] == "completed" and report["joint_names"] == list(
        OMX.joint_names)
    assert max(abs(e) for e in report["final_error_ticks"]) <= 2
    q = np.array(report["final_positions"], dtype=float)
    q = servo_units.ticks_to_radians(q, OMX.servos)
    assert near_goal(kinematics.fk_yawed(OMX.chain, q[None])[0])
    assert run_cli(monkeypatch, ["plan", "--arm", "omx", "--from", "0.2,0,0.2,0", "--to",
                                 GOAL_ARG, "--format", "json"]) == 0
    traj = json.loads(capsys.readouterr().out)
    assert len(traj["poses"][0]) == 4
    assert np.allclose(traj["poses"][-1][:3], GOAL[:3], atol=1e-6)
    assert math.degrees(traj["poses"][-1][3]) == pytest.approx(GOAL[3], abs=1e-6)


def test_move_on_the_wire_reaches_the_goal_and_holds_it(held_omx, monkeypatch, capsys):
    assert near_goal(pose_of(held_omx), (*OMX.home[:3], math.degrees(OMX.home[3])))
    code = run_cli(monkeypatch, ["move", "--arm", "omx", "--device", held_omx.port_path,
                                 "--to", GOAL_ARG, "--json"])
    report = json.loads(capsys.readouterr().out)
    assert code in COMPLETED, report
    assert report["stop_reason"] == "completed" and not report["released"]
    assert max(abs(e) for e in report["final_error_ticks"]) <= 2
    assert near_goal(pose_of(held_omx))
    assert all(held_omx.servo(i).torque_enabled for i in OMX.servo_ids)   # it holds


# -- task: torque off on an arm that falls needs --yes --------------------------------------------

def still(sim, q, ticks: int = 3) -> bool:
    """The joints within ``ticks`` of ``q`` (a held arm droops by a tick or two)."""
    return bool(np.all(np.abs(joints_of(sim) - q) <= ticks * servo_units.radians_per_tick(
        OMX.servos)))


def goals_sent(sim) -> dict[int, int]:
    return {i: len(sim.goal_history(i)) for i in OMX.servo_ids}


def test_torque_off_without_yes_warns_and_changes_nothing(held_omx, monkeypatch, capsys):
    before, q = goals_sent(held_omx), joints_of(held_omx)
    assert run_cli(monkeypatch, ["torque", "off", "--arm", "omx", "--device",
                                 held_omx.port_path]) == 2
    err = capsys.readouterr().err
    assert "fall under gravity" in err and "shoulder" in err and "N·m" in err
    assert err.rstrip().endswith("--yes confirms")
    assert all(held_omx.servo(i).torque_enabled for i in OMX.servo_ids)
    assert goals_sent(held_omx) == before and still(held_omx, q)
    # one joint: the shoulder holds the arm up, the yaw holds nothing against gravity
    assert run_cli(monkeypatch, ["torque", "off", "--joint", "shoulder", "--arm", "omx",
                                 "--device", held_omx.port_path]) == 2
    assert held_omx.servo(12).torque_enabled
    assert run_cli(monkeypatch, ["torque", "off", "--joint", "yaw", "--arm", "omx",
                                 "--device", held_omx.port_path]) == 0
    assert "warning" not in capsys.readouterr().err
    assert not held_omx.servo(11).torque_enabled and held_omx.servo(12).torque_enabled


def test_torque_off_with_yes_lowers_to_the_rest_pose_first(held_omx, monkeypatch, capsys):
    assert run_cli(monkeypatch, ["torque", "off", "--yes", "--arm", "omx", "--device",
                                 held_omx.port_path]) == 0
    out, err = capsys.readouterr()
    assert "after lowering it to its rest pose" in out and "warning" in err
    assert not any(held_omx.servo(i).torque_enabled for i in OMX.servo_ids)
    # the last goals sent are the rest pose's joints
    rest_q = kinematics.ik_yawed(OMX.chain, np.array([OMX.rest]), OMX.elbow)[0]
    last = [held_omx.goal_history(i)[-1] for i in OMX.servo_ids]
    q_last = servo_units.ticks_to_radians(np.array(last), OMX.servos)
    assert np.allclose(q_last, rest_q, atol=0.01)


def test_move_release_without_yes_is_refused_before_moving(held_omx, monkeypatch, capsys):
    before, q = goals_sent(held_omx), joints_of(held_omx)
    assert run_cli(monkeypatch, ["move", "--arm", "omx", "--device", held_omx.port_path,
                                 "--to", GOAL_ARG, "--release"]) == 2
    assert "fall under gravity" in capsys.readouterr().err
    assert goals_sent(held_omx) == before and still(held_omx, q)
    assert all(held_omx.servo(i).torque_enabled for i in OMX.servo_ids)


def test_move_release_with_yes_reaches_the_goal_then_lowers_and_releases(
        held_omx, monkeypatch, capsys):
    code = run_cli(monkeypatch, ["move", "--arm", "omx", "--device", held_omx.port_path,
                                 "--to", GOAL_ARG, "--release", "--yes", "--json"])
    out, err = capsys.readouterr()
    report = json.loads(out)
    assert code in COMPLETED, err
    assert report["stop_reason"] == "completed" and report["released"]
    assert report["release"]["lowered"] and report["release"]["released"]
    assert report["release"]["lowering"]["stop_reason"] == "completed"
    assert "after lowering it to its rest pose" in err
    assert not any(held_omx.servo(i).torque_enabled for i in OMX.servo_ids)


@pytest.mark.parametrize("argv", [
    ["sim", "--arm", "omx", "--to", GOAL_ARG, "--timing", "fast", "--release"],
])
def test_sim_release_on_the_omx_needs_yes(argv, monkeypatch, capsys):
    assert run_cli(monkeypatch, argv) == 2
    assert "confirm" in capsys.readouterr().err
    assert run_cli(monkeypatch, [*argv, "--yes", "--json"]) in COMPLETED
    report = json.loads(capsys.readouterr().out)
    assert report["released"] and report["release"]["lowered"]


def test_a_horizontal_arm_is_released_as_before(monkeypatch, capsys):
    assert run_cli(monkeypatch, ["sim", "--arm", ARM3R, "--to", "0.12,0.24,60", "--timing",
                                 "fast", "--release", "--json"]) in COMPLETED
    report = json.loads(capsys.readouterr().out)
    assert report["released"] and "release" not in report


def test_run_release_on_the_omx_needs_yes(monkeypatch, capsys, tmp_path):
    path = tmp_path / "two.toml"
    path.write_text("[[waypoints]]\nx = 0.2\ny = 0.0\nz = 0.2\npitch_deg = 0\n\n"
                    f"[[waypoints]]\nx = {GOAL[0]}\ny = {GOAL[1]}\nz = {GOAL[2]}\n"
                    f"pitch_deg = {GOAL[3]}\n")
    argv = ["run", str(path), "--arm", "omx", "--sim", "--release"]
    assert run_cli(monkeypatch, argv) == 2
    assert "--yes confirms" in capsys.readouterr().err
    assert run_cli(monkeypatch, [*argv, "--yes", "--json"]) in COMPLETED
    report = json.loads(capsys.readouterr().out)
    assert report["released"] and report["release"]["lowered"]
