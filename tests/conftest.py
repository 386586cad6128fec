"""Shared test pieces: the example arms (``conftest.ARM3R``, ``ARM2R``), a firmware_sim bus
on a pty (fixture ``sim3``) and a ServoBus on one (:func:`open_bus`). Fixtures are injected
by name; the constants and helpers are imported (``from conftest import ARM3R``)."""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import settings

from firmware_sim.bus import SimBus
from firmware_sim.clock import Clock as FirmwareClock
from robodcn.bus import ServoBus
from robodcn.config import Arm, load_arm

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = ROOT / "configs"
ARM3R: Arm = load_arm(CONFIGS / "arm3r.toml")
ARM2R: Arm = load_arm(CONFIGS / "arm2r.toml")

#: Hypothesis without per-example deadlines (issue 17 §6): on a loaded 2-core machine any
#: ``@given`` example can take longer than the default 200 ms and fail as DeadlineExceeded
#: although nothing is wrong; the suite's wall-clock bound is CI's, not an example's.
#: Random generation stays (``derandomize=False``); a test's own ``@settings`` still
#: applies over this profile.
settings.register_profile("robodcn", deadline=None, derandomize=False)
settings.load_profile("robodcn")


def open_bus(sim: SimBus, servos, **kw) -> ServoBus:
    """An open ServoBus on ``sim``'s pty. Generous reply timeout and extra retries: on a
    loaded machine the in-process simulator thread can answer late (it shares the CPU and
    the GIL with the test); real servos do not. Fault tests that expect lost replies pass
    short values."""
    kw.setdefault("retries", 3)
    kw.setdefault("rx_timeout_ms", 150)
    return ServoBus(sim.port_path, servos=servos, **kw).open()


@pytest.fixture
def sim3() -> Iterator[SimBus]:
    """A started firmware_sim bus with servos 1, 2, 3 (timing "fast"); no protocol errors."""
    with SimBus((1, 2, 3), timing="fast") as bus:
        yield bus
    assert not bus.errors, bus.errors


def settled(read, timeout: float = 2.0):
    """The reading (an array) once it has not changed for 50 ms (AssertionError after
    ``timeout``): where a servo came to rest."""
    import time

    import numpy as np

    deadline = time.monotonic() + timeout
    last, since = np.array(read()), time.monotonic()
    while time.monotonic() - since < 0.05:
        assert time.monotonic() < deadline, "the arm did not come to rest"
        time.sleep(0.005)
        now = np.array(read())
        if not np.array_equal(now, last):
            last, since = now, time.monotonic()
    return last


class StreamTime(FirmwareClock):
    """firmware_sim's time read from a streamer's clock (``robodcn.stream.VirtualClock``):
    the servo physics advance exactly as far as the stream's schedule does, whatever the
    host's load (a sample's write and reads happen at its due time)."""

    def __init__(self, clock) -> None:
        self._clock = clock

    def now(self) -> float:
        return self._clock.now()


#: Status timeout of the reads of a :func:`lockstep_arm` (ms; wall time).
LOCKSTEP_RX_TIMEOUT_MS = 2000.0


@contextlib.contextmanager
def lockstep_arm(arm: Arm, **kw) -> Iterator[tuple]:
    """:func:`robodcn.simulated.simulated_arm` on virtual time: yields ``(sa, clock)``,
    ``clock`` a ``robodcn.stream.VirtualClock`` shared by the simulator's physics
    (:class:`StreamTime`); pass ``clock=clock`` to ``execute``. The physics then step per
    simulated second of the schedule, not per wall second: a test of what the stream and
    the physics do (tracking, compensation, collision currents) gets the same run on a
    loaded machine as on an idle one. On virtual time a reply's wall-clock lateness costs
    nothing (the simulator thread, starved of the CPU on a loaded host, answers late, not
    wrongly), so the reads wait for it up to :data:`LOCKSTEP_RX_TIMEOUT_MS`.
    ``simulated_arm`` takes no clock, so its SimBusConfig is given one here."""
    from unittest import mock

    import robodcn.simulated as simulated
    from firmware_sim.bus_config import SimBusConfig
    from robodcn.stream import VirtualClock

    clock = VirtualClock()
    timed = functools.partial(SimBusConfig, clock=StreamTime(clock))
    with contextlib.ExitStack() as stack:
        with mock.patch.object(simulated, "SimBusConfig", timed), \
                mock.patch.object(simulated, "RX_TIMEOUT_MS", LOCKSTEP_RX_TIMEOUT_MS):
            sa = stack.enter_context(simulated.simulated_arm(arm, **kw))
        yield sa, clock
