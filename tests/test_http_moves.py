"""The HTTP service end to end, moves: move, stop and state against
:func:`robodcn.simulated.simulated_arm` in fast timing, and `serve` as a process (a real
client on an ephemeral port; plan-only endpoints are in test_http.py). Expected values
come from the library itself (the planner, FK, servo units), never from a previous run.
"""

from __future__ import annotations

import functools
import http.client
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from typing import Any

import http_helpers
import numpy as np
import pytest
from conftest import settled
from http_helpers import (  # arm_server: a fixture
    ARM,
    BODY,
    HOME,
    ROOT,
    TARGET,
    error_of,
    poll_move,
    start_move,
)

from robodcn import kinematics, servo_units
from robodcn.planner import plan

pytest_plugins = ["http_helpers"]     # fixtures: arm_server

call = functools.partial(http_helpers.call, require_body=True)

# -- moves, stop and state on the simulated arm ---------------------------------------------------

def present(sa: Any) -> list[int]:
    return [sa.sim.servo(i).present_position for i in ARM.servo_ids]


def test_move_executes_and_reports(arm_server: Any) -> None:
    server, sa = arm_server
    start = servo_units.ticks_to_radians(np.array([present(sa)]), ARM.servos)[0]
    status, headers, body = call(server, "POST", "/v1/moves", BODY)
    assert status == 202, body
    assert headers["Location"] == f"/v1/moves/{body['id']}"
    assert body["status"] in ("queued", "running")
    # Planned from the arm's present joints.
    want = plan(ARM, BODY["waypoints"], duration=BODY["duration"], rate_hz=BODY["rate_hz"],
                start_joints=start)
    assert body["samples"] == len(want.t) and body["duration"] == want.duration
    done = poll_move(server, body["id"], lambda b: b["status"] not in ("queued", "running"))
    # "degraded" when the loaded test machine made the streamer skip samples.
    assert done["status"] in ("done", "degraded") and done["progress"] == 1.0, done
    assert (done["status"] == "degraded") == (done["report"]["samples_skipped"] > 0)
    assert done["report"]["stop_reason"] == "completed"
    assert done["report"]["samples_sent"] + done["report"]["samples_skipped"] == \
        done["report"]["samples_total"]
    # The arm ends where the plan ends, within each joint's in-position tolerance ("done"
    # says so); /v1/state reports it through FK.
    tolerance = [math.ceil(j.in_position_tolerance * j.servo.ticks_per_turn / (2 * math.pi)
                           - 1e-9) for j in ARM.joints]
    deadline = time.monotonic() + 5
    while np.any(np.abs(np.array(present(sa)) - want.ticks[-1]) > tolerance):
        assert time.monotonic() < deadline, (present(sa), want.ticks[-1].tolist())
        time.sleep(0.01)
    status, _, state = call(server, "GET", "/v1/state")
    assert status == 200 and state["moving"] is False and state["source"] == "bus"
    assert state["ticks"] == present(sa)
    joints = servo_units.ticks_to_radians(np.array([state["ticks"]]), ARM.servos)[0]
    np.testing.assert_allclose(state["joints"], joints)
    np.testing.assert_allclose(state["pose"], kinematics.fk(ARM.links, joints[None])[0])
    np.testing.assert_allclose(state["pose"][:2], TARGET[:2], atol=2e-3)
    assert state["torque"] is True and state["alerts"] == {}


