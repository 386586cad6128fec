"""Put the servos of an arm on one plant carrying the arm's rigid bodies."""

from __future__ import annotations

from collections.abc import Sequence

from firmware_sim.arm_model import ArmModel
from firmware_sim.dynamics import Plant
from firmware_sim.servo.core import Servo


def couple_arm(arm: ArmModel, servos: Sequence[Servo]) -> Plant:
    """Put ``servos`` (in the arm's joint order, physics model, one shared lock) on one
    plant carrying the arm's rigid bodies; returns it."""
    t0 = servos[0].clock.now()
    drives = []
    thetas = []
    for s in servos:
        m = s.motion
        if m.drive is None or m.plant is None:
            raise ValueError(f"servo {s.id}: an arm needs the physics model (dynamics=True)")
        drives.append(m.drive)
        thetas.append(m.plant.theta[0])
    plant = Plant(drives, thetas, t0, arm=arm)
    plant.owners = list(servos)
    for j, s in enumerate(servos):
        s.motion.plant = plant
        s.motion.joint = j
    return plant
