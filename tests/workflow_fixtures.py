"""Fixtures of the workflow tests (``pytest_plugins = ["workflow_fixtures"]``): ``sim``,
conftest's ``sim3`` without its packet log (kinematic servos), and ``physics_sim``, the same
servos on the physics model driving the 3R example arm. A hand moving a torque-off joint is
:func:`workflow_helpers.backdrive` (firmware_sim's ``Servo.backdrive``)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from workflow_helpers import ARM3R

from firmware_sim.bus import SimBus


@pytest.fixture
def sim() -> Iterator[SimBus]:
    """Three XM430-W350 (ids 1..3, arm3r's) at 1 Mbps, at tick 2048, torque off, kinematic
    (each goal reached at once): conftest's ``sim3`` without the packet log (the run tests
    stream whole trajectories through the CLI; logging every packet slows the simulator
    thread enough to lose replies on a loaded machine)."""
    with SimBus((1, 2, 3), timing="fast", log=False) as bus:
        yield bus
    assert not bus.errors, bus.errors


@pytest.fixture
def physics_sim() -> Iterator[SimBus]:
    """arm3r's servos on the physics model, driving the arm's masses (what ``robodcn sim``
    runs), each at its zero offset, torque off, no packet log."""
    with SimBus(timing="fast", log=False, dynamics=True, arm=ARM3R) as bus:
        yield bus
    assert not bus.errors, bus.errors
