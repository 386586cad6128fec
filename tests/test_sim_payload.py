"""A dry run carries the payload its move declares (issue 27 §2).

``sim --payload 0.5`` and ``payload_kg`` on ``serve --sim`` moves changed the timing and the
compensation but not the simulated arm, which carried the arm file's payload: tracking 3.8°
instead of 0.1°, shoulder current 0.26 A against 0.88 A predicted. firmware_sim's arm now
takes a payload at run time (SimBus.set_payload, the control socket's ``payload``), the
dry run sets it per move, and the report names what the simulated arm carried; a pinned
payload (``--sim-payload``, ``simulated_arm(carried_kg=)``) still simulates a misdeclared
load (tests/test_in_position.py).
"""

from __future__ import annotations

import json
import socket
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from conftest import lockstep_arm
from http_helpers import LOADED_MACHINE, call, poll_move, running
from omx_helpers import OMX
from workflow_helpers import run_cli

import robodcn
from firmware_sim import control_table as fct
from firmware_sim.bus import SimBus
from firmware_sim.control_socket import ControlServer
from robodcn.cli.exit_codes import Exit
from robodcn.controller import ArmController
from robodcn.http import make_server
from robodcn.simulated import simulated_arm
from robodcn.stream import execute

GOAL_ARG = "0.2,0,0.15,0"
GOAL = [0.2, 0.0, 0.15, 0.0]
SHOULDER = 1


def _held_current(sim: SimBus, servo_id: int, seconds: float = 0.4) -> float:
    """Present Current (mA, signed) of a servo holding still, after ``seconds`` to settle."""
    time.sleep(seconds)
    with sim.lock:
        sim.keep_up()
        raw = sim.servo(servo_id).get(fct.PRESENT_CURRENT)
    return float(raw - 65536 if raw >= 32768 else raw)


def test_the_simulated_arm_takes_a_payload_at_run_time():
    """Holding the same pose, the shoulder's current grows with the payload by what gravity
    on the added mass needs: a heavier payload, a larger holding current."""
    with simulated_arm(OMX, timing="fast") as sa:
        sid = OMX.servo_ids[SHOULDER]
        assert sa.sim.payload_kg == OMX.payload_kg
        light = abs(_held_current(sa.sim, sid))
        sa.sim.set_payload(0.5)
        assert sa.sim.payload_kg == 0.5
        heavy = abs(_held_current(sa.sim, sid))
        assert heavy > light + 20, (light, heavy)   # mA: 0.5 kg at ~0.12 m is ~0.6 N·m
        for bad in (-0.1, float("nan"), True, "1"):
            with pytest.raises(ValueError, match="payload"):
                sa.sim.set_payload(bad)             # type: ignore[arg-type]
        assert sa.sim.payload_kg == 0.5


def test_the_control_socket_sets_and_reads_the_payload(tmp_path):
    path = str(tmp_path / "control.sock")
    with simulated_arm(OMX, timing="fast") as sa:
        server = ControlServer(sa.sim, path)
        try:
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
                s.connect(path)
                reader = s.makefile("r")
                answers = []
                for line in ("payload 0.25", "payload", "payload -1", "payload a b"):
                    s.sendall(line.encode() + b"\n")
                    answers.append(reader.readline().strip())
        finally:
            server.close()
    assert answers[0] == "ok" and answers[1] == "ok 0.25"
    assert answers[2].startswith("error payload must be") and "-1" in answers[2]
    assert answers[3].startswith("error payload takes 0 or 1")


def test_a_bus_without_an_arm_carries_nothing():
    with SimBus(ids=[1], model="xm430-w350", log=False) as sim:
        assert sim.payload_kg is None
        with pytest.raises(RuntimeError, match="no arm"):
            sim.set_payload(0.1)


def _dry_run(declared: float, pinned: float | None = None) -> Any:
    """The issue's dry run on virtual time (conftest.lockstep_arm: the same physics on a
    loaded machine as on an idle one): planned for ``declared`` kg from home to the goal,
    the simulated arm carrying it (or ``pinned``), compensation on as ``sim`` streams."""
    traj = robodcn.plan(OMX, [list(OMX.home), GOAL], payload_kg=declared)
    with lockstep_arm(OMX, timing="fast", start_joints=traj.joints[0],
                      carried_kg=pinned) as (sa, clock):
        sa.carry(declared)
        report = execute(traj, sa.bus, clock=clock, settle=1.0)
        return sa.reported(report, traj)