def test_two_concurrent_moves_one_is_409(arm_server: Any) -> None:
    server, _ = arm_server
    body = {**BODY, "duration": 1.0}
    barrier = threading.Barrier(2)
    results: list[tuple[int, Any]] = []

    def post() -> None:
        barrier.wait()
        status, _, data = call(server, "POST", "/v1/moves", body)
        results.append((status, data))

    threads = [threading.Thread(target=post) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert sorted(s for s, _ in results) == [202, 409], results
    accepted = next(d for s, d in results if s == 202)
    refused = next(d for s, d in results if s == 409)
    assert error_of(refused)["code"] == "busy" and accepted["id"] in refused["error"]["message"]
    _, _, health = call(server, "GET", "/healthz")
    assert health["moving"] is True
    final = poll_move(server, accepted["id"], lambda b: b["status"] not in ("queued", "running"))
    assert final["status"] in ("done", "degraded"), final["error"]
    assert call(server, "GET", "/healthz")[2]["moving"] is False


def test_stop_during_a_move_holds(arm_server: Any) -> None:
    server, sa = arm_server
    body = start_move(server, {**BODY, "duration": 2.0}, 0.1)
    assert body["status"] == "running"
    status, _, state = call(server, "GET", "/v1/state")
    assert status == 200 and state["moving"] and state["source"] == "stream"
    assert state["move"] == body["id"]
    status, _, stopped = call(server, "POST", "/v1/stop", {"mode": "hold"})
    at_stop = np.array(present(sa))
    assert status == 200
    assert stopped == {"stopped": True, "move": body["id"], "status": "stopped",
                       "gripper": False, "hold_failed": None}
    final = poll_move(server, body["id"], lambda b: b["status"] != "running")
    assert final["status"] == "stopped" and final["report"]["stop_reason"] == "stopped"
    assert final["progress"] < 1.0
    # The arm holds: goals stop changing; the servos come to rest on the held goals (the
    # goals they were following: a hold never steps back to the lagging present position)
    # and stay there.
    goals = [sa.sim.goal_history(i) for i in ARM.servo_ids]
    assert final["report"]["hold_goals"] == [g[-1] for g in goals]
    held = settled(lambda: present(sa))
    # it rests between where it was when the hold came and the held goal (friction may
    # stop it short): no step back, no overshoot
    lo = np.minimum(at_stop, np.array(final["report"]["hold_goals"])) - 1
    hi = np.maximum(at_stop, np.array(final["report"]["hold_goals"])) + 1
    assert np.all((lo <= held) & (held <= hi)), (at_stop, held, final["report"]["hold_goals"])
    time.sleep(0.2)
    assert [sa.sim.goal_history(i) for i in ARM.servo_ids] == goals
    assert np.abs(np.array(present(sa)) - held).max() <= 1
    # Stopping again is harmless; a body other than {} is refused.
    assert call(server, "POST", "/v1/stop", {})[2]["stopped"] is False
    status, _, data = call(server, "POST", "/v1/stop", {"now": True})
    assert status == 422 and error_of(data)["field"] == "now"


def test_move_errors(arm_server: Any) -> None:
    server, sa = arm_server
    status, _, data = call(server, "GET", "/v1/moves/999")
    assert status == 404 and error_of(data)["field"] == "id"
    status, _, data = call(server, "POST", "/v1/moves", {**BODY, "start_joints": [0, 0, 0]})
    assert status == 422 and error_of(data)["field"] == "start_joints"
    status, _, data = call(server, "POST", "/v1/moves",
                           {"waypoints": [HOME, TARGET, [0.9, 0.0, 0.0]]})
    assert status == 422 and error_of(data)["field"] == "waypoints[2]"
    for raw, code in ((b"{", 400), (b"[]", 422)):
        assert call(server, "POST", "/v1/moves", raw=raw)[0] == code
    assert call(server, "POST", "/v1/moves", BODY, headers={"Content-Type": "text/json"})[0] \
        == 415
    # A bus fault: the servos stop answering.
    sa.sim.faults.drop(times=None)
    status, _, data = call(server, "GET", "/v1/state")
    assert status == 503 and error_of(data)["code"] == "communication"
    sa.sim.faults.clear()
    assert call(server, "GET", "/v1/state")[0] == 200


def test_a_refused_move_reports_its_fault(arm_server: Any) -> None:
    server, sa = arm_server
    sa.sim.faults.trip(3, bits=0x20)  # overload on the wrist servo
    status, _, body = call(server, "POST", "/v1/moves", BODY)
    assert status == 202
    final = poll_move(server, body["id"], lambda b: b["status"] not in ("queued", "running"))
    assert final["status"] == "failed" and final["error"]["code"] == "hardware_alert"
    status, _, state = call(server, "GET", "/v1/state")
    assert status == 200 and state["alerts"] == {"3": "overload"}


def _serve_subprocess(extra: str) -> subprocess.Popen:
    code = ("from robodcn.config import load_arm; from robodcn.http import serve; "
            f"serve(load_arm({str(ROOT / 'configs' / 'arm3r.toml')!r}), port=0, {extra}"
            "ready=lambda url: print(url, flush=True))")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("ROBODCN_TOKEN", None)
    return subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=env, text=True)


