"""Float teach: a vertical arm that a hand moves and that stays where it is left.

In position mode a taught arm must be pushed against its position loop; with torque off a
vertical arm falls. Float mode runs the joints in current control (Operating Mode 0) with
each joint's Goal Current the current that holds the present pose against gravity,
refreshed at ≥ 50 Hz::

    i_j = direction_j · g_j(q) / K_t,j,    K_t = τ_stall / I_stall

g(q) the holding torque of the present joints q (:func:`robodcn.dynamics.gravity_torque`:
the arm's bodies and payload, recursive Newton–Euler), K_t the servo's torque constant
from its 12 V stall torque and stall current (:data:`robodcn.config.SERVO_SPECS`; ROBOTIS
lists the same ratio, e.g. 1.659 N·m/A for the XM540-W150), direction the servo's mounting
sense. Gravity is balanced, the gears' friction holds the rest: a hand moves the arm with
little force and it stays where it is let go. A current above a servo's Current Limit is
clipped to it (the joint would sag; the report names it).

:class:`FloatTeach` is a context manager: entering switches the joints to mode 0 with the
present pose's currents as the first goal and torque on — a freshly powered servo has it
off, and a float without torque lets the arm fall — (servo by servo, each without torque
only for its switch, :meth:`ServoBus.set_operating_mode`), then reads mode and torque back
(CommError, the arm held in position mode, when a joint did not take them);
:meth:`FloatTeach.run` refreshes the goals until :meth:`FloatTeach.stop` (from any thread)
or a duration; leaving switches back to position mode (3) with torque on and Goal Position
:= Present Position, so nothing jumps, and reads that back too (:attr:`FloatTeach.held`).
The clock and the sleep are injectable (tests run the loop on a fake clock).

Intended surfaces: ``robodcn teach --float`` (record poses while floating; Enter records,
``q`` ends) and a console "Float" toggle (HTTP ``POST /v1/float`` {"on": true|false}) that
run :meth:`FloatTeach.run` on the bus thread and read :attr:`FloatTeach.latest`.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray

from robodcn import _checks, dynamics, servo_units
from robodcn.bus import OPERATING_MODE_CURRENT, OPERATING_MODE_POSITION, ServoBus
from robodcn.config import SERVO_SPECS, Arm, JointSpec, rigid_chain
from robodcn.dynamics import RigidChain
from robodcn.errors import CommError, InputError

log = logging.getLogger("robodcn.workflow")

#: The slowest refresh that keeps a hand-moved arm balanced (Hz, issue 18 §3).
MIN_RATE_HZ = 50.0
MAX_RATE_HZ = 1000.0


# -- the physics it asks of robodcn.dynamics ------------------------------------------------------

def arm_chain(arm: Arm) -> RigidChain:
    """The arm as a :class:`robodcn.dynamics.RigidChain` (:func:`robodcn.config.rigid_chain`),
    refusing an arm whose file gives no link masses or centres of mass: a current that
    holds a light arm's default bodies would let a real arm fall or fly (InputError
    naming the key, e.g. ``dynamics.link_masses``)."""
    props = arm.mass_properties
    if props.link_masses is None or props.link_com is None:
        key = "link_masses" if props.link_masses is None else "link_com"
        raise InputError(f"arm {arm.name!r} has no [dynamics] {key}: the gravity torques "
                         "need the links' masses and centres of mass",
                         field=f"dynamics.{key}", value=None)
    return rigid_chain(arm)


def has_gravity(arm: Arm) -> bool:
    """Whether gravity loads the arm's joints (a chain in a vertical plane, g ≠ 0)."""
    return arm.mass_properties.gravity_m_s2 > 0.0


