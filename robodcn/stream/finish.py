"""After the loop: hold, disarm, recover, read the final positions, release.

On every stop the arm holds: the Bus Watchdog is disarmed (which also makes goals writable
after a trip) and the goals the servos hold — the last ones sent, read back from Goal
Position — are written again as the hold (issue 17 §7): the arm stops where its motion
allows, on the goal it was heading for, with no goal step at all. (Writing the present
positions instead, as before, stepped the goal back by the position loop's lag — up to
41 ticks at speed — and let an arm under gravity droop by its gravity offset.) A
collision or tracking stop has already set the goals where the arm is
(:meth:`robodcn.stream.feedback.Feedback.back_off`), so the servos stop pushing; those
are what is read back here. If Goal Position cannot be read: the last plan goal, else the
last present positions. With ``recover=True`` an overload alert reboots that servo, holds
it where it is and enables its torque again (the move stays stopped). Torque goes off only with
``release=True`` (also after a completed move). With the device lost, none of this can
reach the servos: the Bus Watchdog stops them by themselves. Nothing here raises a
BusError: with the link down each step is skipped, and a hold that could not be written
(the device lost, the write refused or unanswered) is said in :attr:`Finished.hold_failed`
— the report's ``hold_failed``, which makes a stop a ``fault`` — never passed over.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn.bus import ServoBus
from robodcn.errors import BusError
from robodcn.stream.clock import Clock

log = logging.getLogger("robodcn.stream")

#: Hardware Error Status bit of an overload (what ``recover=True`` acts on).
OVERLOAD_BIT = 0x20
#: A final reading one tick off its target counts once unchanged for this long (s).
REST_S = 0.05
#: Time between two final reads while settling (s).
SETTLE_POLL_S = 0.005
#: The least settle (s) of a stream whose last goals were slewed after a host stall
#: (:mod:`robodcn.stream.step_guard`): the arm is then still behind its last goal at speed
#: (≈ 100 ticks at the velocity limit), and a next move, planned from that goal at rest,
#: would start while it overshoots (a current its collision stop took for an obstacle).
CATCH_UP_SETTLE_S = 0.3
#: The least settle (s) of a stream that completed: its final read is where the arm came to
#: rest, which the in-position check (:mod:`robodcn.stream.in_position`) compares with the
#: goal. The wait ends as soon as the arm rests within a tick of its last goal: this bound
#: is paid only by an arm that does not get there (a load the plan did not expect, a P
#: loop's friction dead band).
IN_POSITION_SETTLE_S = 0.5


@dataclass
class Finished:
    """What the end of an execution did: the hold goals sent (None without a hold), why
    the hold is not confirmed (None when every servo read it back, or none was asked), the
    final positions read, whether torque went off, the servos recovered."""

    hold_goals: NDArray[np.int64] | None = None
    hold_failed: str | None = None
    final: NDArray[np.int64] | None = None
    released: bool = False
    recovered: list[dict[str, Any]] = field(default_factory=list)


def finish(bus: ServoBus, clock: Clock, *, hold: bool, release: bool, settle: float,
           last_goal: NDArray[np.int64] | None, last_present: NDArray[np.int64] | None,
           hardware: dict[int, int] | None = None) -> Finished:
    """Hold (when stopped), disarm the watchdog, recover (``hardware``: the errors found,
    given only with ``recover``), read the final positions, release."""
    done = Finished()
    try:
        bus.disarm_watchdog()
    except BusError:
        pass  # a dead link cannot be disarmed; the hold below may still get through
    if hardware and not bus.lost:
        done.recovered = _recover(bus, hardware)
    if hold:
        done.hold_goals, done.hold_failed = _hold(bus, last_goal, last_present)
    if not bus.lost:
        done.final = _final(bus, clock, settle, done.hold_goals if hold else last_goal)
    if release and not bus.lost:
        try:
            bus.torque(False)
            done.released = True
        except BusError:
            pass
    return done


def _hold(bus: ServoBus, last_goal: NDArray[np.int64] | None,
          last_present: NDArray[np.int64] | None
          ) -> tuple[NDArray[np.int64] | None, str | None]:
    """Write the hold (the goals the servos hold, read back; else the last goal sent, else
    the last present positions) and confirm it: (the goals sent, None when none went out;
    why the hold is not confirmed, None when it is). A Sync Write has no reply (a stalled
    bus takes its bytes as readily as a live one), so the servos' Goal Position is read
    back: a hold is confirmed only when every servo answers with it (a read that shows
    other goals is read again, the first may be a straggler of the read before)."""
    if bus.lost:
        return None, "the serial device is lost"
    goals = held_goals(bus)
    if goals is None:
        goals = last_goal if last_goal is not None else last_present
    if goals is None:
        return None, "no goal is known to hold (nothing was sent or read)"
    goals = np.clip(goals, bus.limits[:, 0], bus.limits[:, 1])
    try:
        bus.write_encoded(bus.encode_goals(goals[None, :])[0])
    except BusError as exc:
        log.warning("the hold was not written: %s", exc.message)
        return None, f"the hold write failed: {exc.message}"
    if bus.lost:
        return goals, "the serial device was lost while the hold was written"
    held = held_goals(bus)
    if held is not None and not np.array_equal(held, goals):
        # a late reply to the Goal Position read before the write (same size, the old
        # goals) passes for this one's: a second read confirms
        held = held_goals(bus)
    if held is None:
        log.warning("the hold is not confirmed: Goal Position cannot be read back")
        return goals, ("the servos did not answer the read-back of the hold (Goal "
                       "Position): it is not confirmed")
    if not np.array_equal(held, goals):
        off = [f"servo {i} holds {h}, not {g}" for i, h, g in zip(bus.ids, held, goals,
                                                                   strict=True) if h != g]
        return goals, "the hold did not take: " + "; ".join(off)
    return goals, None


def held_goals(bus: ServoBus) -> NDArray[np.int64] | None:
    """The Goal Position (k,) each servo holds now, ticks (None if it cannot be read;
    :meth:`~robodcn.bus.ServoBus.read_goals`: a read no straggler of another passes for)."""
    try:
        return bus.read_goals()
    except BusError:
        return None


def _recover(bus: ServoBus, hardware: dict[int, int]) -> list[dict[str, Any]]:
    """Overload recovery: reboot each servo reporting overload, hold it where it is
    (goal := present position), torque on again; report it. Never resumes the motion."""
    overloaded = [i for i, e in hardware.items() if e > 0 and e & OVERLOAD_BIT]
    recovered: list[dict[str, Any]] = []
    if not overloaded:
        return recovered
    for servo_id in overloaded:
        entry: dict[str, Any] = {"servo_id": servo_id, "hardware_error": int(hardware[servo_id])}
        try:
            bus.reboot([servo_id])
            present = bus.hold_in_place(servo_id)
            bus.write_torque_enabled(servo_id, True)
            entry.update(recovered=True, position=present)
        except BusError as exc:
            entry.update(recovered=False, error=exc.message)
        log.warning("overload recovery of servo %d: %s", servo_id, entry)
        recovered.append(entry)
    try:
        bus.configure()   # the rebooted servos came back at RAM defaults
    except BusError:
        pass
    return recovered


def _final(bus: ServoBus, clock: Clock, settle: float,
           target: NDArray[np.int64] | None) -> NDArray[np.int64] | None:
    """The final positions, read for up to ``settle`` seconds until the arm is on its
    target or at rest within one tick of it (None if they cannot be read).

    One tick off is returned only at rest (the same reading for :data:`REST_S`): a motor
    still closing its last tick would otherwise be reported a tick short of where it comes
    to rest."""
    now = clock.now()
    deadline = now + settle
    final = None
    last, since = None, now
    while True:
        try:
            final = bus.read_positions()
        except BusError:
            return final
        now = clock.now()
        if last is None or not np.array_equal(final, last):
            last, since = final, now
        if target is None or now >= deadline:
            return final
        error = np.abs(final - target).max()
        if error == 0 or (error <= 1 and now - since >= REST_S):
            return final
        clock.sleep(SETTLE_POLL_S)


__all__ = ["CATCH_UP_SETTLE_S", "IN_POSITION_SETTLE_S", "OVERLOAD_BIT",
           "REST_S", "Finished", "finish", "held_goals"]
