"""Issue 27 §3: ``robodcn run`` checks every leg of a waypoints file before anything moves,
names the file's own waypoints and fields in its errors, and runs on the arm the file
names. On firmware_sim's physics OpenMANIPULATOR-X (its pty, the real dynamixel-sdk) and,
for the library, against :func:`robodcn.workflow.run.plan_legs` itself."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from omx_helpers import OMX, pose_of
from workflow_helpers import ARM3R, COMPLETED, run_cli

from robodcn import kinematics
from robodcn.errors import TorqueLimitError
from robodcn.workflow import files
from robodcn.workflow.run import PlanOverrides, legs, plan_legs, waypoints_fields

pytest_plugins = ["omx_helpers"]     # fixtures: held_omx

#: A pick and place on the OM-X whose object (waypoint 1's payload_kg, {payload}) is
#: carried from waypoint 1 on: leg 1 is 0..1 (then close), leg 2 is 1..3 (then open).
PICK = """arm = "omx"

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
payload_kg = {payload}

[[waypoints]]
x = 0.18
y = 0.08
z = 0.15
pitch_deg = 0

[[waypoints]]
x = 0.18
y = 0.08
z = 0.10
pitch_deg = -30
gripper = "open"
"""


@pytest.fixture(autouse=True)
def _no_arm_in_the_environment(monkeypatch):
    monkeypatch.delenv("ROBODCN_ARM", raising=False)


def wire_state(sim) -> dict[int, tuple]:
    """Per servo (the gripper too): every goal it accepted and its torque: what a command
    would change (a held servo's present position settles by a tick or two under gravity
    whatever is sent; :func:`positions` has it)."""
    return {i: (tuple(sim.goal_history(i)), sim.servo(i).torque_enabled)
            for i in (*OMX.servo_ids, OMX.gripper.servo.id)}


def positions(sim) -> list[int]:
    return [sim.servo(i).present_position for i in (*OMX.servo_ids, OMX.gripper.servo.id)]


def still(before: list[int], after: list[int]) -> bool:
    """Nothing moved: every present position within 2 ticks (a held servo settling)."""
    return max(abs(a - b) for a, b in zip(before, after, strict=True)) <= 2


def test_a_later_leg_the_torque_cannot_carry_moves_nothing(held_omx, monkeypatch, capsys,
                                                           tmp_path):
    path = tmp_path / "pick.toml"
    path.write_text(PICK.format(payload=3.0))
    before, where = wire_state(held_omx), positions(held_omx)
    code = run_cli(monkeypatch, ["run", str(path), "--device", held_omx.port_path])
    err = capsys.readouterr().err
    assert code == 3, err
    assert wire_state(held_omx) == before           # no goal, no gripper action, no torque
    assert still(where, positions(held_omx))
    # refused before timing (planner.holding): the waypoint the arm cannot hold, numbered
    # as the file numbers it
    assert err.startswith(f"robodcn: {path}: leg 2 of 2 (waypoints 1..3): waypoint 1 "
                          "(x=0.2000 m, y=0.0000 m, z=0.1000 m, pitch=-30.0°): joint ")
    assert err.endswith("lighten waypoint 1 (payload_kg = 3 in the file) or avoid that "
                        "pose\n")
    assert "--payload" not in err and "leg 1/2" not in err


def test_every_leg_is_planned_from_where_the_one_before_ends(tmp_path):
    path = tmp_path / "pick.toml"
    path.write_text(PICK.format(payload=0.1))
    wp = files.load_waypoints(path, OMX)
    leg_list = legs(wp, waypoints_fields(wp, OMX, PlanOverrides()), OMX)
    present = np.array([0.3, -0.2, 0.4, 0.1])
    first, second = plan_legs(OMX, leg_list, present, source=str(path))
    assert np.allclose(first.joints[0], present)
    assert np.allclose(second.joints[0], first.joints[-1])
    ends = [kinematics.fk_yawed(OMX.chain, t.joints[-1:])[0] for t in (first, second)]
    assert np.allclose(ends, wp.waypoints[[1, 3]], atol=1e-6)


def test_a_leg_error_is_in_the_file_terms_for_the_library(tmp_path):
    path = tmp_path / "pick.toml"
    path.write_text(PICK.format(payload=0.1))
    wp = files.load_waypoints(path, OMX)
    leg_list = legs(wp, waypoints_fields(wp, OMX, PlanOverrides()), OMX)
    heavy = dataclasses.replace(leg_list[1], fields={**leg_list[1].fields, "payload_kg": 3.0})
    with pytest.raises(TorqueLimitError) as caught:
        plan_legs(OMX, [leg_list[0], heavy], OMX.home, source=str(path))
    exc = caught.value
    assert exc.leg == (2, 2, 1, 3)
    assert exc.violation.waypoint == 1 and exc.violation.sample is None
    assert exc.violation.field == "waypoints[1].payload_kg" and \
        exc.field == "waypoints[1].payload_kg"
    assert exc.message.startswith(f"{path}: leg 2 of 2 (waypoints 1..3): waypoints[1] (")
    assert exc.message.endswith("lighten waypoints[1].payload_kg or avoid that pose")


def test_a_too_short_file_duration_names_the_file_field(monkeypatch, capsys, tmp_path):
    path = tmp_path / "quick.toml"
    path.write_text(PICK.format(payload=0.1).replace('arm = "omx"\n',
                                                     'arm = "omx"\n[plan]\nduration = 0.3\n'))
    code = run_cli(monkeypatch, ["run", str(path), "--sim"])
    err = capsys.readouterr().err
    assert code == 3, err
    assert err.endswith(": lengthen [plan] duration (0.3 s in the file)\n") and \
        "--duration" not in err


def test_run_without_arm_runs_on_the_arm_the_file_names(held_omx, monkeypatch, capsys,
                                                        tmp_path):
    path = tmp_path / "taught.toml"
    path.write_text('arm = "omx"\n\n[[waypoints]]\nx = 0.20\ny = 0.0\nz = 0.20\n'
                    'pitch_deg = 0\n\n[[waypoints]]\nx = 0.18\ny = 0.05\nz = 0.15\n'
                    'pitch_deg = -20\n')
    code = run_cli(monkeypatch, ["run", str(path), "--device", held_omx.port_path, "--json"])
    captured = capsys.readouterr()
    assert code in COMPLETED, captured.err
    assert "warning" not in captured.err
    assert json.loads(captured.out)["stop_reason"] == "completed"
    x, y, z, pitch = pose_of(held_omx)
    assert np.allclose((x, y, z), (0.18, 0.05, 0.15), atol=0.004)
    assert abs(np.degrees(pitch) + 20) < 1.5


def test_run_on_another_arm_than_the_file_names_warns(monkeypatch, capsys, tmp_path):
    path = tmp_path / "planar.toml"
    path.write_text('arm = "arm2r"\n\n[[waypoints]]\nx = 0.20\ny = 0.10\ntheta_deg = 30\n\n'
                    '[[waypoints]]\nx = 0.15\ny = 0.20\ntheta_deg = 60\n')
    code = run_cli(monkeypatch, ["run", str(path), "--arm", ARM3R, "--sim"])
    err = capsys.readouterr().err
    assert code in COMPLETED, err
    assert err.startswith(f"robodcn: warning: {path} was taught on arm 'arm2r'; running on "
                          "arm 'arm3r' (--arm)\n")
    assert run_cli(monkeypatch, ["run", str(path), "--arm", "arm2r", "--sim"]) in COMPLETED
    assert "warning" not in capsys.readouterr().err


def test_a_file_naming_an_unknown_arm_is_refused_before_the_bus(monkeypatch, capsys,
                                                                tmp_path):
    path = tmp_path / "p.toml"
    path.write_text('arm = "my-arm"\n\n[[waypoints]]\nx = 0.2\ny = 0.1\n\n'
                    '[[waypoints]]\nx = 0.15\ny = 0.2\n')
    code = run_cli(monkeypatch, ["run", str(path), "--device", "/dev/robodcn-no-such"])
    assert code == 2
    assert capsys.readouterr().err == (
        f"robodcn: {path}: arm: 'my-arm' is neither a file nor an example arm (arm3r, "
        "arm2r, omx)\n")
