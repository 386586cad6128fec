"""``check-config --payload``: per joint the worst holding torque over the joint-limit box
beside the servo's stall torque and the joint's max_torque_nm, and the torque–speed check
of (max_velocity, max_torque_nm)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import CONFIGS
from workflow_helpers import run_cli

from robodcn.config import SERVO_SPECS, load_arm, rigid_chain
from robodcn.dynamics import gravity_torque
from robodcn.workflow.check import summary, torque_check

OMX = load_arm(CONFIGS / "omx.toml")


def test_holding_torques_are_omx_mds_figures():
    """shared/omx.md: ≈ 0.84 N·m stretched out horizontally, ≈ 2.7 N·m with 0.5 kg."""
    empty = {r["name"]: r for r in torque_check(OMX, 0.0)}
    loaded = {r["name"]: r for r in torque_check(OMX, 0.5)}
    assert empty["shoulder"]["holding_torque_nm"] == pytest.approx(0.84, abs=0.02)
    assert loaded["shoulder"]["holding_torque_nm"] == pytest.approx(2.7, abs=0.05)
    assert empty["yaw"]["holding_torque_nm"] == loaded["yaw"]["holding_torque_nm"] == 0.0
    for name in ("shoulder", "elbow", "wrist"):
        assert loaded[name]["holding_torque_nm"] > empty[name]["holding_torque_nm"]
        assert loaded[name]["stall_torque_nm"] == SERVO_SPECS["xm430-w350"].stall_torque
        assert loaded[name]["warnings"] == []


def test_holding_torque_bounds_every_pose_in_the_box():
    """No pose inside the joint limits needs more than the reported worst torque, and one
    pose comes close to it (the box optimum is attained, not an overestimate)."""
    rng = np.random.default_rng(7)
    lo = np.array([j.min_angle for j in OMX.joints])
    hi = np.array([j.max_angle for j in OMX.joints])
    q = lo + (hi - lo) * rng.random((20000, 4))
    need = np.abs(gravity_torque(rigid_chain(OMX), q, 0.5)).max(axis=0)
    worst = np.array([r["holding_torque_nm"] for r in torque_check(OMX, 0.5)])
    assert np.all(need <= worst + 1e-9)
    assert np.all(need[1:] >= 0.95 * worst[1:])


def test_json_gives_joints_in_the_arms_order_and_passes(monkeypatch, capsys):
    assert run_cli(monkeypatch, ["check-config", "omx", "--payload", "0.5", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert [j["name"] for j in data["joints"]] == ["yaw", "shoulder", "elbow", "wrist"]
    for joint, spec in zip(data["joints"], OMX.joints, strict=True):
        assert joint["stall_torque_nm"] == pytest.approx(4.1)
        assert joint["max_torque_nm"] == spec.max_torque
        assert joint["holding_torque_nm"] >= 0.0 and joint["warnings"] == []
    assert data["payload_kg"] == 0.5 and data["warnings"] == []
    assert data["pose_keys"] == ["x", "y", "z", "pitch"]


def test_a_heavy_payload_warns_above_stall_and_max_torque(monkeypatch, capsys):
    assert run_cli(monkeypatch, ["check-config", "omx", "--payload", "2"]) == 0
    out = capsys.readouterr().out
    assert "with a 2 kg payload" in out
    assert "! joint 'shoulder': holding torque 8.3" in out
    assert "exceeds the servo's stall torque 4.10 N·m" in out
    assert "! joint 'wrist': holding torque 2.5" in out and "max_torque_nm 2.30" in out


def test_default_payload_is_the_arms(tmp_path):
    text = (CONFIGS / "omx.toml").read_text().replace("payload_kg = 0.0", "payload_kg = 0.5")
    path = tmp_path / "loaded.toml"
    path.write_text(text)
    arm = load_arm(path)
    assert summary(arm)["payload_kg"] == 0.5
    assert [r["holding_torque_nm"] for r in torque_check(arm)] == \
        [r["holding_torque_nm"] for r in torque_check(OMX, 0.5)]


def test_max_torque_above_the_torque_speed_line_warns(tmp_path, monkeypatch, capsys):
    """available = 4.1 × (1 − 1.5 / 4.82) ≈ 2.82 N·m at the shoulder's 1.5 rad/s."""
    text = (CONFIGS / "omx.toml").read_text().replace("max_torque_nm = 2.8",
                                                      "max_torque_nm = 3.5")
    path = tmp_path / "hot.toml"
    path.write_text(text)
    rows = {r["name"]: r for r in torque_check(load_arm(path))}
    assert rows["shoulder"]["available_torque_nm"] == pytest.approx(
        4.1 * (1 - 1.5 / (46 * 2 * np.pi / 60)))
    assert len(rows["shoulder"]["warnings"]) == 1
    assert "torque–speed line" in rows["shoulder"]["warnings"][0]
    assert rows["wrist"]["warnings"] == []
    assert run_cli(monkeypatch, ["check-config", str(path)]) == 0
    assert "! joint 'elbow': max_torque_nm 3.50 N·m lies above" in capsys.readouterr().out


def test_a_planar_arm_without_gravity_shows_no_torque_table(monkeypatch, capsys):
    assert run_cli(monkeypatch, ["check-config", "arm3r"]) == 0
    assert "holding torque" not in capsys.readouterr().out


def test_payload_must_be_a_number_at_least_zero(monkeypatch, capsys):
    with pytest.raises(SystemExit) as exit_:
        run_cli(monkeypatch, ["check-config", "omx", "--payload", "-1"])
    assert exit_.value.code == 2 and "--payload" in capsys.readouterr().err


# -- --payload on the planning commands (issue 19) ------------------------------------------------

def test_plan_payload_reaches_the_request(monkeypatch, capsys):
    from robodcn.planner import Trajectory

    assert run_cli(monkeypatch, ["plan", "--arm", "arm3r", "--to", "0.2,0.1,0", "--payload",
                                 "0.5", "--format", "json", "-q"]) == 0
    assert Trajectory.from_json(capsys.readouterr().out).request.payload_kg == 0.5
    assert run_cli(monkeypatch, ["plan", "--arm", "arm3r", "--to", "0.2,0.1,0", "--format",
                                 "json", "-q"]) == 0
    assert Trajectory.from_json(capsys.readouterr().out).request.payload_kg == 0.0  # the arm's


def test_run_payload_overrides_the_files_and_a_timed_file_refuses_it(tmp_path):
    import argparse

    from robodcn.cli.run_cmd import load_run_file
    from robodcn.config import load_arm

    arm = load_arm(CONFIGS / "arm3r.toml")
    path = tmp_path / "w.toml"
    path.write_text("[plan]\npayload_kg = 0.2\n\n[[waypoints]]\nx = 0.25\ny = 0.1\n\n"
                    "[[waypoints]]\nx = 0.12\ny = 0.24\ntheta_deg = 60\n")

    def args(**kw):
        base = dict(file=str(path), method=None, beta=None, turn=None, duration=None,
                    profile=None, blend=None, rate=None, payload=None)
        return argparse.Namespace(**{**base, **kw})

    assert load_run_file(args(), arm)[1]["payload_kg"] == 0.2
    assert load_run_file(args(payload=0.4), arm)[1]["payload_kg"] == 0.4
    path.write_text(path.read_text().replace("payload_kg = 0.2", "payload_kg = -1"))
    with pytest.raises(Exception, match=r"plan\.payload_kg: must be"):
        load_run_file(args(), arm)