def test_the_issues_dry_run_carries_the_declared_payload():
    """``payload 0.5`` declared: the simulated arm carries 0.5 kg, the compensation planned
    for it keeps the tracking near 0.1° and ends in position, and the shoulder's current is
    near its prediction (3.8° and 0.26 A against 0.88 A predicted before)."""
    report = _dry_run(0.5)
    assert (report.sim_payload_kg, report.planned_payload_kg) == (0.5, 0.5)
    assert report.completed, report.headline
    assert max(report.tracking_error_max_rad[1:]) < np.radians(1.0), report.tracking_error_max_rad
    measured = report.current_peak_a[SHOULDER]
    predicted = report.predicted_current_peak_a[SHOULDER]
    assert measured == pytest.approx(predicted, rel=0.25), (measured, predicted)
    # the same plan on an arm pinned to carry nothing: what the dry run showed before
    light = _dry_run(0.5, pinned=0.0)
    assert (light.sim_payload_kg, light.planned_payload_kg) == (0.0, 0.5)
    assert light.out_of_position and not light.completed
    assert max(light.tracking_error_max_rad) > 2 * max(report.tracking_error_max_rad)
    assert light.current_peak_a[SHOULDER] < 0.75 * measured


def test_sim_carries_the_declared_payload_and_says_so(monkeypatch, capsys):
    code = run_cli(monkeypatch, ["sim", "--arm", "omx", "--to", GOAL_ARG, "--payload", "0.5",
                                 "--timing", "fast", "--json"])
    report = json.loads(capsys.readouterr().out)
    assert (report["sim_payload_kg"], report["planned_payload_kg"]) == (0.5, 0.5)
    if not report["skipped"]:       # a host stall lets the goals run ahead (item 3)
        assert code == Exit.DONE, report["headline"]


def test_the_text_report_names_the_payload(monkeypatch, capsys):
    run_cli(monkeypatch, ["sim", "--arm", "omx", "--to", GOAL_ARG, "--payload", "0.3",
                          "--sim-payload", "0.1", "--timing", "fast"])
    out = capsys.readouterr().out
    assert "  simulated arm carried 0.1 kg at the tool point, the plan declares 0.3 kg\n" in out


@pytest.fixture
def sim_server() -> Iterator[tuple[Any, Any]]:
    """``serve --sim``'s wiring (robodcn.http.service): the controller carries each move's
    payload on the simulated arm."""
    with simulated_arm(OMX, timing="fast") as sa:
        controller = ArmController(OMX, sa.bus, execute_options=LOADED_MACHINE, simulated=sa)
        try:
            with running(make_server(OMX, controller, request_timeout=10.0)) as server:
                yield server, sa
        finally:
            controller.close()
    assert not sa.sim.errors, sa.sim.errors


def _move(server: Any, body: dict[str, Any]) -> dict[str, Any]:
    status, _, reply = call(server, "POST", "/v1/moves", body)
    assert status == 202, reply
    return poll_move(server, reply["id"], lambda b: b["status"] not in ("queued", "running"),
                     timeout=30)


def test_serve_sim_carries_each_moves_payload(sim_server):
    server, sa = sim_server
    for payload in (0.5, 0.0):
        done = _move(server, {"waypoints": [GOAL if payload else list(OMX.home)],
                              "payload_kg": payload})
        report = done["report"]
        assert report["sim_payload_kg"] == report["planned_payload_kg"] == payload
        assert sa.sim.payload_kg == payload
        if not report["skipped"]:   # a host stall lets the goals run ahead (item 3)
            assert report["out_of_position"] == [], report["headline"]
    # no payload_kg: the arm file's
    done = _move(server, {"waypoints": [GOAL]})
    assert done["report"]["sim_payload_kg"] == OMX.payload_kg
    assert np.isfinite(done["report"]["current_peak_a"]).all()


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
payload_kg = 0.3

[[waypoints]]
x = 0.18
y = 0.08
z = 0.15
pitch_deg = 0
"""


def test_run_sim_carries_each_legs_payload(monkeypatch, capsys, tmp_path):
    """``run FILE --sim``: a leg after the gripper closes on an object (the file's
    ``payload_kg``) is dry-run with the simulated arm carrying it."""
    monkeypatch.delenv("ROBODCN_ARM", raising=False)
    path = tmp_path / "pick.toml"
    path.write_text(PICK)
    run_cli(monkeypatch, ["run", str(path), "--sim", "--json"])
    data = json.loads(capsys.readouterr().out)
    carried = [(leg["report"]["sim_payload_kg"], leg["report"]["planned_payload_kg"])
               for leg in data["legs"]]
    assert carried == [(OMX.payload_kg, OMX.payload_kg), (0.3, 0.3)], carried
