"""check-config, config example and the packaged example arms (--arm NAME from anywhere)."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
from conftest import ROOT
from workflow_helpers import ARM2R, ARM3R, run_cli

from robodcn import kinematics
from robodcn.config import load_arm
from robodcn.workflow.check import summary, workspace_samples
from robodcn.workflow.examples import EXAMPLES, example_path, resolve_arm


def test_packaged_examples_are_the_configs():
    for name in EXAMPLES:
        assert example_path(name).read_bytes() == (ROOT / "configs" / f"{name}.toml").read_bytes()


def test_config_example_prints_the_file(monkeypatch, capsys):
    assert run_cli(monkeypatch, ["config", "example", "arm2r"]) == 0
    assert capsys.readouterr().out == open(ARM2R).read()
    assert run_cli(monkeypatch, ["config", "example"]) == 0
    assert capsys.readouterr().out == open(ARM3R).read()


def test_example_names_work_from_any_directory(tmp_path):
    code = ("import sys; from robodcn.workflow import resolve_arm; "
            "print(resolve_arm('arm2r').name, resolve_arm(None).name)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["arm2r", "arm3r"]
    out = subprocess.run([sys.executable, "-m", "robodcn", "config", "example", "arm3r"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=60)
    assert out.returncode == 0 and load_arm(ARM3R).name in out.stdout


def test_resolve_arm_prefers_a_file_and_env(tmp_path, monkeypatch):
    mine = tmp_path / "arm2r"                  # a file called like an example wins
    mine.write_text(open(ARM2R).read().replace('name = "arm2r"', 'name = "mine"'))
    monkeypatch.chdir(tmp_path)
    assert resolve_arm("arm2r").name == "mine"
    monkeypatch.setenv("ROBODCN_ARM", "arm3r")
    assert resolve_arm(None).name == "arm3r"


def test_check_config_summary(monkeypatch, capsys):
    assert run_cli(monkeypatch, ["check-config", ARM3R]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"{ARM3R}: OK") and "0.050..0.350 m" in out
    assert "wrist" in out and "-1" in out and "1000000 baud" in out
    assert run_cli(monkeypatch, ["check-config", "arm2r", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["dof"] == 2 and not data["full_pose"]
    assert [j["servo"]["id"] for j in data["joints"]] == [1, 2]


def test_summary_tick_ranges_follow_direction():
    arm = load_arm(ARM3R)
    wrist = summary(arm)["joints"][2]
    lo, hi = wrist["tick_range_angles"]
    # direction −1: tick 0 is +180°, tick 4095 is −179.9°.
    assert math.isclose(hi, math.pi) and math.isclose(lo, -math.pi * 4094 / 4096)


def test_check_config_flags_joint_limits_beyond_the_ticks(tmp_path, monkeypatch, capsys):
    path = tmp_path / "narrow.toml"
    path.write_text(open(ARM3R).read().replace("min_tick = 0", "min_tick = 1500", 1))
    assert run_cli(monkeypatch, ["check-config", str(path)]) == 0
    assert "joint limits exceed the tick range" in capsys.readouterr().out


def test_check_config_bad_files(tmp_path, monkeypatch, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(open(ARM3R).read().replace("id = 2", "id = 1"))
    assert run_cli(monkeypatch, ["check-config", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "joints[1].servo.id" in err and str(bad) in err
    assert run_cli(monkeypatch, ["check-config", str(tmp_path / "none.toml")]) == 2
    assert "none.toml" in capsys.readouterr().err
    assert run_cli(monkeypatch, ["check-config", ARM3R, "--plot",
                                 str(tmp_path / "no" / "dir.png")]) == 2
    assert "--plot" in capsys.readouterr().err


def test_check_config_plot(tmp_path, monkeypatch, capsys):
    png = tmp_path / "ws.png"
    assert run_cli(monkeypatch, ["check-config", "arm2r", "--plot", str(png)]) == 0
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 10_000


def test_workspace_samples_stay_inside_the_annulus_and_limits():
    arm = load_arm(ARM3R)
    poses = workspace_samples(arm, per_joint=9)
    assert poses.shape == (9 ** 3, 3)
    inner, outer = kinematics.workspace(arm.links)
    r = kinematics.wrist_radius(arm.links, poses)
    assert np.all((r >= inner - 1e-9) & (r <= outer + 1e-9))


def test_readme_workflow_commands_that_need_no_servos_run(tmp_path):
    readme = (ROOT / "README.md").read_text()
    block = readme.split("## Everyday workflow", 1)[1].split("```sh\n", 1)[1].split("```")[0]
    commands = [line.split("  #")[0].strip() for line in block.splitlines()]
    offline = [c for c in commands if c.startswith(("robodcn config", "robodcn check-config"))]
    assert len(offline) == 2
    for command in offline:
        args, _, redirect = command.removeprefix("robodcn ").partition(" > ")
        out = subprocess.run([sys.executable, "-m", "robodcn", *args.split()],
                             capture_output=True, text=True, cwd=tmp_path, timeout=120)
        assert out.returncode == 0, (command, out.stderr)
        if redirect:
            (tmp_path / redirect).write_text(out.stdout)
    assert (tmp_path / "ws.png").stat().st_size > 0
    assert load_arm(tmp_path / "my.toml").name == "arm2r"


def test_every_workflow_command_has_help_and_a_description():
    import argparse

    from robodcn.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    helps = {c.dest: c.help for c in sub._choices_actions}
    names = ["calibrate", "teach", "run", "pose", "torque", "reboot", "servo", "check-config",
             "config"]
    for name in names:
        assert len(helps[name]) > 15, name
        command = sub.choices[name]
        assert len(command.description or "") > 20, name
        text = command.format_help()
        for action in command._actions:
            if action.option_strings and action.dest != "help":
                assert action.help, (name, action.option_strings)
        if name not in ("check-config", "config", "servo"):
            assert "--device" in text and "--baud" in text and "--arm" in text, name
