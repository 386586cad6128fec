"""Fixtures of the workflow tests (``pytest_plugins = ["workflow_fixtures"]``): the
simulator's backdrive (a hand moving a torque-off joint) and ``sim``, conftest's ``sim3``
without its packet log."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from firmware_sim.bus import SimBus
from firmware_sim.profile import hold
from firmware_sim.servo import Servo


def _backdrive_shim(self: Servo, ticks: int) -> None:  # shim until fw lands
    """Present Position reads ``ticks``, as if a hand turned the torque-off servo there."""
    with self._lock:
        self.update()
        if self.torque_enabled:
            raise RuntimeError(f"servo {self.id}: torque is on, it cannot be backdriven")
        now = self.clock.now()
        self._profile = hold(now, float(ticks))
        self._refresh(now)


@pytest.fixture
def backdrive(monkeypatch) -> Callable[[SimBus, dict[int, int]], None]:
    """``backdrive(sim, {id: ticks})`` moves torque-off servos by hand."""
    if not hasattr(Servo, "backdrive"):  # shim until fw lands
        monkeypatch.setattr(Servo, "backdrive", _backdrive_shim, raising=False)

    def move(sim: SimBus, ticks: dict[int, int]) -> None:
        with sim.lock:
            for servo_id, tick in ticks.items():
                sim.servo(servo_id).backdrive(int(tick))

    return move


@pytest.fixture
def sim() -> Iterator[SimBus]:
    """Three XM430-W350 (ids 1..3, arm3r's) at 1 Mbps, at tick 2048, torque off: conftest's
    ``sim3`` without the packet log (the run tests stream whole trajectories through the CLI;
    logging every packet slows the simulator thread enough to lose replies on a loaded
    machine)."""
    with SimBus((1, 2, 3), timing="fast", log=False) as bus:
        yield bus
    assert not bus.errors, bus.errors
