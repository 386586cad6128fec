"""Stop stops everything, health tells the truth (issue 26 §6).

Against firmware_sim over a pty with the real dynamixel-sdk: ``POST /v1/stop`` during a
gripper action halts the jaws where they are (``stopped: true``; it answered ``stopped:
false`` and the jaws kept closing); ``GET /healthz`` is 503 with the reason while the device
is gone or a servo reports a hardware error (it answered 200 "ok"), and 200 again once the
bus is back; a stop on a bus that stalls (firmware_sim SIGSTOPped) says its hold was not
written (it once said ``stopped``), the move ends ``fault`` with ``hold_failed``.
"""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

from http_helpers import (
    ARM,
    BODY,
    HOME,
    LOADED_MACHINE,
    ROOT,
    call,
    error_of,
    finished,
    poll_move,
    running,
    serving_arm,
    start_move,
)

from robodcn.config import load_arm
from robodcn.http import make_server

OMX = load_arm(ROOT / "configs" / "omx.toml")


def wait_for(condition: Any, timeout: float = 5.0, poll: float = 0.005) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(poll)


@contextlib.contextmanager
def served(device: str, arm: Any = ARM) -> Iterator[Any]:
    """A service driving the servos on ``device`` (a pty of firmware_sim)."""
    from robodcn.bus import ServoBus
    from robodcn.controller import ArmController

    bus = ServoBus(device, 1_000_000, servos=arm.servos).open()
    try:
        bus.verify()
        controller = ArmController(arm, bus, execute_options=LOADED_MACHINE)
        try:
            with running(make_server(arm, controller, request_timeout=5.0)) as server:
                yield server
        finally:
            controller.close()
    finally:
        bus.close()


# -- stop halts the gripper --------------------------------------------------------------------

def test_stop_halts_a_closing_gripper_where_the_jaws_are() -> None:
    with serving_arm(OMX, request_timeout=10.0) as (server, sa):
        jaws = sa.sim.servo(OMX.gripper.servo.id)
        status, _, opened = call(server, "POST", "/v1/gripper", {"command": "open"})
        assert status == 200 and opened["settled"], opened
        answers: dict[str, Any] = {}
        closing = threading.Thread(target=lambda: answers.update(
            close=call(server, "POST", "/v1/gripper", {"command": "close"})))
        closing.start()
        try:
            start = jaws.present_position
            wait_for(lambda: start - jaws.present_position > 150)  # closing, well under way
            asked = time.monotonic()
            status, _, stop = call(server, "POST", "/v1/stop", {})
            took = time.monotonic() - asked
        finally:
            closing.join(10)
        assert status == 200 and stop == {"stopped": True, "move": None, "status": None,
                                          "gripper": True, "hold_failed": None}, stop
        assert took < 0.3, took  # the action's next poll (20 ms), not its 3 s timeout
        status, _, closed = answers["close"]
        assert status == 200 and closed["stopped"] and not closed["settled"], closed
        # Its goal is where the jaws were when halted, not the closed goal, and they stay.
        halted = closed["final_tick"]
        assert jaws.goal_position == halted != closed["goal_tick"]
        assert sa.sim.goal_history(OMX.gripper.servo.id)[-1] == halted
        time.sleep(0.3)
        rest = jaws.present_position
        time.sleep(0.2)
        assert abs(jaws.present_position - rest) <= 2
        assert abs(rest - halted) < abs(closed["goal_tick"] - halted) / 4, (rest, halted)
        # Nothing moves: a stop answers not stopped.
        assert call(server, "POST", "/v1/stop", {})[2]["stopped"] is False


# -- health ------------------------------------------------------------------------------------

