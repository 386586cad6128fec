"""What a servo's output does: the profile in force and, in the physics model, the drive
and the shaft on its plant; the position frames between them.

Position frames: the profile runs in the *present* frame (what Present Position reads).
The motor's own position is ``actual = s·(present − Homing Offset)`` with s = −1 when
Drive Mode bit 0 (reverse) is set. Homing Offset and Drive Mode are EEPROM items, so they
change only with torque off, when the motor is at rest: the actual position is kept and
Present Position jumps (:meth:`Motion.set_actual`).
"""

from __future__ import annotations

import dataclasses

from firmware_sim import control_table as ct
from firmware_sim.control_table import ControlTable
from firmware_sim.drive import PULSES_PER_RAD, Drive
from firmware_sim.dynamics import Plant
from firmware_sim.profile import (
    ACCELERATION_UNIT,
    VELOCITY_UNIT,
    Profile,
    hold,
    plan_time_based,
    plan_velocity_based,
    plan_velocity_mode,
)

#: Pulses per revolution (12-bit absolute encoder).
PULSES_PER_REV = 4096
#: Operating modes whose goal is a position.
POSITION_MODES = (ct.MODE_POSITION, ct.MODE_EXTENDED_POSITION, ct.MODE_CURRENT_POSITION)


class Motion:
    """The profile generator's plan and (physics model) the drive and its plant shaft.

    Parameters
    ----------
    table : ControlTable
        The servo's table (Homing Offset, Drive Mode, profile items are read from it).
    profile : Profile
        The plan in force (present frame, pulses and seconds).

    Attributes
    ----------
    drive, plant : Drive, Plant or None
        Set in the physics model; ``joint`` is this shaft's index on the plant.
    """

    def __init__(self, table: ControlTable, profile: Profile) -> None:
        self.table = table
        self.profile = profile
        self.drive: Drive | None = None
        self.plant: Plant | None = None
        self.joint = 0

    # ---- frames ---------------------------------------------------------------------
    def sign(self) -> int:
        """−1 with Drive Mode bit 0 (reverse), else 1."""
        return -1 if self.table.get(ct.DRIVE_MODE) & ct.DRIVE_REVERSE else 1

    def actual(self, present: float) -> float:
        """actual = s·(present − Homing Offset)."""
        return self.sign() * (present - self.table.get(ct.HOMING_OFFSET))

    def present(self, actual: float) -> float:
        """present = s·actual + Homing Offset."""
        return self.sign() * actual + self.table.get(ct.HOMING_OFFSET)

    def actual_now(self, now: float) -> float:
        """The motor's multi-turn position counter (actual frame), pulses."""
        if self.plant is None:
            return self.actual(self.profile.state(now)[0])
        assert self.drive is not None
        return self.plant.theta[self.joint] * PULSES_PER_RAD - self.drive.turns

    def present_now(self, now: float) -> float:
        """Present Position as a float (present frame), pulses."""
        if self.plant is None:
            return self.profile.state(now)[0]
        return self.present(self.actual_now(now))

    def set_actual(self, now: float, actual: float) -> None:
        """Make the counter read ``actual`` (the shaft stays put); the profile holds there."""
        if self.plant is not None:
            assert self.drive is not None
            self.drive.turns = self.plant.theta[self.joint] * PULSES_PER_RAD - actual
            self.drive.reset_controllers()
        self.profile = hold(now, self.present(actual))

    def single_turn(self, now: float) -> None:
        """Present Position back to the absolute encoder's one-turn value (plus offset)."""
        self.set_actual(now, self.actual_now(now) % PULSES_PER_REV)

    def hold_here(self, now: float) -> float:
        """The profile stops where the servo is (kinematic: the profile's own position);
        returns that position."""
        p = self.present_now(now)
        self.profile = hold(now, p)
        if self.drive is not None:
            self.drive.reset_controllers()
        return p

    def place(self, now: float, ticks: int) -> None:
        """Put the output shaft where Present Position reads ``ticks``, at rest."""
        if self.plant is not None:
            assert self.drive is not None
            self.plant.theta[self.joint] = ((self.actual(ticks) + self.drive.turns)
                                            / PULSES_PER_RAD)
            self.plant.omega[self.joint] = 0.0
        self.profile = hold(now, float(ticks))

    # ---- the profile generator ---------------------------------------------------------
    def follow(self, now: float, position: bool) -> None:
        """Re-plan after a goal write: Goal Position in the position modes (``position``),
        Goal Velocity in velocity mode (e-manual "Profile Velocity(112)")."""
        t = self.table
        mode = t.get(ct.OPERATING_MODE)
        p, v = self.profile.state(now)
        if mode in POSITION_MODES and position:
            self.profile = self.plan_position(now, p, v, t.get(ct.GOAL_POSITION))
        elif mode == ct.MODE_VELOCITY and not position:
            accel = t.get(ct.PROFILE_ACCELERATION) * ACCELERATION_UNIT
            self.profile = plan_velocity_mode(now, p, v,
                                              t.get(ct.GOAL_VELOCITY) * VELOCITY_UNIT, accel)

    def plan_position(self, now: float, p: float, v: float, goal: int) -> Profile:
        """The profile from (p, v) to ``goal``: time-based (Drive Mode bit 2) or
        velocity-based with Profile Velocity capped by Velocity Limit."""
        t = self.table
        pv, pa = t.get(ct.PROFILE_VELOCITY), t.get(ct.PROFILE_ACCELERATION)
        if t.get(ct.DRIVE_MODE) & ct.DRIVE_TIME_BASED:
            return plan_time_based(now, p, v, goal, pv / 1000.0, pa / 1000.0)
        if pv > 0:
            pv = min(pv, t.get(ct.VELOCITY_LIMIT))
        key = ("velocity-based", goal, pv, pa)
        if self.profile.key == key:
            # the same goal again (streaming): the plan in force (running or finished)
            # already answers it; re-planning would only add float noise
            return self.profile
        plan = plan_velocity_based(now, p, v, goal, pv * VELOCITY_UNIT, pa * ACCELERATION_UNIT)
        return dataclasses.replace(plan, key=key)
