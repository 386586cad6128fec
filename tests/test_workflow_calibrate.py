"""robodcn calibrate end to end: the real dynamixel-sdk against firmware_sim on a pty, the
arm moved by hand through the simulator's backdrive of torque-off servos."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
from workflow_helpers import ARM3R, NO_DEVICE, backdrive, run_cli, settle

from robodcn.config import load_arm
from robodcn.workflow.calibrate import Calibration, JointCalibration, updated_toml

#: Where the "real" arm's joint angles are 0, and which way each joint turns.
TRUE_ZERO = {1: 2100, 2: 1900, 3: 2300}
pytest_plugins = ["workflow_fixtures"]     # fixtures: sim
MARGIN = math.ceil(2.0 / 360.0 * 4096)     # the default --margin of 2°


def _steps(sim, *, shoulder_range=(500, 3600), wrist_range=(800, 3900)):
    def to(ticks, then=""):
        def step():
            backdrive(sim, ticks)
            return then
        return step

    def sweep(servo_id, lo, hi, back):
        def step():
            # By hand: in steps of at most 400 ticks, pausing at the ends.
            start = TRUE_ZERO[servo_id]
            path = [*np.linspace(start, lo, 6)[1:], *np.linspace(lo, hi, 9)[1:],
                    *np.linspace(hi, back, 6)[1:]]
            for tick in path:
                backdrive(sim, {servo_id: round(tick)})
                settle(sim, 3 if tick in (lo, hi) else 1)
            return ""
        return step

    return [to(TRUE_ZERO),                                   # reference pose
            to({1: TRUE_ZERO[1] + 200}),                     # shoulder +: ticks up
            sweep(1, *shoulder_range, TRUE_ZERO[1]),
            to({2: TRUE_ZERO[2] - 300}),                     # elbow +: ticks down
            "s",                                             # skip the elbow's range
            to({3: TRUE_ZERO[3] + 150}),                     # wrist +: ticks up
            sweep(3, *wrist_range, TRUE_ZERO[3])]


def test_calibrate_writes_offsets_directions_and_ranges(sim, monkeypatch, tmp_path,
                                                        capsys):
    out = tmp_path / "arm.toml"
    sim.servo(2).write(64, b"\x01")                          # torque on: calibrate turns it off
    code = run_cli(monkeypatch, ["calibrate", "--arm", ARM3R, "--device", sim.port_path,
                                 "--out", str(out), "--yes"], _steps(sim))
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert not any(s.torque_enabled for s in sim.servos)
    arm = load_arm(out)
    servos = {j.name: j.servo for j in arm.joints}
    assert [s.zero_offset for s in arm.servos] == [TRUE_ZERO[1], TRUE_ZERO[2], TRUE_ZERO[3]]
    assert [s.direction for s in arm.servos] == [1, -1, 1]
    assert (servos["shoulder"].min_tick, servos["shoulder"].max_tick) == (500 + MARGIN,
                                                                          3600 - MARGIN)
    assert (servos["wrist"].min_tick, servos["wrist"].max_tick) == (800 + MARGIN, 3900 - MARGIN)
    assert (servos["elbow"].min_tick, servos["elbow"].max_tick) == (0, 4095)   # skipped
    per_tick = 360.0 / 4096
    for joint in arm.joints:
        s = joint.servo
        if joint.name == "elbow":
            assert math.degrees(joint.max_angle) == 160.0
            continue
        ends = sorted(s.direction * (t - s.zero_offset) * per_tick for t in (s.min_tick,
                                                                             s.max_tick))
        # Joint limits inside the tick range, rounded inward by less than 0.1°.
        assert ends[0] <= math.degrees(joint.min_angle) < ends[0] + 0.1 + 1e-9
        assert ends[1] - 0.1 - 1e-9 < math.degrees(joint.max_angle) <= ends[1]
    text = out.read_text()
    original = Path(ARM3R).read_text()
    assert text.splitlines()[:3] == original.splitlines()[:3]          # comments kept
    assert "# metres: shoulder→elbow" in text
    assert "-zero_offset = 2048" in captured.out and "+zero_offset = 2100" in captured.out
    # With the new file the reference pose reads as joint angles 0.
    backdrive(sim, TRUE_ZERO)
    code = run_cli(monkeypatch, ["pose", "--arm", str(out), "--device", sim.port_path,
                                 "--json"])
    state = json.loads(capsys.readouterr().out)
    assert code == 0 and np.allclose(state["joints"], 0.0, atol=1e-12)


def test_range_across_the_tick_wrap_is_noted_and_left(sim, monkeypatch, tmp_path,
                                                      capsys):
    out = tmp_path / "arm.toml"
    code = run_cli(monkeypatch, ["calibrate", "--arm", ARM3R, "--device", sim.port_path,
                                 "--out", str(out), "--yes"],
                   _steps(sim, shoulder_range=(-300, 3600)))
    err = capsys.readouterr().err
    assert code == 0, err
    assert "Extended Position Mode" in err and "'shoulder'" in err
    shoulder = load_arm(out).joints[0]
    assert (shoulder.servo.min_tick, shoulder.servo.max_tick) == (0, 4095)
    assert shoulder.servo.zero_offset == TRUE_ZERO[1]


def test_declining_writes_nothing(sim, monkeypatch, tmp_path, capsys):
    out = tmp_path / "arm.toml"
    code = run_cli(monkeypatch, ["calibrate", "--arm", ARM3R, "--device", sim.port_path,
                                 "--out", str(out), "--no-ranges"],
                   [s for i, s in enumerate(_steps(sim)) if i in (0, 1, 3, 5)]
                   + ["n"])
    assert code == 1                               # declined: not Ctrl-C's 130
    assert "not written" in capsys.readouterr().err and not out.exists()


def test_a_joint_that_does_not_move_is_an_error_naming_it(sim, monkeypatch,
                                                          tmp_path, capsys):
    out = tmp_path / "arm.toml"
    code = run_cli(monkeypatch, ["calibrate", "--arm", ARM3R, "--device", sim.port_path,
                                 "--out", str(out), "--yes", "--no-ranges"], ["", ""])
    err = capsys.readouterr().err
    assert code == 2 and "joint 'shoulder' moved 0 ticks" in err and not out.exists()


def test_input_ending_early_writes_nothing(sim, monkeypatch, tmp_path, capsys):
    out = tmp_path / "arm.toml"
    code = run_cli(monkeypatch, ["calibrate", "--arm", ARM3R, "--device", sim.port_path,
                                 "--out", str(out)], [""])
    assert code == 2 and "input ended" in capsys.readouterr().err and not out.exists()


def test_existing_out_needs_force_before_the_bus_opens(monkeypatch, tmp_path, capsys):
    out = tmp_path / "arm.toml"
    out.write_text("keep me")
    code = run_cli(monkeypatch, ["calibrate", "--arm", ARM3R, "--device", NO_DEVICE, "--out",
                                 str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "--out" in err and "--force" in err and str(out) in err
    assert out.read_text() == "keep me"


def test_bad_margin_and_arm_are_rejected(monkeypatch, tmp_path, capsys):
    out = str(tmp_path / "x.toml")
    code = run_cli(monkeypatch, ["calibrate", "--arm", "arm9r", "--device", NO_DEVICE,
                                 "--out", out])
    assert code == 2 and "'arm9r'" in capsys.readouterr().err
    try:
        run_cli(monkeypatch, ["calibrate", "--device", NO_DEVICE, "--out", out, "--margin",
                              "-1"])
    except SystemExit as exc:
        assert exc.code == 2
    assert "--margin" in capsys.readouterr().err


def test_updated_toml_keeps_radian_keys_in_radians():
    text = Path(ARM3R).read_text().replace("min_deg = -170.0", "min = -2.9", 1)
    cal = Calibration(tuple(JointCalibration(n, 2048, 1, 100, 4000, -1.5, 1.5)
                            for n in ("shoulder", "elbow", "wrist")))
    data = tomllib.loads(updated_toml(text, cal))
    assert data["joints"][0]["min"] == -1.5 and "min_deg" not in data["joints"][0]
    assert data["joints"][1]["min_deg"] == round(math.degrees(-1.5), 1)
    assert data["joints"][2]["servo"]["direction"] == 1


def test_a_joint_that_did_not_move_is_asked_again_and_the_rest_kept(sim, monkeypatch,
                                                                     tmp_path, capsys):
    """No motion in a direction step: asked again (the joints done are kept), 's' skips."""
    out = tmp_path / "arm.toml"
    steps = _steps(sim)
    script = [steps[0], steps[1], steps[2],                  # reference, shoulder done
              "",                                            # elbow: not moved yet
              steps[3], "s",                                 # moved now; skip its range
              "", "s"]                                       # wrist never moves: skipped
    code = run_cli(monkeypatch, ["calibrate", "--arm", ARM3R, "--device", sim.port_path,
                                 "--out", str(out), "--yes"], script)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "joint 'elbow' moved 0 ticks" in captured.err and "s: skip this joint" in captured.err
    assert "joint 'wrist': skipped" in captured.err
    arm = load_arm(out)
    original = load_arm(ARM3R)
    assert [s.zero_offset for s in arm.servos] == [TRUE_ZERO[1], TRUE_ZERO[2], TRUE_ZERO[3]]
    assert [s.direction for s in arm.servos] == [1, -1, original.servos[2].direction]
    shoulder = arm.joints[0].servo
    assert (shoulder.min_tick, shoulder.max_tick) == (500 + MARGIN, 3600 - MARGIN)
    wrist, was = arm.joints[2], original.joints[2]
    assert (wrist.servo.min_tick, wrist.servo.max_tick) == (was.servo.min_tick,
                                                            was.servo.max_tick)
    assert (wrist.min_angle, wrist.max_angle) == (was.min_angle, was.max_angle)