def gravity_torques(arm: Arm, joints: NDArray[np.float64], payload_kg: float | None = None,
                    chain: Any = None) -> NDArray[np.float64]:
    """Holding torques g(q) (N·m, joint order, yaw first) at ``joints`` (rad, (k,) or (n, k))
    with ``payload_kg`` at the tool point (default the arm's); zeros without gravity.

    ``chain`` is :func:`arm_chain` of the arm when the caller keeps it (a loop)."""
    q = np.asarray(joints, dtype=np.float64)
    if not has_gravity(arm):
        return np.zeros_like(q)
    payload = arm.payload_kg if payload_kg is None else payload_kg
    chain = arm_chain(arm) if chain is None else chain
    return np.asarray(dynamics.gravity_torque(chain, q, payload), dtype=np.float64)


def torque_constant(joint: JointSpec) -> float:
    """K_t = τ_stall / I_stall of the joint's servo model (N·m/A, 12 V datasheet)."""
    return SERVO_SPECS[joint.servo.model].torque_constant


# -- the loop ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class FloatSample:
    """One refresh: t (s since the float began), joints (rad, the arm's joint order), ticks
    (Present Position, bus order), currents_a (the Goal Currents written, A, one per
    floating joint)."""

    t: float
    joints: tuple[float, ...]
    ticks: tuple[int, ...]
    currents_a: tuple[float, ...]


@dataclass(frozen=True)
class FloatReport:
    """What a float did: cycles run, duration_s, rate_hz (achieved mean), worst_period_s,
    late_cycles (periods longer than 1/MIN_RATE_HZ), clipped (joints whose gravity current
    was above the Current Limit at some cycle), the last sample, held (after leaving: every
    floating joint read back in position mode with torque on; None while floating)."""

    joints: tuple[str, ...]
    cycles: int
    duration_s: float
    rate_hz: float
    worst_period_s: float
    late_cycles: int
    clipped: tuple[str, ...]
    last: FloatSample | None
    held: bool | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"joints": list(self.joints), "cycles": self.cycles,
                "duration_s": self.duration_s, "rate_hz": self.rate_hz,
                "worst_period_s": self.worst_period_s, "late_cycles": self.late_cycles,
                "clipped": list(self.clipped), "held": self.held,
                "last": None if self.last is None else {
                    "t": self.last.t, "joints": list(self.last.joints),
                    "ticks": list(self.last.ticks),
                    "currents_a": list(self.last.currents_a)}}


