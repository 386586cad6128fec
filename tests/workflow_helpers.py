"""Shared pieces of the workflow tests: an in-process SimBus for the arm3r servos, the
simulator's backdrive (a hand moving a torque-off joint) and scripted stdin for prompts."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import pytest

from firmware_sim.bus import SimBus
from firmware_sim.profile import hold
from firmware_sim.servo import Servo
from robodcn import cli

ROOT = Path(__file__).resolve().parent.parent
ARM3R = str(ROOT / "configs" / "arm3r.toml")
ARM2R = str(ROOT / "configs" / "arm2r.toml")
#: A device that does not exist: a command that fails with exit code 2 on it has refused
#: before opening the bus.
NO_DEVICE = "/dev/robodcn-test-no-such-device"


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
    """Three XM430-W350 (ids 1..3, arm3r's) at 1 Mbps, at tick 2048, torque off."""
    bus = SimBus([1, 2, 3], "xm430-w350", baud=1_000_000, timing="fast", log=False)
    bus.start()
    try:
        yield bus
    finally:
        bus.close()
        assert bus.errors == []


Step = str | Callable[[], str]


class ScriptedStdin:
    """stdin whose lines come from ``steps``: a string is a line, a callable runs (moves the
    simulated arm, say) and returns the line. End of the steps is end of input."""

    def __init__(self, steps: Sequence[Step]) -> None:
        self.steps = list(steps)
        self.read = 0

    def readline(self) -> str:
        if not self.steps:
            return ""
        step = self.steps.pop(0)
        self.read += 1
        line = step() if callable(step) else step
        return line + "\n"


def run_cli(monkeypatch, argv: Sequence[str], steps: Sequence[Step] = ()) -> int:
    """``robodcn.cli.main(argv)`` with scripted stdin; returns the exit code."""
    stdin = ScriptedStdin(steps)
    monkeypatch.setattr(sys, "stdin", stdin)
    return cli.main(list(argv))


def settle(sim: SimBus, packets: int = 3, timeout: float = 5.0) -> str:
    """Wait until the bus has received ``packets`` more instructions (the calibration
    sampler has read the new position), however loaded the machine; returns ''."""
    start = sim.rx_packets
    deadline = time.monotonic() + timeout
    while sim.rx_packets < start + packets:
        if time.monotonic() > deadline:
            raise AssertionError(f"the bus saw no {packets} instructions within {timeout} s")
        time.sleep(0.005)
    return ""
