"""Numbers a float cannot hold, anywhere in a plan body: a 422 naming the field, never a 500."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from http_helpers import ARM, TARGET, call, error_of, running

from robodcn.http import make_server

HUGE = int("1" + "0" * 400)          # 401 digits: json.loads gives an int, float() overflows


@pytest.fixture(scope="module")
def planner() -> Iterator[Any]:
    with running(make_server(ARM, None, request_timeout=1.0)) as server:
        yield server


@pytest.mark.parametrize("part, field", [
    ("velocities", "start_state.velocities[1]"),
    ("accelerations", "start_state.accelerations[1]"),
])
def test_an_integer_too_large_for_a_float_in_the_start_state_is_a_422(planner: Any, part: str,
                                                                         field: str) -> None:
    state: dict[str, Any] = {"joints": [0.1, 0.4, 0.3], part: [0, HUGE, 0]}
    status, _, body = call(planner, "POST", "/v1/trajectories",
                           {"waypoints": [list(TARGET)], "start_state": state})
    assert status == 422, body
    error = error_of(body)
    assert error["field"] == field
    assert "401 digits" in error["message"]
