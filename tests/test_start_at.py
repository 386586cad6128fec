"""``start_at`` on a move body: refused when past or too far ahead (422 naming it, nothing
moves), and a scheduled move's first sample goes out at that UNIX time (the stream's own
record of its first write, on the real clock, against the simulator)."""

from __future__ import annotations

import functools
import time
from typing import Any

import http_helpers
import pytest
from http_helpers import BODY, error_of, poll_move

from robodcn.contract.start_at import START_AT_AHEAD, check_start_at

pytest_plugins = ["http_helpers"]     # fixtures: arm_server

call = functools.partial(http_helpers.call, require_body=True)


@pytest.mark.parametrize("offset", [-5.0, START_AT_AHEAD + 5.0])
def test_start_at_out_of_range_is_422_and_nothing_moves(arm_server: Any, offset: float):
    server, _ = arm_server
    status, _, body = call(server, "POST", "/v1/moves",
                           {**BODY, "start_at": time.time() + offset})
    assert status == 422
    err = error_of(body)
    assert err["field"] == "start_at"
    assert ("past" if offset < 0 else "ahead") in err["message"]
    assert server.controller.moves() == []


@pytest.mark.parametrize("value", ["soon", None, True, float("inf")])
def test_start_at_not_a_time_is_named(value):
    with pytest.raises(ValueError, match="start_at") as err:
        check_start_at(value)
    assert err.value.field == "start_at"


@pytest.mark.serial  # rates and times on the real clock
def test_a_scheduled_move_starts_at_start_at(arm_server: Any):
    server, _ = arm_server
    start_at = time.time() + 0.8
    status, _, move = call(server, "POST", "/v1/moves", {**BODY, "start_at": start_at})
    assert status == 202, move
    done = poll_move(server, move["id"], lambda m: m["status"] not in ("queued", "running"))
    assert done["status"] in ("done", "degraded"), done  # degraded: a loaded host skipped
    records = server.controller.move(move["id"]).execution.stream.records
    first_write = time.time() - (time.perf_counter() - records.at[0])
    period = 1 / BODY["rate_hz"]
    assert start_at - 0.002 <= first_write <= start_at + period + 0.1, (  # a loaded host
        first_write - start_at)


def test_given_trajectory_and_openapi_take_start_at(arm_server: Any):
    server, _ = arm_server
    status, _, doc = call(server, "GET", "/openapi.json")
    schemas = doc["components"]["schemas"]
    for body in schemas["MoveBody"]["anyOf"]:
        assert body["properties"]["start_at"]["type"] == "number"
    status, _, body = call(server, "POST", "/v1/moves",
                           {"trajectory": {"joint_names": ["a"], "points": []},
                            "start_at": "noon"})
    assert status == 422 and error_of(body)["field"] == "start_at"
