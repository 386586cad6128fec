"""The protocol suites of test_fw_bus.py and test_fw_faults.py again, with the physics model.

Every SimBus built by those tests gets ``dynamics=True`` (the kinematic model is the
default they run with); tests that time a profiled move against the kinematic formula
are kinematic by definition and are left out here.
"""

from __future__ import annotations

import pytest

import firmware_sim.bus as fw_bus
from tests import test_fw_bus, test_fw_faults
from tests.test_fw_bus import *  # noqa: F403  (re-collected with physics on)
from tests.test_fw_faults import *  # noqa: F403

_KINEMATIC_ONLY = {"test_profiled_move_matches_x_series_formula"}
for _name in _KINEMATIC_ONLY:
    globals().pop(_name, None)


@pytest.fixture(autouse=True)
def _physics_on(monkeypatch):
    original = fw_bus.SimBus.__init__
    built = []

    def init(self, *args, **kwargs):
        kwargs.setdefault("dynamics", True)
        original(self, *args, **kwargs)
        built.append(self)

    assert test_fw_bus.SimBus is test_fw_faults.SimBus is fw_bus.SimBus
    monkeypatch.setattr(fw_bus.SimBus, "__init__", init)
    yield
    assert built and all(s.dynamics for b in built for s in b.servos)
