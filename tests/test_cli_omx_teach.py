"""Teaching the OpenMANIPULATOR-X by hand and replaying it, on the wire (firmware_sim's
physics omx under gravity): ``teach --float`` holds the arm in float mode while a hand
moves it (the prompt keeps working while the float loop runs), ``o``/``c`` actuate the
gripper and mark the waypoint, and ``run`` plays the taught pick-and-place leg by leg:
the object in the jaws is held without an overload alert and the arm reaches the place
pose."""

from __future__ import annotations

import json
import time
import tomllib

import numpy as np
import pytest
from omx_helpers import OMX, pose_of
from workflow_helpers import COMPLETED, run_cli

from robodcn.workflow import files
from robodcn.workflow.run import PlanOverrides, legs, waypoints_fields

pytest_plugins = ["omx_helpers"]     # fixtures: held_omx

#: Overload, in Hardware Error Status (bit 5).
OVERLOAD = 0x20


def hand(sim, servo_id: int, torque_nm: float, seconds: float = 0.3):
    """A prompt step: a hand pushes one joint for a while and lets go, then Enter-like
    ``line``; the float loop keeps running meanwhile (the prompt is on another thread)."""
    def step(line: str = "") -> str:
        sim.servo(servo_id).push(torque_nm)
        time.sleep(seconds)
        sim.servo(servo_id).push(0.0)
        time.sleep(0.5)
        return line
    return step


def then(step, line: str):
    return lambda: step(line)


def wait(seconds: float, line: str = ""):
    def step() -> str:
        time.sleep(seconds)
        return line
    return step


# -- teach --float -------------------------------------------------------------------------------

def test_teach_float_holds_the_arm_where_the_hand_leaves_it(held_omx, monkeypatch, capsys,
                                                             tmp_path):
    out = tmp_path / "float.toml"
    start = pose_of(held_omx)
    steps = [wait(0.3), then(hand(held_omx, 12, -0.3), ""), wait(0.6, "q")]
    code = run_cli(monkeypatch, ["teach", "--arm", "omx", "--device", held_omx.port_path,
                                 "--out", str(out), "--float"], steps)
    err = capsys.readouterr().err
    assert code == 0, err
    assert "float: joints yaw, shoulder, elbow, wrist hold against gravity" in err
    assert "the arm holds where it was left (position mode)" in err
    wp = files.load_waypoints(out, OMX)
    assert np.allclose(wp.waypoints[0][:3], start[:3], atol=0.003)     # it did not fall
    assert np.linalg.norm(wp.waypoints[1][:3] - wp.waypoints[0][:3]) > 0.01   # moved by hand
    # position mode again, torque on, holding where the hand left it
    assert all(held_omx.servo(i).operating_mode == 3 for i in OMX.servo_ids)
    assert all(held_omx.servo(i).torque_enabled for i in OMX.servo_ids)
    time.sleep(0.3)
    assert np.allclose(pose_of(held_omx)[:3], wp.waypoints[1][:3], atol=0.004)


def test_teach_without_float_on_the_omx_needs_yes(held_omx, monkeypatch, capsys, tmp_path):
    code = run_cli(monkeypatch, ["teach", "--arm", "omx", "--device", held_omx.port_path,
                                 "--out", str(tmp_path / "x.toml")], ["q"])
    err = capsys.readouterr().err
    assert code == 2 and "teach --float" in err and "fall under gravity" in err
    assert all(held_omx.servo(i).torque_enabled for i in OMX.servo_ids)
    assert not (tmp_path / "x.toml").exists()


# -- a taught pick-and-place replays ------------------------------------------------------------

def test_a_taught_pick_and_place_replays_holding_the_object(held_omx, monkeypatch, capsys,
                                                            tmp_path):
    pick = tmp_path / "pick.toml"
    gripper = held_omx.servo(15)
    assert run_cli(monkeypatch, ["gripper", "open", "--arm", "omx", "--device",
                                 held_omx.port_path]) == 0
    gripper.set_obstacle(-20.0)                         # an object between the jaws
    steps = [wait(0.3),                                  # Enter: the start, at home
             then(hand(held_omx, 12, -0.3), "c"),        # down to the object: close here
             then(hand(held_omx, 11, 0.5, 0.4), "o"),   # turned to the place: open there
             "q"]
    code = run_cli(monkeypatch, ["teach", "--arm", "omx", "--device", held_omx.port_path,
                                 "--out", str(pick), "--float"], steps)
    err = capsys.readouterr().err
    assert code == 0, err
    assert "an object stopped the jaws" in err
    data = tomllib.loads(pick.read_text())
    assert [w.get("gripper") for w in data["waypoints"]] == [None, "close", "open"]
    wp = files.load_waypoints(pick, OMX)
    assert abs(wp.waypoints[2][1] - wp.waypoints[1][1]) > 0.01      # the place is elsewhere

    # Replay from the place pose, the jaws open, the object back between them.
    assert gripper.hardware_error == 0
    code = run_cli(monkeypatch, ["run", str(pick), "--arm", "omx", "--device",
                                 held_omx.port_path, "--json"])
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    assert code in COMPLETED, captured.err
    assert [leg["waypoints"] for leg in report["legs"]] == [[0, 1], [1, 2]]
    assert [leg["gripper"] for leg in report["legs"]] == ["close", "open"]
    for leg in report["legs"]:
        assert leg["report"]["stop_reason"] == "completed"
    closed = report["legs"][0]["gripper_result"]
    assert closed["blocked"] and closed["settled"]       # the object stopped the jaws: held
    assert report["legs"][1]["gripper_result"]["settled"]
    assert gripper.hardware_error & OVERLOAD == 0 and gripper.torque_enabled
    assert "leg 1/2: waypoints 0..1" in captured.err
    # at rest on the place pose
    x, y, z, pitch = pose_of(held_omx)
    assert np.allclose((x, y, z), wp.waypoints[2][:3], atol=0.004)
    assert abs(pitch - wp.waypoints[2][3]) < np.radians(1.5)


