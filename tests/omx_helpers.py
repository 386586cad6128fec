"""The packaged OpenMANIPULATOR-X on firmware_sim for the command-line tests
(test_cli_omx_motion, test_cli_omx_teach): the arm (``OMX``), where its servos are
(:func:`joints_of`, :func:`pose_of`) and the fixture ``held_omx`` for
``pytest_plugins = ["omx_helpers"]``."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
from conftest import CONFIGS

from firmware_sim.bus import SimBus
from robodcn import kinematics, servo_units
from robodcn.config import Arm, load_arm
from robodcn.simulated import simulated_arm

OMX: Arm = load_arm(CONFIGS / "omx.toml")


@pytest.fixture
def held_omx() -> Iterator[SimBus]:
    """firmware_sim's physics omx (ids 11-15), held at its home pose as a previous session
    left it; yields the SimBus, whose pty the command under test opens. The simulator must
    end without protocol errors."""
    with simulated_arm(OMX, timing="fast") as s:
        s.bus.close()                     # the command opens the pty itself
        yield s.sim
    assert not s.sim.errors, s.sim.errors


def joints_of(sim: SimBus) -> np.ndarray:
    """The joint angles (rad) of ``sim``'s present positions (``servo_units.ticks_to_radians``)."""
    ticks = [sim.servo(i).present_position for i in OMX.servo_ids]
    return servo_units.ticks_to_radians(np.array(ticks), OMX.servos)


def pose_of(sim: SimBus) -> np.ndarray:
    """Where the arm is: x, y, z (m), pitch (rad), the yawed forward kinematics of
    :func:`joints_of`."""
    return kinematics.fk_yawed(OMX.chain, joints_of(sim)[None])[0]