class FloatTeach:
    """Float mode on ``bus`` for ``arm`` (module docstring).

    Parameters
    ----------
    bus : an open bus driving the arm's servos in joint order
    arm : the arm (its ``[dynamics]`` masses and centres of mass)
    joints : names of the joints to float; default the chain's (a yaw stays in position
        mode: pass ``arm.joint_names`` to float it too — its gravity current is 0, so it
        turns freely)
    rate_hz : refresh rate, 50..1000 Hz; default the arm's bus rate (at least 50)
    payload_kg : mass at the tool point; default the arm's
    clock, sleep : monotonic time source and wait
    """

    def __init__(self, bus: ServoBus, arm: Arm, *, joints: Sequence[str] | None = None,
                 rate_hz: float | None = None, payload_kg: float | None = None,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        if tuple(bus.ids) != tuple(arm.servo_ids):
            raise InputError(f"the bus drives servo ids {list(bus.ids)}, arm {arm.name!r} "
                             f"has {list(arm.servo_ids)}", field="bus", value=list(bus.ids))
        names = tuple(j.name for j in arm.chain_joints) if joints is None else tuple(joints)
        unknown = [n for n in names if n not in arm.joint_names]
        if unknown or not names or len(set(names)) != len(names):
            raise InputError(f"joints must be distinct joints of arm {arm.name!r} "
                             f"({', '.join(arm.joint_names)}), got {list(names)}",
                             field="joints", value=list(names))
        rate = max(MIN_RATE_HZ, arm.bus.rate_hz) if rate_hz is None else rate_hz
        if not _checks.is_finite_real(rate) or not MIN_RATE_HZ <= rate <= MAX_RATE_HZ:
            raise InputError(f"rate_hz must be within {MIN_RATE_HZ:g}..{MAX_RATE_HZ:g} Hz, got "
                             f"{rate!r}", field="rate_hz", value=rate)
        if payload_kg is not None and (not _checks.is_finite_real(payload_kg)
                                       or payload_kg < 0):
            raise InputError(f"payload_kg must be a mass ≥ 0 kg, got {payload_kg!r}",
                             field="payload_kg", value=payload_kg)
        self.bus = bus
        self.arm = arm
        self.joint_names = names
        self.rate_hz = float(rate)
        self.payload_kg = arm.payload_kg if payload_kg is None else float(payload_kg)
        self.clock = clock
        self.sleep = sleep
        self._index = [arm.joint_names.index(n) for n in names]
        self._ids = tuple(arm.servo_ids[i] for i in self._index)
        self._per_amp = np.array([arm.joints[i].servo.direction / torque_constant(arm.joints[i])
                                  for i in self._index])
        # the masses are there: fail before any write
        self._chain = arm_chain(arm) if has_gravity(arm) else None
        self._stop = threading.Event()
        self._active = False
        self._start = 0.0
        self._cycles = 0
        self._worst = 0.0
        self._late = 0
        self._clipped: set[str] = set()
        self._limits: NDArray[np.float64] | None = None
        #: The last refresh (None before the first); safe to read from another thread.
        self.latest: FloatSample | None = None
        #: After leaving: every floating joint read back in position mode with torque on.
        self.held: bool | None = None

    # -- one refresh ----------------------------------------------------------------------------

    def currents(self, joints: NDArray[np.float64]) -> NDArray[np.float64]:
        """Goal Currents (A) of the floating joints that hold ``joints`` (rad) against
        gravity, clipped to the servos' Current Limits (module docstring)."""
        torque = gravity_torques(self.arm, joints, self.payload_kg, self._chain)[self._index]
        amps = torque * self._per_amp
        if self._limits is None:
            self._limits = np.array([self.bus.current_limit(i) for i in self._ids])
        over = np.abs(amps) > self._limits
        if over.any():
            for k in np.flatnonzero(over):
                name = self.joint_names[k]
                if name not in self._clipped:
                    log.warning("float: joint %s needs %.2f A against gravity, above its "
                                "Current Limit %.2f A: it will sag", name, amps[k],
                                self._limits[k])
                self._clipped.add(name)
            amps = np.clip(amps, -self._limits, self._limits)
        return amps

    def _read(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        ticks = self.bus.read_positions()
        return ticks, servo_units.ticks_to_radians(ticks, self.arm.servos)

    def step(self) -> FloatSample:
        """Read the present joints, write the currents that hold them; the sample."""
        if not self._active:
            raise InputError("float is not active: enter the FloatTeach first", field="float",
                             value=None)
        ticks, q = self._read()
        amps = self.currents(q)
        self.bus.write_goal_currents(amps, self._ids)
        return self._sample(ticks, q, amps)

    def _sample(self, ticks: NDArray[np.int64], q: NDArray[np.float64],
                amps: NDArray[np.float64]) -> FloatSample:
        sample = FloatSample(self.clock() - self._start, tuple(q.tolist()),
                             tuple(int(t) for t in ticks), tuple(amps.tolist()))
        self.latest = sample
        return sample

    # -- lifecycle ------------------------------------------------------------------------------

    def _not_engaged(self, mode: int) -> tuple[str, ...]:
        """The floating joints that do not read back Operating Mode ``mode`` with torque
        on (one read of each item per servo)."""
        modes = self.bus.operating_modes(self._ids)
        torque = self.bus.torque_enabled()
        return tuple(name for name, i in zip(self.joint_names, self._ids, strict=True)
                     if modes.get(i) != mode or not torque.get(i))

    def __enter__(self) -> Self:
        """Switch the floating joints to current control with the present pose's currents,
        torque on (a freshly powered servo has it off), and read both back: CommError when
        a joint is not floating (the joints are then held in position mode)."""
        ticks, q = self._read()
        amps = self.currents(q)
        self._start = self.clock()
        self.bus.set_operating_mode(OPERATING_MODE_CURRENT, self._ids,
                                    goal_current_a=amps.tolist(), torque=True)
        off = self._not_engaged(OPERATING_MODE_CURRENT)
        if off:
            self.bus.set_operating_mode(OPERATING_MODE_POSITION, self._ids, torque=True)
            raise CommError(f"float: joint(s) {', '.join(off)} did not read back current "
                            "control with torque on; the arm is held in position mode",
                            field="joints", value=list(off))
        self.held = None
        self._active = True
        self._stop.clear()
        self._sample(ticks, q, amps)
        log.info("float on: joints %s at %.0f Hz", ", ".join(self.joint_names), self.rate_hz)
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close(raising=exc is None)

    def close(self, *, raising: bool = True) -> None:
        """Position mode (3) again with torque on, Goal Position := Present Position (no
        jump), read back into :attr:`held`; idempotent.

        With ``raising`` False a failure is logged, not raised (leaving on another error).
        """
        if not self._active:
            return
        self._active = False
        self._stop.set()
        self.held = False
        try:
            self.bus.set_operating_mode(OPERATING_MODE_POSITION, self._ids, torque=True)
            off = self._not_engaged(OPERATING_MODE_POSITION)
        except Exception as error:
            if raising:
                raise
            log.warning("float: position mode could not be restored: %s", error)
            return
        self.held = not off
        if off:
            log.warning("float off: joint(s) %s do not read back position mode with torque "
                        "on", ", ".join(off))
        else:
            log.info("float off: position mode, holding where the arm was left")

    def stop(self) -> None:
        """End :meth:`run` after its present cycle (from any thread)."""
        self._stop.set()

    def run(self, duration_s: float | None = None,
            on_sample: Callable[[FloatSample], None] | None = None) -> FloatReport:
        """Refresh at ``rate_hz`` until :meth:`stop` or ``duration_s`` (None: until stop).

        ``on_sample`` is called with each sample (on this thread). Holds the bus for the
        loop (other threads get BusyError). A cycle that comes late is run at once (no
        catching up); periods above 1/MIN_RATE_HZ are counted as late.
        """
        if duration_s is not None and (not _checks.is_finite_real(duration_s)
                                       or duration_s < 0):
            raise InputError(f"duration_s must be a number of seconds ≥ 0, got "
                             f"{duration_s!r}", field="duration_s", value=duration_s)
        period = 1.0 / self.rate_hz
        begin = self.clock()
        last = begin
        deadline = begin
        with self.bus.claim():
            while not self._stop.is_set():
                now = self.clock()
                if duration_s is not None and now - begin >= duration_s:
                    break
                if self._cycles:
                    gap = now - last
                    self._worst = max(self._worst, gap)
                    self._late += gap > 1.0 / MIN_RATE_HZ
                last = now
                sample = self.step()
                self._cycles += 1
                if on_sample is not None:
                    on_sample(sample)
                deadline = max(deadline + period, self.clock())
                wait = deadline - self.clock()
                if wait > 0:
                    self.sleep(wait)
        return self.report()

    def report(self) -> FloatReport:
        """What the float did so far (:class:`FloatReport`)."""
        duration = (self.latest.t if self.latest is not None else 0.0)
        rate = self._cycles / duration if duration > 0 else 0.0
        return FloatReport(self.joint_names, self._cycles, duration, rate, self._worst,
                           self._late, tuple(n for n in self.joint_names if n in self._clipped),
                           self.latest, self.held)


__all__ = ["MAX_RATE_HZ", "MIN_RATE_HZ", "FloatReport", "FloatSample", "FloatTeach",
           "arm_chain", "gravity_torques", "has_gravity", "torque_constant"]
