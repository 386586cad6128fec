"""schemathesis against ``/openapi.json`` of a real server (the ``serve --sim`` stack):
no server error, no undocumented status, every response in its schema and content type,
405 with ``Allow`` for undeclared methods. Bounded examples so the run stays under a minute.
"""

from __future__ import annotations

import json
import urllib.request
from collections.abc import Iterator
from typing import Any

import pytest
import schemathesis
from http_helpers import ARM, running
from hypothesis import HealthCheck, settings

from robodcn.http import make_server, openapi

#: Moves run against the simulated arm in fast timing; the watchdog is relaxed because the
#: simulator shares this (loaded) process.
EXECUTE = {"watchdog_ms": 1000}


@pytest.fixture(scope="module")
def api_url() -> Iterator[str]:
    from robodcn.controller import ArmController
    from robodcn.simulated import simulated_arm

    with simulated_arm(ARM, timing="fast") as sa:
        controller = ArmController(ARM, sa.bus, execute_options=EXECUTE)
        try:
            with running(make_server(ARM, controller, request_timeout=5.0)) as server:
                yield server.url
        finally:
            controller.close()


#: Every check runs but positive_data_acceptance: a schema-valid body may still be
#: infeasible (a waypoint out of reach, a segment over a joint limit, one method per
#: segment), a 422 naming the field that no JSON schema can predict. A schema-violating
#: body is refused with 400/422 (413 only over the byte limit, which a fuzzed body never
#: reaches; more waypoints than maxItems is a 422). ``GET /v1/events`` is a stream that
#: never ends by itself: its first events are read and each checked against its schema.
CONFIG = schemathesis.Config.from_dict({
    "max-stream-events": 4,
    "checks": {
        "positive_data_acceptance": {"enabled": False},
        "negative_data_rejection": {"expected-statuses": [
            "400", "401", "404", "405", "409", "415", "422", "5XX"]}}})
#: The document the server serves (test_served_document_is_the_one_fuzzed checks it is).
schema = schemathesis.openapi.from_dict(openapi(ARM), config=CONFIG)


def test_served_document_is_the_one_fuzzed(api_url: str) -> None:
    with urllib.request.urlopen(f"{api_url}/openapi.json", timeout=10) as resp:
        assert json.loads(resp.read()) == json.loads(json.dumps(openapi(ARM)))


@schema.parametrize()
@settings(max_examples=15, deadline=None, suppress_health_check=list(HealthCheck))
def test_api_conforms_to_its_openapi(case: Any, api_url: str) -> None:
    case.call_and_validate(base_url=api_url, timeout=20)
