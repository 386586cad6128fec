"""What an accepted write does besides storing its values: frames, mode changes, torque,
watchdog and goals (e-manual notes on Operating Mode (11), Torque Enable (64), Drive Mode
(10) bit 3 "torque on by goal update", Bus Watchdog (98)).

A mode change resets Profile Velocity/Acceleration and Goal PWM/Current to their limits;
entering (extended) position mode re-reads the absolute encoder (one turn), as does
torque-on in position mode. Torque on holds where the servo is; torque off stops there.
"""

from __future__ import annotations

from firmware_sim import control_table as ct
from firmware_sim.control_table import Item
from firmware_sim.servo.live import refresh
from firmware_sim.servo.state import ServoState
from firmware_sim.servo.words import round_half_up


def commit(st: ServoState, values: dict[Item, int]) -> int:
    """Store validated ``values`` and apply their effects; returns 0 (ok)."""
    t = st.table
    motion = st.motion
    now = st.clock.now()
    written = {it.address for it in values}
    old_torque = t.get(ct.TORQUE_ENABLE)
    actual = motion.actual_now(now)
    old_mode = t.get(ct.OPERATING_MODE)
    for it in sorted(values, key=lambda it: it.address):
        t.set(it.address, values[it])
    if written & {ct.HOMING_OFFSET, ct.DRIVE_MODE}:
        motion.set_actual(now, actual)
    if ct.OPERATING_MODE in written and t.get(ct.OPERATING_MODE) != old_mode:
        if t.get(ct.OPERATING_MODE) in (ct.MODE_POSITION, ct.MODE_EXTENDED_POSITION):
            motion.single_turn(now)
        for a in (ct.PROFILE_VELOCITY, ct.PROFILE_ACCELERATION):
            if a not in written:
                t.set(a, 0)
        reset_goals(st, keep=written)
    if ct.TORQUE_ENABLE in written:
        new_torque = t.get(ct.TORQUE_ENABLE)
        if new_torque and not old_torque:
            torque_on(st, now, keep_goal=ct.GOAL_POSITION in written)
        elif old_torque and not new_torque:
            motion.hold_here(now)
    if ct.BUS_WATCHDOG in written:
        st.watchdog.written(t, now)
    if ct.GOAL_POSITION in written or ct.GOAL_VELOCITY in written:
        goal_changed(st, now, ct.GOAL_POSITION in written)
    refresh(st, now)
    return 0


def torque_on(st: ServoState, now: float, keep_goal: bool) -> None:
    """Torque on: the servo holds where it is; the goal follows the present position.
    In position control mode torque-on re-reads the absolute encoder (e-manual note)."""
    if st.table.get(ct.OPERATING_MODE) == ct.MODE_POSITION:
        st.motion.single_turn(now)
    p = st.motion.hold_here(now)
    if not keep_goal:
        st.table.set(ct.GOAL_POSITION, round_half_up(p))
    st.watchdog.armed_at = now


def goal_changed(st: ServoState, now: float, position: bool) -> None:
    """A goal was written: torque on by goal update (Drive Mode bit 3) if allowed, then
    the profile follows the goal."""
    t = st.table
    if not t.get(ct.TORQUE_ENABLE):
        if not (t.get(ct.DRIVE_MODE) & ct.DRIVE_TORQUE_ON_BY_GOAL) or \
                t.get(ct.HARDWARE_ERROR_STATUS) & t.get(ct.SHUTDOWN):
            return
        t.set(ct.TORQUE_ENABLE, 1)
        torque_on(st, now, keep_goal=True)
    st.motion.follow(now, position)


def reset_goals(st: ServoState, keep: set[int] | frozenset[int] = frozenset()) -> None:
    """Goal PWM and Goal Current to their limits, Goal Position to where the servo is
    (except the items in ``keep``, just written)."""
    t = st.table
    if ct.GOAL_PWM not in keep:
        t.set(ct.GOAL_PWM, t.get(ct.PWM_LIMIT))
    if st.spec.has_current and ct.GOAL_CURRENT not in keep:
        t.set(ct.GOAL_CURRENT, t.get(ct.CURRENT_LIMIT))
    if ct.GOAL_POSITION not in keep:
        t.set(ct.GOAL_POSITION, round_half_up(st.motion.present_now(st.clock.now())))
