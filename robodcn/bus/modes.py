"""Operating Mode (11) switching: current (0), position (3), current-based position (5) …

Operating Mode lives in the EEPROM area, which is locked while torque is on (e-manual
"Torque Enable"), so a switch is: torque off, write the mode, set the goals the new mode
acts on, torque back on. The e-manual warns that changing the mode resets Profile
Velocity/Acceleration to 0, Goal PWM and Goal Current to their limits and the gains to the
mode's defaults (dynamixel-notes §2), hence before torque comes back:

* a position mode (3, 4, 5) gets Goal Position := Present Position, so torque-on holds where
  the servo is instead of jumping to an old goal;
* current control (0) gets the Goal Current asked for, 0 A by default — never the Current
  Limit the switch left there, which would drive the servo at full current;
* current-based position (5) gets the Goal Current asked for (the limit of its position
  loop), else keeps the reset value (the Current Limit).

Servos are switched one after the other, so each joint is without torque only for its own
few transactions (an arm under gravity sags a little meanwhile; a joint whose torque was
off stays off unless ``torque=True``). A switch leaves :attr:`configured` False: the
stream's profile and gains were reset, so the next stream configures the servos again
(which also brings them back to mode 3).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from robodcn import _checks
from robodcn.bus.control_table import (
    ADDR_GOAL_CURRENT,
    ADDR_GOAL_POSITION,
    ADDR_OPERATING_MODE,
    ADDR_PRESENT_POSITION,
    ADDR_TORQUE_ENABLE,
    CURRENT_MODES,
    MODEL_OPERATING_MODES,
    POSITION_MODES,
)
from robodcn.bus.currents import Currents
from robodcn.bus.single import Servo
from robodcn.config import ServoSpec
from robodcn.errors import CommError, InputError
from robodcn.servo_models import OPERATING_MODE_CURRENT, OPERATING_MODE_NAMES

log = logging.getLogger("robodcn.bus")


@dataclass(frozen=True)
class ModeSwitch:
    """What :meth:`Modes.set_operating_mode` did to one servo.

    servo_id; previous and mode (Operating Mode values before and after); torque_on after
    the switch; goal_current_units written (None: left as it was); held_tick: the Goal
    Position written from Present Position (None: not written).
    """

    servo_id: int
    previous: int
    mode: int
    torque_on: bool
    goal_current_units: int | None = None
    held_tick: int | None = None

    @property
    def changed(self) -> bool:
        return self.previous != self.mode


class Modes(Currents):
    """Reading and switching the Operating Mode (module docstring)."""

    def operating_mode(self, servo: Servo) -> int:
        """Operating Mode (11) of one servo (a bus id or a spec)."""
        return self._read_int(self.spec_of(servo).id, ADDR_OPERATING_MODE, 1)

    def operating_modes(self, servos: Iterable[Servo] | None = None) -> dict[int, int]:
        """Operating Mode per servo id (default: every servo of the bus)."""
        specs = self._specs(servos)
        return {spec.id: self.operating_mode(spec) for spec in specs}

    def _specs(self, servos: Iterable[Servo] | None) -> tuple[ServoSpec, ...]:
        specs = self.servos if servos is None else tuple(self.spec_of(s) for s in servos)
        ids = [s.id for s in specs]
        if not specs or len(set(ids)) != len(ids):
            raise InputError(f"servos must name distinct servos, got ids {ids}",
                             field="servos", value=ids)
        return specs

    def set_operating_mode(self, mode: int, servos: Iterable[Servo] | None = None, *,
                           goal_current_a: float | Sequence[float] | None = None,
                           torque: bool | None = None) -> tuple[ModeSwitch, ...]:
        """Switch ``servos`` (default: every servo of the bus) to Operating Mode ``mode``.

        Parameters
        ----------
        mode : an Operating Mode the servos' model offers (0, 1, 3, 4, 5, 16 on an XM430;
            no 0 or 5 on an XL430)
        servos : bus ids or specs (a servo of the wire that is not a joint, e.g. a gripper)
        goal_current_a : in a current mode, the Goal Current (A, signed) to set before torque
            comes back: one for all or one per servo; default 0 A in mode 0, the Current
            Limit (as the switch leaves it) in mode 5; an error in other modes
        torque : torque after the switch: None restores each servo's own, True/False sets it

        Returns
        -------
        One :class:`ModeSwitch` per servo, in order. A servo already in ``mode`` is not
        switched (nor its torque touched, unless ``torque`` says otherwise); its goal
        current is still written when given.

        Raises
        ------
        InputError before anything is written: a mode the model lacks (field "mode"), a
        goal current above a servo's Current Limit or without a current mode. CommError
        when a servo fails mid-switch (torque is put back on first where it was on).
        """
        specs = self._specs(servos)
        if not _checks.is_int(mode) or int(mode) not in OPERATING_MODE_NAMES:
            raise InputError(f"mode must be an Operating Mode "
                             f"({', '.join(f'{k} {v}' for k, v in OPERATING_MODE_NAMES.items())})"
                             f", got {mode!r}", field="mode", value=mode)
        mode = int(mode)
        for spec in specs:
            if mode not in MODEL_OPERATING_MODES.get(spec.model, frozenset()):
                raise InputError(f"servo {spec.id} ({spec.model}) has no "
                                 f"{OPERATING_MODE_NAMES[mode]} mode ({mode})", field="mode",
                                 value=mode)
        if torque is not None and not isinstance(torque, bool):
            raise InputError(f"torque must be true, false or None, got {torque!r}",
                             field="torque", value=torque)
        currents = self._goal_units(mode, specs, goal_current_a)
        with self.claim():
            switches = tuple(self._switch(spec, mode, units, torque)
                             for spec, units in zip(specs, currents, strict=True))
        if any(s.changed for s in switches):
            self.configured = False
        return switches

    def _goal_units(self, mode: int, specs: tuple[ServoSpec, ...],
                    goal_current_a: float | Sequence[float] | None) -> list[int | None]:
        """Goal Current units per servo (None: leave), all checked before any write."""
        if goal_current_a is None:
            return [0 if mode == OPERATING_MODE_CURRENT else None for _ in specs]
        if mode not in CURRENT_MODES:
            raise InputError(f"goal_current_a needs a current mode (0 or 5), not mode {mode}",
                             field="goal_current_a", value=goal_current_a)
        values = ([goal_current_a] * len(specs) if _checks.is_real(goal_current_a)
                  else list(goal_current_a))  # type: ignore[arg-type]
        if len(values) != len(specs):
            raise InputError(f"goal_current_a must be one current or one per servo "
                             f"({len(specs)}), got {len(values)}", field="goal_current_a",
                             value=goal_current_a)
        return [self.goal_current_units(spec, value)
                for spec, value in zip(specs, values, strict=True)]

    def _switch(self, spec: ServoSpec, mode: int, units: int | None,
                torque: bool | None) -> ModeSwitch:
        """One servo: torque off, mode, goals, torque as asked (module docstring)."""
        servo_id = spec.id
        previous = self._read_int(servo_id, ADDR_OPERATING_MODE, 1)
        was_on = bool(self._read_int(servo_id, ADDR_TORQUE_ENABLE, 1))
        on_after = was_on if torque is None else torque
        changed = previous != mode
        held = None
        try:
            if changed and was_on:
                self._write_int(servo_id, ADDR_TORQUE_ENABLE, 0, 1)
            if changed:
                self._write_int(servo_id, ADDR_OPERATING_MODE, mode, 1)
            if units is not None:
                self._write_int(servo_id, ADDR_GOAL_CURRENT, units, 2)
            turning_on = on_after and (changed or not was_on)
            if mode in POSITION_MODES and turning_on:
                held = self._read_int(servo_id, ADDR_PRESENT_POSITION, 4, signed=True)
                self._write_int(servo_id, ADDR_GOAL_POSITION, held, 4)
            if turning_on:
                self._write_int(servo_id, ADDR_TORQUE_ENABLE, 1, 1)
            elif was_on and not on_after and not changed:
                self._write_int(servo_id, ADDR_TORQUE_ENABLE, 0, 1)
        except CommError:
            if was_on and changed:
                self._restore_torque(servo_id)
            raise
        if changed:
            log.info("servo %d: operating mode %d (%s) -> %d (%s)", servo_id, previous,
                     OPERATING_MODE_NAMES.get(previous, "?"), mode, OPERATING_MODE_NAMES[mode])
        return ModeSwitch(servo_id, previous, mode, on_after, units, held)

    def _restore_torque(self, servo_id: int) -> None:
        """Best effort after a failed switch: torque back on (the arm must not fall)."""
        try:
            self._write_int(servo_id, ADDR_TORQUE_ENABLE, 1, 1)
        except CommError as exc:
            log.warning("servo %d: torque could not be restored after a failed mode "
                        "switch: %s", servo_id, exc.message)


__all__ = ["ModeSwitch", "Modes"]
