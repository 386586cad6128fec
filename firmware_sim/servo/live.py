"""The live items (Present *, Moving, Moving Status, Realtime Tick, trajectories) brought
up to a time, and the control-table snapshot the physics drive steps on.

Kinematic model: Present Position/Velocity are the profile's. Physics model: they come
from the plant's shaft and the drive (PWM, current, voltage, temperature), the trajectory
items from the profile. "In position" (Moving Status bit 0) needs the goal exactly in the
kinematic model and within the Moving Threshold in the physics model (inference).
"""

from __future__ import annotations

import math

from firmware_sim import control_table as ct
from firmware_sim.drive import PULSES_PER_RAD, DriveSettings
from firmware_sim.motor import CURRENT_UNIT_A, PWM_FULL
from firmware_sim.profile import VELOCITY_UNIT
from firmware_sim.servo.motion import POSITION_MODES
from firmware_sim.servo.state import ServoState
from firmware_sim.servo.words import (
    S16,
    S32,
    TICK_MOVING,
    U16,
    U32,
    VEL_POS_TRAJ,
    round_half_up,
    wrap32,
)


def _tick(st: ServoState, now: float) -> int:
    # the epsilon keeps 1.234 s from reading 1233 ms through float rounding
    return math.floor((now - st.boot_time) * 1000.0 + 1e-6) % 32768


def refresh(st: ServoState, now: float) -> bool:
    """Write the live items for time ``now``; True when the supply is outside Min/Max
    Voltage Limit and no input-voltage error stands yet (the caller raises it)."""
    data = st.table.data
    data[ct.REGISTERED_INSTRUCTION] = int(st.registered is not None)
    data[ct.BACKUP_READY] = int(st.backup is not None)
    if st.motion.plant is None:
        _refresh_kinematic(st, now)
        return False
    return _refresh_physics(st, now)


def _refresh_kinematic(st: ServoState, now: float) -> None:
    # hot path (every read): struct on the byte image rather than typed item access
    data = st.table.data
    prof = st.motion.profile
    p, v = prof.state(now)
    vel = wrap32(round_half_up(v / VELOCITY_UNIT))
    pos = wrap32(round_half_up(p))
    ongoing = prof.ongoing(now)
    moving = ongoing or abs(vel) > U32.unpack_from(data, ct.MOVING_THRESHOLD)[0]
    status = prof.kind
    if ongoing:
        status |= ct.MS_PROFILE_ONGOING
    elif (data[ct.TORQUE_ENABLE] and data[ct.OPERATING_MODE] in POSITION_MODES
          and pos == S32.unpack_from(data, ct.GOAL_POSITION)[0]):
        status |= ct.MS_IN_POSITION
    TICK_MOVING.pack_into(data, ct.REALTIME_TICK, _tick(st, now), int(moving), status)
    VEL_POS_TRAJ.pack_into(data, ct.PRESENT_VELOCITY, vel, pos, vel, pos)


