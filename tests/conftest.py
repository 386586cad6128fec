"""Shared fixtures: the example arms, firmware_sim buses on a pty, a ServoBus on them and a
simulated arm. Test files import the helpers (``from conftest import ...`` is not needed:
pytest injects the fixtures by name; the constants are importable as ``conftest.ARM3R``)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from firmware_sim.bus import SimBus
from robodcn.bus import ServoBus
from robodcn.config import Arm, load_arm
from robodcn.simulated import SimulatedArm, simulated_arm

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = ROOT / "configs"
ARM3R: Arm = load_arm(CONFIGS / "arm3r.toml")
ARM2R: Arm = load_arm(CONFIGS / "arm2r.toml")


def open_bus(sim: SimBus, servos, **kw) -> ServoBus:
    """An open ServoBus on ``sim``'s pty. Generous reply timeout and extra retries: on a
    loaded machine the in-process simulator thread can answer late (it shares the CPU and
    the GIL with the test); real servos do not. Fault tests that expect lost replies pass
    short values."""
    kw.setdefault("retries", 3)
    kw.setdefault("rx_timeout_ms", 150)
    return ServoBus(sim.port_path, servos=servos, **kw).open()


@pytest.fixture
def arm3r() -> Arm:
    return ARM3R


@pytest.fixture
def arm2r() -> Arm:
    return ARM2R


@pytest.fixture
def sim3() -> Iterator[SimBus]:
    """A started firmware_sim bus with servos 1, 2, 3 (timing "fast"); no protocol errors."""
    with SimBus((1, 2, 3), timing="fast") as bus:
        yield bus
    assert not bus.errors, bus.errors


@pytest.fixture
def sim_arm3r() -> Iterator[SimulatedArm]:
    """:func:`robodcn.simulated.simulated_arm` of the 3R example arm (timing "fast")."""
    with simulated_arm(ARM3R, timing="fast") as sa:
        yield sa