def _request(url: str, method: str, path: str, body: Any = None) -> tuple[int, Any]:
    host, port = url.removeprefix("http://").split(":")
    conn = http.client.HTTPConnection(host, int(port), timeout=10)
    try:
        data = None if body is None else json.dumps(body)
        conn.request(method, path, body=data, headers={"Content-Type": "application/json"})
        resp = conn.getresponse()
        return resp.status, json.loads(resp.read())
    finally:
        conn.close()


def _state_then_signal(proc: subprocess.Popen, sig: int = signal.SIGTERM,
                       during: Any = None) -> dict[str, Any]:
    """GET /v1/state, optionally ``during(url)``, then the signal: a clean, quiet exit."""
    try:
        url = proc.stdout.readline().strip()
        assert url.startswith("http://127.0.0.1:"), proc.stderr.read() if not url else url
        status, state = _request(url, "GET", "/v1/state")
        assert status == 200 and state["source"] == "bus", state
        if during is not None:
            during(url)
        proc.send_signal(sig)
        assert proc.wait(10) == 0
        assert proc.stderr.read() == ""  # quiet: no per-request logging, no traceback
        return state
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_serve_sim_runs_until_a_signal(sig: int) -> None:
    state = _state_then_signal(_serve_subprocess("sim=True, "), sig)
    want = servo_units.radians_to_ticks(kinematics.ik(ARM.links, [ARM.home], ARM.elbow),
                                        ARM.servos)[0]
    assert state["ticks"] == want.tolist()


def test_serve_on_a_device_stops_a_move_and_holds_on_sigterm() -> None:
    from firmware_sim.bus import SimBus

    def start_move(url: str) -> None:
        status, body = _request(url, "POST", "/v1/moves", {**BODY, "duration": 3.0})
        assert status == 202, body
        deadline = time.monotonic() + 10
        while _request(url, "GET", f"/v1/moves/{body['id']}")[1]["progress"] < 0.05:
            assert time.monotonic() < deadline
            time.sleep(0.01)

    with SimBus(ARM.servo_ids, timing="fast") as sim:
        placed = [sim.servo(i).present_position for i in ARM.servo_ids]
        proc = _serve_subprocess(f"device={sim.port_path!r}, baud=1000000, ")
        state = _state_then_signal(proc, signal.SIGTERM, start_move)
        assert state["ticks"] == placed
        # The service stopped the move on its way out: the arm holds, torque on.
        goals = [sim.goal_history(i) for i in ARM.servo_ids]
        full = len(plan(ARM, BODY["waypoints"], duration=3.0, rate_hz=BODY["rate_hz"]).t)
        assert 1 < len(goals[0]) < full  # cut short, not run to its end
        time.sleep(0.1)
        assert [sim.goal_history(i) for i in ARM.servo_ids] == goals
        assert all(sim.servo(i).torque_enabled for i in ARM.servo_ids)
        assert [sim.servo(i).goal_position for i in ARM.servo_ids] == [g[-1] for g in goals]
    assert not sim.errors, sim.errors
