"""Where the arm ended, honestly (issue 26 §5): every completed move compares the final
measured position with its goal; a joint at rest beyond its in-position tolerance (arm file
``in_position_deg``, default 3 ticks) ends the move ``degraded`` — exit 5 on the command
line, status ``degraded`` over HTTP — naming each joint's error in degrees, and ``done``
means in position. On firmware_sim's physics omx carrying another payload than the plan
declares (the sim's arm file says what it carries, the plan's ``payload_kg`` what it
expects), as on a real arm whose load was misdeclared."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from conftest import CONFIGS
from http_helpers import LOADED_MACHINE, call, poll_move, running
from workflow_helpers import run_cli

from robodcn.cli.exit_codes import Exit
from robodcn.config import IN_POSITION_TICKS, arm_from_dict, load_arm
from robodcn.errors import ConfigError
from robodcn.stream.in_position import position_misses, tolerance_ticks

OMX = load_arm(CONFIGS / "omx.toml")
#: The issue's goal: x, y, z (m), pitch (deg).
GOAL_ARG = "0.2,0,0.15,0"
GOAL = [0.2, 0.0, 0.15, 0.0]
#: kg the simulated arm carries in the mismatch cases: well within the omx's 0.5 kg, enough
#: for a P loop planned for none to rest ~20 ticks short.
CARRIED_KG = 0.3
TICK_DEG = 360.0 / 4096


def omx_carrying(kg: float, tmp_path=None) -> Any:
    """The packaged omx whose ``[dynamics] payload_kg`` is ``kg``: the arm file the
    simulator reads (what the arm carries); written to ``tmp_path`` as TOML when given
    (returns the path), else the Arm."""
    text = (CONFIGS / "omx.toml").read_text()
    assert "payload_kg = 0.0 " in text
    text = text.replace("payload_kg = 0.0 ", f"payload_kg = {kg} ", 1)
    if tmp_path is None:
        import tomllib

        return arm_from_dict(tomllib.loads(text), source=f"omx carrying {kg} kg")
    path = tmp_path / "omx-carrying.toml"
    path.write_text(text)
    return path


def _check_misses(report: dict[str, Any]) -> None:
    """Every miss is beyond its tolerance, its degrees are its ticks', and it is the final
    position against the plan's last sample."""
    goal = np.array(report["goal_ticks"])
    final = np.array(report["final_positions"])
    names = report["joint_names"]
    for miss in report["out_of_position"]:
        j = names.index(miss["joint"])
        assert miss["error_ticks"] == final[j] - goal[j]
        assert abs(miss["error_ticks"]) > report["in_position_ticks"][j]
        assert math.degrees(miss["error_rad"]) == pytest.approx(miss["error_ticks"] * TICK_DEG)


# -- the arm file and the check ---------------------------------------------------------------

def test_the_arm_file_sets_each_joints_tolerance_in_degrees():
    doc = OMX.to_dict()
    doc["joints"][2]["in_position_deg"] = 0.5
    arm = arm_from_dict(doc)
    assert arm.joints[2].in_position_tolerance == pytest.approx(math.radians(0.5))
    assert arm.joints[1].in_position_tolerance == pytest.approx(
        IN_POSITION_TICKS * 2 * math.pi / 4096)
    # 0.5° is 5.69 ticks: five whole ticks; the others keep the default
    assert tolerance_ticks(arm.servos, arm).tolist() == [3, 3, 5, 3]
    assert arm_from_dict(arm.to_dict()).joints[2].in_position == arm.joints[2].in_position
    for bad in (20.0, 0.01, -1.0):
        doc["joints"][2]["in_position_deg"] = bad
        with pytest.raises(ConfigError) as info:
            arm_from_dict(doc, source="omx.toml")
        assert info.value.key == "joints[2].in_position_deg"
        assert "one tick" in info.value.message


def test_a_miss_is_named_with_its_error_in_joint_degrees():
    servos = OMX.servos
    misses = position_misses([2048, 2000, 2060, 2051], [2048, 2048, 2048, 2048],
                             [3, 3, 3, 3], servos, OMX.joint_names)
    assert [(m.joint, m.error_ticks) for m in misses] == [("shoulder", -48), ("elbow", 12)]
    assert math.degrees(misses[0].error_rad) == pytest.approx(-48 * TICK_DEG)
    assert position_misses([2048, 2045, 2051, 2048], [2048] * 4, [3] * 4, servos,
                           OMX.joint_names) == ()


# -- the command line ------------------------------------------------------------------------------