def _refresh_physics(st: ServoState, now: float) -> bool:
    data = st.table.data
    motion = st.motion
    drive, plant = motion.drive, motion.plant
    assert drive is not None and plant is not None
    j = motion.joint
    sign = -1 if data[ct.DRIVE_MODE] & ct.DRIVE_REVERSE else 1
    homing = S32.unpack_from(data, ct.HOMING_OFFSET)[0]
    actual = plant.theta[j] * PULSES_PER_RAD - drive.turns
    pos = wrap32(round_half_up(sign * actual + homing))
    vel = wrap32(round_half_up(sign * plant.omega[j] * PULSES_PER_RAD / VELOCITY_UNIT))
    prof = motion.profile
    p_d, v_d = prof.state(now)
    ongoing = prof.ongoing(now)
    threshold = U32.unpack_from(data, ct.MOVING_THRESHOLD)[0]
    moving = ongoing or abs(vel) > threshold
    status = prof.kind
    if ongoing:
        status |= ct.MS_PROFILE_ONGOING
    elif (data[ct.TORQUE_ENABLE] and data[ct.OPERATING_MODE] in POSITION_MODES
          and abs(pos - S32.unpack_from(data, ct.GOAL_POSITION)[0]) <= threshold):
        status |= ct.MS_IN_POSITION
    TICK_MOVING.pack_into(data, ct.REALTIME_TICK, _tick(st, now), int(moving), status)
    VEL_POS_TRAJ.pack_into(data, ct.PRESENT_VELOCITY, vel, pos,
                           wrap32(round_half_up(v_d / VELOCITY_UNIT)),
                           wrap32(round_half_up(p_d)))
    S16.pack_into(data, ct.PRESENT_PWM, max(-PWM_FULL, min(PWM_FULL, round_half_up(
        sign * drive.duty * PWM_FULL))))
    if st.spec.has_current:
        present_current = round_half_up(sign * drive.current / CURRENT_UNIT_A)
    else:          # Present Load: 0.1 % of the rated stall current
        present_current = round_half_up(sign * 1000.0 * drive.current
                                        / drive.motor.stall_current)
    S16.pack_into(data, ct.PRESENT_CURRENT, max(-32768, min(32767, present_current)))
    volts = round_half_up(drive.supply_voltage / 0.1)
    U16.pack_into(data, ct.PRESENT_INPUT_VOLTAGE, volts)
    data[ct.PRESENT_TEMPERATURE] = max(0, min(255, round_half_up(drive.thermal.temperature)))
    lo = U16.unpack_from(data, ct.MIN_VOLTAGE_LIMIT)[0]
    hi = U16.unpack_from(data, ct.MAX_VOLTAGE_LIMIT)[0]
    return not lo <= volts <= hi and not data[ct.HARDWARE_ERROR_STATUS] & ct.HW_INPUT_VOLTAGE


#: The control-table bytes a drive's settings come from (Drive Mode at 10 … Goal Current at
#: 102–103; the present values live above): :func:`configure_drive` rebuilds the snapshot
#: only when they, the profile or the supply voltage changed.
SETTINGS_END = ct.GOAL_CURRENT + 2


def configure_drive(st: ServoState) -> None:
    """Snapshot what the drive reads from the control table (before plant steps); kept
    while the bytes it reads (:data:`SETTINGS_END`), the profile and the supply voltage
    are those it was built from (a plant advances several times a 10 ms cycle and the
    snapshot, 15 table reads, was most of a servo's update)."""
    drive = st.motion.drive
    assert drive is not None
    t = st.table
    head = bytes(t.data[:SETTINGS_END])
    built = drive.settings_from
    if drive.settings is not None and built is not None and built[0] == head \
            and built[1] is st.motion.profile and built[2] == drive.supply_voltage:
        return
    drive.settings_from = (head, st.motion.profile, drive.supply_voltage)
    xm = st.spec.has_current
    stall = drive.supply_voltage / drive.motor.resistance
    drive.settings = DriveSettings(
        torque_on=bool(t.data[ct.TORQUE_ENABLE]),
        mode=t.get(ct.OPERATING_MODE),
        sign=st.motion.sign(),
        homing=t.get(ct.HOMING_OFFSET),
        kpp=t.get(ct.POSITION_P_GAIN) / 128.0,
        kpi=t.get(ct.POSITION_I_GAIN) / 65536.0,
        kpd=t.get(ct.POSITION_D_GAIN) / 16.0,
        kff1=t.get(ct.FEEDFORWARD_1ST_GAIN) / 4.0,
        kff2=t.get(ct.FEEDFORWARD_2ND_GAIN) / 4.0,
        kvp=t.get(ct.VELOCITY_P_GAIN) / 128.0,
        kvi=t.get(ct.VELOCITY_I_GAIN) / 65536.0,
        pwm_limit=float(abs(t.get(ct.GOAL_PWM))),
        goal_pwm=float(t.get(ct.GOAL_PWM)),
        goal_current=(t.get(ct.GOAL_CURRENT) * CURRENT_UNIT_A if xm else stall),
        current_limit=(t.get(ct.CURRENT_LIMIT) * CURRENT_UNIT_A if xm else stall),
        profile=st.motion.profile,
        temperature_limit=float(t.get(ct.TEMPERATURE_LIMIT)),
        voltage_ok=True,
    )
