"""The service under abuse, online operations under races (issue 17 §7): each test names
the bug it keeps fixed; the rest of the abuse tests are in test_http_abuse.py."""

from __future__ import annotations

import time
from typing import Any

from http_helpers import (
    HOME,
    TARGET,
    call,
    error_of,
    finished,
    poll_move,
    run_move,
    start_move,
)

from robodcn.errors import InputError

pytest_plugins = ["http_helpers"]     # fixtures: abused_server, planner_server


# -- online operations under races (issue 17 §7) ---------------------------------------------

#: A move long enough to act on mid-way.
SLOW = {"waypoints": [HOME, TARGET], "duration": 2.0, "rate_hz": 100}


def test_a_huge_integer_speed_scale_is_422_not_500(abused_server: Any) -> None:
    """PUT /v1/speed {"scale": 1000…0} (401 digits) raised OverflowError (500)."""
    server, _ = abused_server
    raw = b'{"scale": 1' + b"0" * 400 + b"}"
    status, _, body = call(server, "PUT", "/v1/speed", raw=raw)
    assert status == 422 and error_of(body)["field"] == "scale", body
    status, _, body = call(server, "PUT", "/v1/speed", raw=b'{"scale": -1' + b"0" * 400 + b"}")
    assert status == 422 and error_of(body)["field"] == "scale", body


def test_a_pause_answered_200_is_paused_in_the_reply_and_the_state(abused_server: Any) -> None:
    server, _ = abused_server
    move = start_move(server, SLOW, 0.05)
    status, _, paused = call(server, "POST", "/v1/pause")
    assert status == 200 and paused["paused"] is True and paused["id"] == move["id"], paused
    status, _, state = call(server, "GET", "/v1/state")
    assert status == 200 and state["paused"] is True and state["move"] == move["id"], state
    assert state["speed_scale"] == 1.0
    assert call(server, "POST", "/v1/stop", {"mode": "hold"})[0] == 200


def test_a_pause_the_move_end_overtakes_is_409(abused_server: Any, monkeypatch: Any) -> None:
    """The move reaches its end before a brake could stop it: not '200, paused: false'."""
    from robodcn.stream.online import Execution

    server, _ = abused_server
    move = start_move(server, SLOW, 0.05)
    monkeypatch.setattr(Execution, "pause", lambda self: None)  # the end came first
    status, _, body = call(server, "POST", "/v1/pause")
    assert status == 409 and error_of(body)["code"] == "no_move", body
    status, _, state = call(server, "GET", "/v1/state")
    assert state["paused"] is False
    poll_move(server, move["id"], finished)


def test_race_outcomes_are_409_not_422(abused_server: Any, monkeypatch: Any) -> None:
    """'the stream ran ahead of planning' (nothing changed) and 'the execution is not
    running' (it ended meanwhile) are conflicts, not bad input (README: 409)."""
    from robodcn.stream.online import Execution, SwitchMissed

    server, _ = abused_server
    move = start_move(server, SLOW, 0.05)

    def missed(self: Any, scale: float) -> None:
        raise SwitchMissed("change speed", self.status)

    monkeypatch.setattr(Execution, "set_speed", missed)
    status, _, body = call(server, "PUT", "/v1/speed", {"scale": 0.5})
    assert status == 409 and error_of(body)["code"] == "busy", body
    assert "ran ahead of planning" in body["error"]["message"]

    def ended(self: Any) -> None:
        self.wait(10)  # the move ends while the operation plans
        raise InputError("cannot resume: the execution is not running", field="execution",
                         value=self.status)

    monkeypatch.setattr(Execution, "resume", ended)
    status, _, body = call(server, "POST", "/v1/resume")
    assert status == 409 and error_of(body)["code"] == "no_move", body
    poll_move(server, move["id"], finished)


def test_a_replace_as_the_move_ends_is_409_and_the_service_stays_usable(
        abused_server: Any, monkeypatch: Any) -> None:
    """A replace answered 202 just after the stream had stopped left a move 'running' for
    good (every later move 409 busy, stop answering status 'running')."""
    from robodcn.stream.online import Execution

    server, _ = abused_server
    move = start_move(server, SLOW, 0.05)
    real = Execution.retarget

    def late(self: Any, target: Any, **options: Any) -> int:
        first = real(self, target, **options)
        self.wait(10)  # the stream ends before the controller takes the new move over
        return first

    monkeypatch.setattr(Execution, "retarget", late)
    call(server, "POST", "/v1/stop", {"mode": "smooth"})
    status, _, body = call(server, "POST", "/v1/moves",
                           {"waypoints": [HOME, TARGET], "rate_hz": 100, "replace": True})
    assert status == 409 and error_of(body)["code"] == "no_move", body
    final = poll_move(server, move["id"], finished)
    assert final["status"] == "stopped", final
    status, _, stop = call(server, "POST", "/v1/stop", {"mode": "hold"})
    assert status == 200 and stop["stopped"] is False, stop
    monkeypatch.undo()
    run_move(server, {"waypoints": [HOME, TARGET], "rate_hz": 100})   # the next move runs


def test_a_smooth_stop_answers_without_waiting_for_the_move_to_end(
        abused_server: Any, monkeypatch: Any) -> None:
    """Stop waited a fixed 1 s for the move to end; it answers once the brake is in."""
    from robodcn.stream.online import Execution

    server, _ = abused_server
    move = start_move(server, SLOW, 0.05)
    monkeypatch.setattr(Execution, "stop", lambda self, mode="smooth", reason="": None)
    started = time.monotonic()
    status, _, stop = call(server, "POST", "/v1/stop")  # a brake that takes its time
    took = time.monotonic() - started
    assert status == 200 and stop == {"stopped": True, "move": move["id"],
                                      "status": "running", "gripper": False,
                                      "hold_failed": None}, stop
    assert took < 0.5, took
    monkeypatch.undo()
    assert call(server, "POST", "/v1/stop", {"mode": "hold"})[2]["status"] == "stopped"