def test_legs_split_at_actions_and_carry_the_payload(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text("""
[plan]
method = "sclerp"
payload_kg = 0.0

[[waypoints]]
x = 0.20
y = 0.0
z = 0.20
pitch_deg = 0

[[waypoints]]
x = 0.20
y = 0.0
z = 0.10
pitch_deg = -30
gripper = "close"
payload_kg = 0.1

[[waypoints]]
x = 0.18
y = 0.08
z = 0.15
pitch_deg = 0
method = "dlb"

[[waypoints]]
x = 0.18
y = 0.08
z = 0.10
pitch_deg = -30
gripper = "open"
""")
    wp = files.load_waypoints(path, OMX)
    fields = waypoints_fields(wp, OMX, PlanOverrides(duration=6.0))
    got = legs(wp, fields, OMX)
    assert [(g.first, g.last, g.gripper, g.payload_kg) for g in got] == [
        (0, 1, "close", 0.0), (1, 3, "open", 0.1)]
    assert got[0].fields["waypoints"][0] == tuple(wp.waypoints[0])
    assert got[1].fields["waypoints"][0] is None          # from where the last leg rests
    assert got[1].fields["method"] == ("dlb", "sclerp")
    assert got[0].fields["duration"] == pytest.approx(2.0)
    assert got[1].fields["duration"] == pytest.approx(4.0)
    assert got[1].fields["payload_kg"] == 0.1


def test_an_action_on_the_first_waypoint_is_a_leg_of_its_own(monkeypatch, capsys, tmp_path):
    path = tmp_path / "first.toml"
    path.write_text("""
[plan]
method = "sclerp"

[[waypoints]]
x = 0.20
y = 0.0
z = 0.20
pitch_deg = 0
gripper = "open"

[[waypoints]]
x = 0.20
y = 0.05
z = 0.12
pitch_deg = -30
gripper = "close"
""")
    wp = files.load_waypoints(path, OMX)
    got = legs(wp, waypoints_fields(wp, OMX, PlanOverrides(method=("dlb",))), OMX)
    assert [(g.first, g.last, g.gripper) for g in got] == [(0, 0, "open"), (0, 1, "close")]
    assert got[0].fields["waypoints"] == [tuple(wp.waypoints[0])] and "method" not in \
        got[0].fields
    assert got[1].fields["method"] == ("dlb",)
    assert run_cli(monkeypatch, ["run", str(path), "--arm", "omx", "--sim", "--json"]) in \
        COMPLETED
    report = json.loads(capsys.readouterr().out)
    assert [leg["gripper_result"]["command"] for leg in report["legs"]] == ["open", "close"]
    assert all(leg["report"]["stop_reason"] == "completed" for leg in report["legs"])


def test_teach_float_release_needs_yes_and_lowers_at_the_end(held_omx, monkeypatch, capsys,
                                                             tmp_path):
    out = tmp_path / "r.toml"
    argv = ["teach", "--arm", "omx", "--device", held_omx.port_path, "--out", str(out),
            "--float", "--release"]
    assert run_cli(monkeypatch, argv, ["", "q"]) == 2          # refused before the float
    assert "--yes confirms" in capsys.readouterr().err and not out.exists()
    assert all(held_omx.servo(i).operating_mode == 3 for i in OMX.servo_ids)
    steps = [wait(0.2), then(hand(held_omx, 12, -0.3), ""), "q"]
    assert run_cli(monkeypatch, [*argv, "--yes"], steps) == 0
    err = capsys.readouterr().err
    assert "after lowering it to its rest pose" in err and out.exists()
    assert not any(held_omx.servo(i).torque_enabled for i in OMX.servo_ids)


def test_run_plots_one_file_a_leg(monkeypatch, capsys, tmp_path):
    path = tmp_path / "legs.toml"
    path.write_text("[[waypoints]]\nx = 0.2\ny = 0.0\nz = 0.2\npitch_deg = 0\n"
                    "gripper = \"open\"\n\n"
                    "[[waypoints]]\nx = 0.2\ny = 0.05\nz = 0.12\npitch_deg = -30\n"
                    "gripper = \"close\"\n")
    png = tmp_path / "legs.png"
    assert run_cli(monkeypatch, ["run", str(path), "--arm", "omx", "--sim", "--plot",
                                 str(png)]) in COMPLETED
    err = capsys.readouterr().err
    for k in (1, 2):
        leg = tmp_path / f"legs-leg{k}.png"
        assert leg.read_bytes()[:4] == b"\x89PNG" and f"plot: {leg}" in err
