"""A replacement's status counts its own samples, not the replaced move's (issue 17 §2)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from robodcn.config import load_arm
from robodcn.contract import MOVE_OMIT, parse_request
from robodcn.controller import ArmController
from robodcn.planner import plan
from robodcn.simulated import simulated_arm

ROOT = Path(__file__).resolve().parent.parent
ARM = load_arm(ROOT / "configs" / "arm3r.toml")


@pytest.fixture
def controller() -> Iterator[ArmController]:
    with simulated_arm(ARM, timing="fast") as sa:
        c = ArmController(ARM, sa.bus, execute_options={"watchdog_ms": 1000})
        try:
            yield c
        finally:
            c.close()


def test_a_replacement_counts_its_own_samples(controller: Any) -> None:
    import time

    first = controller.start_move(plan(ARM, [ARM.home, (0.18, 0.12, 0.6)], duration=2.0))
    deadline = time.monotonic() + 10
    while first.progress < 0.3:
        assert time.monotonic() < deadline
        time.sleep(0.005)
    request = parse_request({"waypoints": [list(ARM.home), [0.2, 0.05, 0.3]], "rate_hz": 100},
                            ARM, omit=MOVE_OMIT)
    new = controller.replace_move(request)
    controller.wait(new.id, 10)
    assert first.status == "replaced" and new.status in ("done", "degraded"), new.error
    whole = new.execution.report
    own = new.report
    assert new.offset > 0
    # the replacement's samples are those from its switch on, and only those
    assert own.samples_total == whole.samples_total - new.offset
    assert own.samples_sent + own.skipped <= own.samples_total
    assert own.samples_total < whole.samples_total
