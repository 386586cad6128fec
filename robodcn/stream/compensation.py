"""Tracking compensation: the goals to send so that a servo's position follows the plan.

A Dynamixel in position mode with the factory gains (P only, Profile Velocity 0) drives its
motor with PWM = KPP·(goal − present), KPP = P/128. To move along the plan it needs the
PWM duty u(q̇, q̈, τ_load) of :mod:`robodcn.stream.servo_model`, so it lags by
e = 885·u/KPP pulses (≈ 7.5° at 170°/s on an XM430-W350). The streamer therefore sends the
goal the plan needs::

    g_i = q(t_i + T/2) + dir·885·u(t_i + T/2)/KPP          (ticks, per joint)

— a lead of the goal by the loop's lag, from the plan's own velocities, accelerations and
the arm's inverse dynamics (its ``[dynamics]`` masses). t_i + T/2 because a streamed goal
is held for one period T: a staircase follows its ramp half a period late. The Coulomb term
keeps the sign of the last motion while the plan rests, so the shaft comes to rest on the
plan instead of a friction dead band short of it.

Why not the firmware's Feedforward 1st/2nd Gains: they act on the servo's own profile
generator's velocity and acceleration, which are zero with Profile Velocity 0 (every
streamed goal a step); turning the profile on instead makes the servo re-plan a trapezoid
toward each streamed goal, which adds its own lag. The lead gives the same PWM as full
velocity + acceleration feedforward (FF1 ≈ 4·885/ω_no-load), with friction and load terms
on top, and no extra writes per cycle.

The model assumes the position loop is P only (I = D = 0, FF = 0: the XM430's factory gains;
the P gain is read from each servo). A Position D Gain (the XL430-W250's factory 4000) kicks
every goal step, and the PWM limit clips the kicks while the damping between steps is not
clipped, which adds lag this model does not predict: on the XL430 the lead still helps
(about 2.5× on the 2R example arm) but falls short of the XM430's figures.

Goals stay inside the servo's position limits (a lead past a limit is cut there: the servo
refuses it otherwise; the plan itself was checked against the limits before).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from robodcn.config import Arm, ServoSpec
from robodcn.stream.servo_model import (
    DEFAULT_P_GAIN,
    PWM_FULL,
    ArmDynamics,
    derivatives,
    motor_of,
)


def _midpoints(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Values at t_i + T/2: the mean of samples i and i + 1 (the last sample kept)."""
    out = values.copy()
    out[:-1] = 0.5 * (values[:-1] + values[1:])
    return out


def _held_sign(qd: NDArray[np.float64], eps: float) -> NDArray[np.float64]:
    """sgn q̇, carried forward through rests (|q̇| ≤ eps): the direction of the last motion."""
    sign = np.where(np.abs(qd) > eps, np.sign(qd), 0.0)
    out = np.empty_like(sign)
    for j in range(sign.shape[1]):
        column = sign[:, j]
        moving = np.nonzero(column)[0]
        if moving.size == 0:
            out[:, j] = 0.0
            continue
        index = np.maximum.accumulate(np.where(column != 0, np.arange(len(column)), 0))
        held = column[index]
        held[:moving[0]] = 0.0
        out[:, j] = held
    return out


def plan_load(arm: Arm | None, joints: NDArray[np.float64], qd: NDArray[np.float64],
              qdd: NDArray[np.float64]) -> NDArray[np.float64]:
    """Joint load torques of the arm along the plan (zero without an arm)."""
    if arm is None:
        return np.zeros_like(joints)
    return ArmDynamics.of(tuple(arm.links), arm.dynamics).torques(joints, qd, qdd)


def compensated_ticks(joints: NDArray[np.float64], period: float,
                      servos: Sequence[ServoSpec], limits: NDArray[np.int64],
                      arm: Arm | None = None,
                      p_gains: Sequence[int] | None = None) -> NDArray[np.int64]:
    """Goal ticks (n, k) that make the servos follow ``joints`` (n, k) rad (module notes).

    Parameters
    ----------
    joints : planned joint angles, one row a sample, ``period`` s apart.
    servos : the servos in joint order (model, ticks per turn, zero, direction).
    limits : (k, 2) servo position limits, ticks.
    arm : the arm whose masses load the joints (None: the motors alone).
    p_gains : Position P Gain per servo (default: the model's factory value).
    """
    qd, qdd = derivatives(joints, period)
    q_m, qd_m, qdd_m = _midpoints(joints), _midpoints(qd), _midpoints(qdd)
    load = plan_load(arm, q_m, qd_m, qdd_m)
    held = _held_sign(qd_m, 1e-6)
    out = np.empty(joints.shape, dtype=np.int64)
    for j, spec in enumerate(servos):
        motor = motor_of(spec.model)
        kpp = (DEFAULT_P_GAIN.get(spec.model, 800) if p_gains is None else p_gains[j]) / 128.0
        # u with the Coulomb term on the held sign (motor.duty uses sgn q̇).
        u = motor.duty(qd_m[:, j], qdd_m[:, j], load[:, j])
        u += motor.coulomb * (held[:, j] - np.sign(qd_m[:, j])) * motor.resistance / \
            (motor.eta_k * motor.voltage)
        lag_ticks = PWM_FULL * u / kpp * spec.ticks_per_turn / 4096.0
        ticks = spec.zero_offset + spec.direction * (
            q_m[:, j] * spec.ticks_per_turn / (2.0 * math.pi) + lag_ticks)
        out[:, j] = np.clip(np.round(ticks), limits[j, 0], limits[j, 1]).astype(np.int64)
    return out


__all__ = ["compensated_ticks", "plan_load"]