def test_healthz_is_503_with_the_reason_while_the_device_is_gone(tmp_path: Any) -> None:
    from firmware_sim.bus import SimBus

    link = str(tmp_path / "ttyARM")
    sim = SimBus(ARM.servo_ids, timing="fast", link=link).start()
    try:
        with served(link) as server:
            status, _, health = call(server, "GET", "/healthz")
            assert status == 200 and health["status"] == "ok", health
            sim.close()  # the device is gone
            status, _, body = call(server, "GET", "/healthz")
            assert status == 503, body
            error = error_of(body)
            assert error["field"] in ("bus", "port") and error["code"] == "communication", error
            assert link in error["message"] or "servo" in error["message"], error
            # It stays 503 (the device is still gone), and says so again.
            status, _, again = call(server, "GET", "/healthz")
            assert status == 503 and "unavailable" in error_of(again)["message"], again
            sim = SimBus(ARM.servo_ids, timing="fast", link=link).start()  # back
            status, _, health = call(server, "GET", "/healthz")
            assert status == 200 and health["status"] == "ok", health
    finally:
        sim.close()


def test_healthz_names_a_servo_hardware_error_until_it_is_rebooted() -> None:
    with serving_arm(ARM, check_sim=False) as (server, sa):
        assert call(server, "GET", "/healthz")[0] == 200
        joint = ARM.joint_names[0]
        sa.sim.faults.trip(ARM.servo_ids[0])  # overload
        status, _, body = call(server, "GET", "/healthz")
        assert status == 503, body
        error = error_of(body)
        assert error["code"] == "hardware_alert" and "overload" in error["message"], error
        assert f"servo {ARM.servo_ids[0]} ({joint})" in error["message"], error
        status, _, reboot = call(server, "POST", "/v1/reboot", {"joint": joint})
        assert status == 200, reboot
        status, _, health = call(server, "GET", "/healthz")
        assert status == 200 and health["status"] == "ok", health


# -- a stop whose hold the bus did not take ----------------------------------------------------

@contextlib.contextmanager
def firmware_process() -> Iterator[tuple[subprocess.Popen[str], str]]:
    """``python -m firmware_sim`` for the example arm: (its process, its device)."""
    proc = subprocess.Popen([sys.executable, "-m", "firmware_sim", "--ids", "1,2,3", "--arm",
                             str(ROOT / "configs" / "arm3r.toml"), "--timing", "fast"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=ROOT)
    try:
        device = proc.stdout.readline().strip()  # type: ignore[union-attr]
        assert device.startswith("/dev/"), proc.stderr.read()  # type: ignore[union-attr]
        yield proc, device
    finally:
        proc.send_signal(signal.SIGCONT)
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=10)


def test_a_stop_on_a_stalled_bus_says_its_hold_was_not_written() -> None:
    """firmware_sim SIGSTOPped mid-move: the hold is written into a bus nobody reads. The
    stop answers not stopped, the move ends fault with hold_failed, health is 503; once the
    simulator runs again the service recovers by itself."""
    with firmware_process() as (proc, device), served(device) as server:
        move = start_move(server, {**BODY, "duration": 4.0}, 0.05)
        proc.send_signal(signal.SIGSTOP)
        time.sleep(0.05)
        status, _, stop = call(server, "POST", "/v1/stop", {"mode": "hold"})
        assert status == 200 and stop["stopped"] is False, stop
        final = poll_move(server, move["id"], finished, timeout=30)
        assert final["status"] == "fault", final
        report = final["report"]
        assert report is not None and report["hold_failed"], report
        assert "hold was not written" in report["message"], report["message"]
        status, _, body = call(server, "GET", "/healthz")
        assert status == 503 and error_of(body)["code"] == "communication", body
        proc.send_signal(signal.SIGCONT)
        wait_for(lambda: call(server, "GET", "/healthz")[0] == 200, timeout=20, poll=0.2)
        status, _, again = call(server, "POST", "/v1/moves", {"waypoints": [HOME]})
        assert status == 202, again
        done = poll_move(server, again["id"], finished, timeout=20)
        assert done["status"] in ("done", "degraded"), done
