"""calibrate's dialogue as a user meets it: `s` skips a joint at its first prompt, `n` at
"write?" is exit 1, and an arm with a [gripper] gets a step for its open and closed angles
(the real dynamixel-sdk against firmware_sim, the jaws moved by hand through backdrive)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from workflow_helpers import ARM3R, backdrive, run_cli

from firmware_sim.bus import SimBus
from robodcn.config import load_arm

GRIPPER = """
[gripper]
id = 4
model = "xm430-w350"
open_deg = 60.0
closed_deg = -60.0
open_width_mm = 75.0
closed_width_mm = 20.0
grip_current_a = 0.5
"""


@pytest.fixture
def arm_with_gripper(tmp_path: Path) -> Path:
    path = tmp_path / "arm3r-gripper.toml"
    path.write_text(Path(ARM3R).read_text(encoding="utf-8") + GRIPPER, encoding="utf-8")
    return path


@pytest.fixture
def sim4():
    with SimBus((1, 2, 3, 4), timing="fast", log=False) as bus:
        yield bus


def _to(sim, ticks):
    def step():
        backdrive(sim, ticks)
        return ""
    return step


def test_s_at_a_joint_s_first_prompt_skips_it_and_the_gripper_step_writes_its_angles(
        sim4, arm_with_gripper, monkeypatch, tmp_path, capsys):
    out = tmp_path / "calibrated.toml"
    reference = {1: 2048, 2: 2048, 3: 2048}
    open_tick, closed_tick = 2048 + 600, 2048 - 500
    script = [_to(sim4, reference),
              "s", "s", "s",                          # every joint skipped at its first prompt
              _to(sim4, {4: open_tick}), _to(sim4, {4: closed_tick})]
    code = run_cli(monkeypatch, ["calibrate", "--arm", str(arm_with_gripper), "--device",
                                 sim4.port_path, "--out", str(out), "--no-ranges", "--yes"],
                   script)
    err = capsys.readouterr().err
    assert code == 0, err
    assert "(s: skip this joint)" in err
    for name in ("shoulder", "elbow", "wrist"):
        assert f"joint {name!r}: skipped" in err
    assert "fully open" in err and "fully closed" in err
    gripper = load_arm(out).gripper
    assert math.degrees(gripper.open_angle) == pytest.approx(600 * 360 / 4096, abs=0.05)
    assert math.degrees(gripper.closed_angle) == pytest.approx(-500 * 360 / 4096, abs=0.05)
    assert not sim4.servo(4).torque_enabled            # the jaws were left free to move


def test_a_skipped_gripper_keeps_its_angles(sim4, arm_with_gripper, monkeypatch, tmp_path,
                                            capsys):
    out = tmp_path / "calibrated.toml"
    code = run_cli(monkeypatch, ["calibrate", "--arm", str(arm_with_gripper), "--device",
                                 sim4.port_path, "--out", str(out), "--no-ranges", "--yes"],
                   [_to(sim4, {1: 2048, 2: 2048, 3: 2048}), "s", "s", "s", "s"])
    assert code == 0, capsys.readouterr().err
    before, after = load_arm(arm_with_gripper).gripper, load_arm(out).gripper
    assert (after.open_angle, after.closed_angle) == (before.open_angle, before.closed_angle)