def test_the_issues_sim_with_a_payload_it_does_not_carry_exits_5_naming_the_joints(
        monkeypatch, capsys):
    """``sim --payload 0.8`` on an arm carrying nothing (``--sim-payload 0``: the dry run
    carries the declared payload unless told otherwise, issue 27 §2): the goals led for
    0.8 kg leave it ~5° off; it said ``completed``, exit 0."""
    code = run_cli(monkeypatch, ["sim", "--arm", "omx", "--to", GOAL_ARG, "--payload", "0.8",
                                 "--sim-payload", "0", "--timing", "fast"])
    out = capsys.readouterr().out
    assert code == Exit.DEGRADED
    headline, *lines = out.splitlines()
    assert "out of position: shoulder" in headline and "elbow" in headline
    line = next(x for x in lines if x.startswith("  out of position: "))
    for name in ("shoulder", "elbow", "wrist"):
        assert f"{name} -" in line and "° (" in line
    assert "tolerance 0.26°" in line


def test_a_heavier_payload_than_planned_ends_degraded_with_the_errors_in_degrees(
        monkeypatch, capsys, tmp_path):
    arm_file = omx_carrying(CARRIED_KG, tmp_path)
    code = run_cli(monkeypatch, ["sim", "--arm", str(arm_file), "--to", GOAL_ARG,
                                 "--payload", "0", "--sim-payload", str(CARRIED_KG),
                                 "--timing", "fast", "--json"])
    report = json.loads(capsys.readouterr().out)
    assert code == Exit.DEGRADED, report["headline"]
    assert (report["sim_payload_kg"], report["planned_payload_kg"]) == (CARRIED_KG, 0.0)
    assert report["stop_reason"] == "completed" and report["outcome"] == "degraded"
    assert report["completed"] is False
    sagged = {m["joint"] for m in report["out_of_position"]}
    assert {"shoulder", "elbow"} <= sagged
    _check_misses(report)
    assert "out of position: " in report["headline"]


def test_a_move_with_its_payload_declared_ends_in_position(monkeypatch, capsys, tmp_path):
    arm_file = omx_carrying(CARRIED_KG, tmp_path)
    code = run_cli(monkeypatch, ["sim", "--arm", str(arm_file), "--to", GOAL_ARG,
                                 "--payload", str(CARRIED_KG), "--timing", "fast", "--json"])
    report = json.loads(capsys.readouterr().out)
    if report["skipped"]:
        # a host stall on the loaded test machine (see the HTTP test below)
        assert (code, report["outcome"]) == (Exit.DEGRADED, "degraded")
        return
    assert report["out_of_position"] == [], report["headline"]
    error = np.array(report["final_positions"]) - np.array(report["goal_ticks"])
    assert np.all(np.abs(error) <= np.array(report["in_position_ticks"]))
    assert (code, report["outcome"]) == (Exit.DONE, "done")


# -- HTTP -----------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def carrying_server() -> Iterator[Any]:
    """A service planning for the packaged omx (payload 0 kg unless a body says) on a
    simulated omx that carries :data:`CARRIED_KG`."""
    from robodcn.controller import ArmController
    from robodcn.http import make_server
    from robodcn.simulated import simulated_arm

    with simulated_arm(omx_carrying(CARRIED_KG), timing="fast") as sa:
        controller = ArmController(OMX, sa.bus, execute_options=LOADED_MACHINE)
        try:
            with running(make_server(OMX, controller, request_timeout=10.0)) as server:
                yield server
        finally:
            controller.close()
    assert not sa.sim.errors, sa.sim.errors


def _move(server: Any, body: dict[str, Any]) -> dict[str, Any]:
    status, _, reply = call(server, "POST", "/v1/moves", body)
    assert status == 202, reply
    return poll_move(server, reply["id"], lambda b: b["status"] not in ("queued", "running"),
                     timeout=20)


def test_an_http_move_that_rests_off_its_goal_is_degraded(carrying_server, caplog):
    caplog.set_level("WARNING", logger="robodcn.controller")
    _move(carrying_server, {"waypoints": [list(OMX.home)], "payload_kg": CARRIED_KG})
    done = _move(carrying_server, {"waypoints": [GOAL], "payload_kg": 0.0})
    report = done["report"]
    assert done["status"] == "degraded", report["headline"]
    assert report["stop_reason"] == "completed" and report["out_of_position"]
    _check_misses(report)
    assert any(done["id"] in r.getMessage() and "out of position" in r.getMessage()
               for r in caplog.records)
    # declared as carried, the same move back and forth ends in position
    _move(carrying_server, {"waypoints": [list(OMX.home)], "payload_kg": CARRIED_KG})
    done = _move(carrying_server, {"waypoints": [GOAL], "payload_kg": CARRIED_KG})
    report = done["report"]
    if report["skipped"]:
        # a host stall on the loaded test machine: the goals caught up at the velocity
        # limit and the arm may still be closing the last ticks when the wait ends
        assert done["status"] == "degraded", report["headline"]
    else:
        assert report["out_of_position"] == [], report["headline"]
        assert done["status"] == "done"
