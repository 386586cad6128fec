"""Shared pieces of the streamer tests (test_stream, test_preflight, test_step_guard,
test_collision_slew): the example moves, a ServoBus on the simulator, placing the arm,
reading what the servos accepted, a source whose goals jump (:class:`Jumping`)."""

from __future__ import annotations

import functools
import time

import conftest
import numpy as np
from conftest import ARM3R

import robodcn
from firmware_sim.bus import SimBus
from robodcn.bus import ServoBus
from robodcn.planner import Trajectory
from robodcn.stream import ExecutionReport, Progress
from robodcn.stream import execute as _execute

# These are protocol tests on the kinematic model (goals sent = goals planned): the
# tracking compensation, on by default, is tested on the physics sim in test_compensation.
execute = functools.partial(_execute, compensation=False)

ARM = ARM3R
IDS = ARM.servo_ids
WRITES = ("WRITE", "SYNC_WRITE", "REG_WRITE", "BULK_WRITE")
RATE = 100.0


def plan(rate: float = RATE, end=(0.22, 0.18, 0.6)) -> Trajectory:
    return robodcn.plan(ARM, [ARM.home, end], rate_hz=rate)


TRAJ = plan()
#: A longer move (≈ 0.4 s, the shoulder turns ≈ 0.5 rad) for tests that inject a fault
#: mid-move: there is room left after the injection even on a loaded machine.
LONG = plan(end=(0.15, 0.25, 1.2))




def open_bus(sim: SimBus, servos=ARM.servos, **kw) -> ServoBus:
    return conftest.open_bus(sim, servos, **kw)


def place(bus: ServoBus, ticks, timeout: float = 5.0) -> None:
    """Move the simulated arm to ``ticks`` through the SDK and wait until it is there."""
    bus.verify()
    bus.configure()
    bus.write_goals(np.asarray(ticks))
    deadline = time.monotonic() + timeout
    while np.abs(bus.read_positions() - ticks).max() > 1:
        assert time.monotonic() < deadline, "the simulated arm never reached its goal"
        time.sleep(0.01)


def history(sim: SimBus) -> np.ndarray:
    """Goals each servo accepted, (n, k) in joint order."""
    return np.array([sim.goal_history(i) for i in IDS]).T


def write_count(sim: SimBus) -> int:
    return sum(len(sim.packets("rx", name)) for name in WRITES)


def present(sim: SimBus) -> list[int]:
    return [sim.servo(i).present_position for i in IDS]


def assert_holds(sim: SimBus, report: ExecutionReport) -> None:
    """After a stop the servos keep the hold goals and stay where they are."""
    assert report.hold_goals is not None
    assert [sim.servo(i).goal_position for i in IDS] == list(report.hold_goals)
    assert history(sim)[-1].tolist() == list(report.hold_goals)
    time.sleep(0.2)                                # let a servo finish its last step
    first = present(sim)
    time.sleep(0.05)
    assert present(sim) == first
    assert sim.servo(IDS[0]).torque_enabled        # no release was asked for


def inject_at(sample: int, action):
    """A progress callback that runs ``action`` once, at the first report past ``sample``."""
    done = []

    def callback(p: Progress) -> None:
        if p.sample >= sample and not done:
            done.append(p.sample)
            action()

    return callback


class Jumping:
    """The planned samples with joint 0's goals stepped by ``jump`` ticks from sample ``at``
    on (a source whose goals step beyond the limit mid-move and at its last sample)."""

    def __init__(self, planned, bus, at, jump):
        self.planned = planned
        self.period, self.rate_hz = planned.period, planned.rate_hz
        self.compensated = planned.compensated
        sent = np.array(planned.commanded, dtype=np.int64)
        sent[at:, 0] += jump
        self.sent = sent
        self._encoded = bus.encode_goals(sent)

    def __len__(self):
        return len(self.planned)

    def goal(self, i):
        return self.planned.goal(i)

    def encoded(self, i):
        return self._encoded[i]
