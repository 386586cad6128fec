"""The service's log says what a move's record says: a smooth stop is logged "stopped", not
"completed: all samples sent" (its brake runs to its own end)."""

from __future__ import annotations

import logging

from http_helpers import BODY, call, finished, poll_move, serving_arm, start_move


def test_a_smoothly_stopped_move_is_logged_stopped(caplog) -> None:
    caplog.set_level(logging.INFO, logger="robodcn.stream")
    with serving_arm() as (server, _):
        move = start_move(server, {**BODY, "duration": 3.0}, 0.1)
        status, _, reply = call(server, "POST", "/v1/stop", {})
        assert status == 200 and reply["stopped"], reply
        final = poll_move(server, move["id"], finished)
    assert final["status"] == "stopped", final
    headlines = [r.getMessage() for r in caplog.records
                 if r.name == "robodcn.stream" and r.levelno >= logging.INFO
                 and ("completed" in r.getMessage() or "stopped after" in r.getMessage())]
    assert headlines and all(h.startswith("stopped after") for h in headlines), headlines
