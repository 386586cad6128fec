"""Shared pieces of the workflow tests: paths, scripted stdin for prompts, the CLI in-process.
The fixtures (in-process SimBus, kinematic and physics) are in workflow_fixtures.py."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Sequence

from conftest import CONFIGS

from firmware_sim.bus import SimBus
from robodcn import cli

ARM3R = str(CONFIGS / "arm3r.toml")
ARM2R = str(CONFIGS / "arm2r.toml")
#: A device that does not exist: a command that fails with exit code 2 on it has refused
#: before opening the bus.
NO_DEVICE = "/dev/robodcn-test-no-such-device"
#: A run's exit code: 0, or 5 when the loaded test machine made the stream skip samples (the
#: report then says so); tests of other things accept both.
COMPLETED = (0, 5)


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


def backdrive(sim: SimBus, ticks: dict[int, int]) -> None:
    """Move torque-off servos by hand to ``{id: ticks}`` (``Servo.backdrive``), all under the
    bus lock so no read sees half of the move."""
    with sim.lock:
        for servo_id, tick in ticks.items():
            sim.servo(servo_id).backdrive(int(tick))


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
