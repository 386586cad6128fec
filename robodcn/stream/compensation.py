"""Tracking compensation: the goals to send so that a servo's position follows the plan.

A Dynamixel in position mode with the factory gains (P only, Profile Velocity 0) drives its
motor with PWM = KPP·(goal − present), KPP = P/128. To move along the plan it needs the
PWM duty u(q̇, q̈, τ_load) of :mod:`robodcn.stream.servo_model`, so it lags by
e = 885·u/KPP pulses (≈ 7.5° at 170°/s on an XM430-W350). The streamer therefore sends the
goal the plan needs::

    g_i = q(t_i + T/2) + dir·885·u(t_i + T/2)/KPP          (ticks, per joint)

— a lead of the goal by the loop's lag, from the plan's own velocities, accelerations and
the arm's inverse dynamics: the joint torques τ(q, q̇, q̈) of
:func:`robodcn.dynamics.inverse_dynamics` on :func:`robodcn.config.rigid_chain` (links,
payload at the tool point, gravity, the rotor's J_rotor·N²·q̈), the same function the
timing's torque limits use. On an arm under gravity the lead therefore holds the gravity
torque's steady-state offset KPP·e = 885·u(g(q)) from the first sample: a P-only loop
would otherwise droop by it for good (the OpenMANIPULATOR-X's stretched shoulder by
~24 ticks). With a Position I Gain the loop is PWM = KPP·e + KPI·Σe (Σ over the control
milliseconds, the goal held T): the lag that gives the needed PWM solves
e_i = (885·u_i − KPI·Σ_i)/KPP, Σ_{i+1} = Σ_i + 1000·T·e_i (from Σ_0 = 0), so the lead covers
the load at once and hands it to the integrator as that builds up. t_i + T/2 because a streamed goal
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

Ramp in and out (issue 17 §7): the lead switches on with the first sample (Coulomb, the
planned acceleration, gravity) and changes at once where the plan's acceleration does, a
goal step the servo would take at full PWM. The led goals are made joint-velocity limited
(:func:`limit_steps`: every step within v_max·T of the joint, the first from the goal the
servo holds before the stream, the last exactly on the plan's rest goal): the mean of the
smallest v_max·T-Lipschitz majorant and the largest minorant of the led goals (both are
Lipschitz, so their mean is), clipped to the cones v_max·T·|i − i₀| around the start and
the end. Where the led goals already keep the limit both envelopes are those goals.

The Coulomb term before the plan's first motion takes the sign of the way the arm has to go
from where it rests to the plan's first sample (a drooped arm is lifted against friction),
when that is more than one tick.

Goals stay inside the servo's position limits (a lead past a limit is cut there: the servo
refuses it otherwise; the plan itself was checked against the limits before).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.config import Arm, ServoSpec, rigid_chain
from robodcn.dynamics import gravity_torque, inverse_dynamics
from robodcn.servo_units import radians_to_ticks, ticks_to_radians
from robodcn.stream.servo_model import DEFAULT_P_GAIN, PWM_FULL, derivatives, motor_of

#: Present − plan gap (ticks) above which the first motion's friction sign is the gap's.
GAP_TICKS = 1.0


def _midpoints(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Values at t_i + T/2: the mean of samples i and i + 1 (the last sample kept)."""
    out = values.copy()
    out[:-1] = 0.5 * (values[:-1] + values[1:])
    return out


def _held_sign(qd: NDArray[np.float64], eps: float,
               initial: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """sgn q̇, carried forward through rests (|q̇| ≤ eps): the direction of the last motion;
    before the first motion ``initial`` (default 0)."""
    sign = np.where(np.abs(qd) > eps, np.sign(qd), 0.0)
    out = np.empty_like(sign)
    for j in range(sign.shape[1]):
        column = sign[:, j]
        first = 0.0 if initial is None else float(initial[j])
        moving = np.nonzero(column)[0]
        if moving.size == 0:
            out[:, j] = first
            continue
        index = np.maximum.accumulate(np.where(column != 0, np.arange(len(column)), 0))
        held = column[index]
        held[:moving[0]] = first
        out[:, j] = held
    return out


def payload_of(arm: Arm | None, payload_kg: float | None) -> float:
    """The payload (kg) a prediction uses: ``payload_kg``, else the arm file's default."""
    if payload_kg is not None:
        return float(payload_kg)
    return 0.0 if arm is None else float(arm.payload_kg)


def plan_torques(arm: Arm | None, servos: Sequence[ServoSpec], joints: NDArray[np.float64],
                 qd: NDArray[np.float64], qdd: NDArray[np.float64],
                 payload_kg: float | None = None) -> NDArray[np.float64]:
    """Joint torques τ (n, k), N·m at the output shafts, that give the plan's motion.

    τ = M(q)·q̈ + C(q, q̇)·q̇ + g(q) of :func:`robodcn.dynamics.inverse_dynamics` on the arm's
    :func:`~robodcn.config.rigid_chain` (rotor armature included, no friction); without an
    arm the rotors alone, J_rotor·N²·q̈ of each servo's motor model.
    """
    if arm is None:
        inertia = np.array([motor_of(s.model).inertia for s in servos])
        return qdd * inertia
    return inverse_dynamics(rigid_chain(arm), np.atleast_2d(joints), np.atleast_2d(qd),
                            np.atleast_2d(qdd), payload_of(arm, payload_kg))


def plan_load(arm: Arm | None, joints: NDArray[np.float64], qd: NDArray[np.float64],
              qdd: NDArray[np.float64]) -> NDArray[np.float64]:
    """Joint load torques of the arm along the plan without the rotors' J·q̈ (zero without
    an arm): :func:`plan_torques` minus the armature (transitional name)."""
    if arm is None:
        return np.zeros_like(joints)
    servos = arm.servos
    inertia = np.array([motor_of(s.model).inertia for s in servos])
    return plan_torques(arm, servos, joints, qd, qdd) - qdd * inertia


def _gains(servos: Sequence[ServoSpec], gains: Sequence[int] | None,
           default: dict[str, int] | int) -> list[float]:
    if gains is not None:
        return [float(g) for g in gains]
    return [float(default.get(s.model, 800) if isinstance(default, dict) else default)
            for s in servos]


def lag_pulses(pwm: NDArray[np.float64], period: float, p_gain: float,
               i_gain: float = 0.0) -> NDArray[np.float64]:
    """Position error (pulses) at which the loop outputs ``pwm`` (n,) (module notes).

    P only: e = PWM/KPP. With an I gain the integrator Σ (pulses·ms, from 0) carries part:
    e_i = (PWM_i − KPI·Σ_i)/KPP, Σ_{i+1} = Σ_i + 1000·T·e_i, i.e. Σ is the first-order
    filter Σ_{i+1} = a·Σ_i + (1000·T/KPP)·PWM_i, a = 1 − KPI·1000·T/KPP (by FFT convolution
    with the kernel aᵐ, vectorised).
    """
    kpp = p_gain / 128.0
    kpi = i_gain / 65536.0
    if kpi <= 0.0 or len(pwm) == 0:
        return pwm / kpp
    t_ms = 1000.0 * period
    a = 1.0 - kpi * t_ms / kpp
    if not 0.0 < a < 1.0:                # the integrator outruns a sample: P share only
        return pwm / kpp
    n = len(pwm)
    kernel = a ** np.arange(n)
    size = 1 << math.ceil(math.log2(2 * n))
    conv = np.fft.irfft(np.fft.rfft(pwm, size) * np.fft.rfft(kernel, size), size)[:n]
    integral = np.concatenate([[0.0], (t_ms / kpp) * conv[:-1]])
    return (pwm - kpi * integral) / kpp


def limit_steps(goals: NDArray[np.float64], step: ArrayLike,
                start: ArrayLike | None = None) -> NDArray[np.float64]:
    """Goals (n, k) whose every step is within ``step`` (k,) per joint (module notes).

    The mean of the smallest ``step``-Lipschitz majorant max_m(g_m − δ·|i − m|) and the
    largest minorant min_m(g_m + δ·|i − m|) of ``goals``, clipped to the cones δ·(i + 1)
    around ``start`` (the goal held before sample 0; None: no constraint) and δ·(n − 1 − i)
    around the last goal, which is kept. Goals that keep the limit are returned as they are.
    """
    g = np.asarray(goals, dtype=np.float64)
    n = len(g)
    if n == 0:
        return g.copy()
    delta = np.broadcast_to(np.asarray(step, dtype=np.float64), g.shape[1:])
    free = ~np.isfinite(delta)           # no step limit (no arm): 0·∞ would make NaN goals
    if free.all():
        return g.copy()
    delta = np.where(free, 0.0, delta)
    index = np.arange(n, dtype=np.float64)[:, None]
    ramp = index * delta
    upper = np.maximum(np.maximum.accumulate(g + ramp, axis=0) - ramp,
                       np.maximum.accumulate((g - ramp)[::-1], axis=0)[::-1] + ramp)
    lower = np.minimum(np.minimum.accumulate(g - ramp, axis=0) + ramp,
                       np.minimum.accumulate((g + ramp)[::-1], axis=0)[::-1] - ramp)
    out = 0.5 * (upper + lower)
    end = g[-1]
    to_end = (n - 1 - index) * delta
    out = np.clip(out, end - to_end, end + to_end)
    if start is not None:
        first = np.asarray(start, dtype=np.float64)
        from_start = (index + 1) * delta
        out = np.clip(out, first - from_start, first + from_start)
    return np.where(free, g, out)


def max_steps(arm: Arm | None, servos: Sequence[ServoSpec], period: float,
              joints: int) -> NDArray[np.float64]:
    """Each joint's largest goal step, ticks: v_max·T (inf without an arm)."""
    if arm is None:
        return np.full(joints, np.inf)
    return np.array([j.max_velocity * period * s.ticks_per_turn / (2.0 * math.pi)
                     for j, s in zip(arm.joints, servos, strict=True)])


def compensated_ticks(joints: NDArray[np.float64], period: float,
                      servos: Sequence[ServoSpec], limits: NDArray[np.int64],
                      arm: Arm | None = None,
                      p_gains: Sequence[int] | None = None, *,
                      i_gains: Sequence[int] | None = None,
                      start_goal: ArrayLike | None = None,
                      present: ArrayLike | None = None,
                      payload_kg: float | None = None, first: int = 0) -> NDArray[np.int64]:
    """Goal ticks (n, k) that make the servos follow ``joints`` (n, k) rad (module notes).

    Parameters
    ----------
    joints : planned joint angles, one row a sample, ``period`` s apart.
    servos : the servos in joint order (model, ticks per turn, zero, direction).
    limits : (k, 2) servo position limits, ticks.
    arm : the arm whose bodies load the joints (None: the motors alone, no step limit).
    p_gains, i_gains : Position P and I Gains per servo (default: the model's factory
        values, I = 0).
    start_goal : the Goal Position (k,) the servos hold before sample 0, ticks: the first
        step is limited from it (None: from the first led goal, unconstrained).
    present : Present Position (k,) before sample 0, ticks: the friction sign before the
        first motion (None: no Coulomb term before it).
    payload_kg : the point mass at the tool point (None: the arm file's ``payload_kg``).
    first : rows before it only give the differences (an online tail's samples before its
        switch): the step limit applies from row ``first``, ``start_goal`` being the goal
        held before that row; the rows before are led but not limited.
    """
    joints = np.asarray(joints, dtype=np.float64)
    qd, qdd = derivatives(joints, period)
    q_m, qd_m, qdd_m = _midpoints(joints), _midpoints(qd), _midpoints(qdd)
    torque = plan_torques(arm, servos, q_m, qd_m, qdd_m, payload_kg)
    initial = None
    if present is not None and len(joints):
        gap = (radians_to_ticks(joints[0], servos) - np.asarray(present, dtype=np.int64)) \
            * np.array([s.direction for s in servos])
        initial = np.where(np.abs(gap) > GAP_TICKS, np.sign(gap), 0.0)
    held = _held_sign(qd_m, 1e-6, initial)
    p = _gains(servos, p_gains, DEFAULT_P_GAIN)
    i = _gains(servos, i_gains, 0)
    led = np.empty(joints.shape, dtype=np.float64)
    for j, spec in enumerate(servos):
        u = motor_of(spec.model).duty_for(qd_m[:, j], torque[:, j], held[:, j])
        lag = lag_pulses(PWM_FULL * u, period, p[j], i[j]) * spec.ticks_per_turn / 4096.0
        led[:, j] = spec.zero_offset + spec.direction * (
            q_m[:, j] * spec.ticks_per_turn / (2.0 * math.pi) + lag)
    led[first:] = limit_steps(led[first:], max_steps(arm, servos, period, len(servos)),
                              start_goal)
    lo, hi = limits[:, 0], limits[:, 1]
    return np.clip(np.round(led), lo, hi).astype(np.int64)


def holding_goals(arm: Arm | None, servos: Sequence[ServoSpec], present: ArrayLike,
                  limits: NDArray[np.int64], p_gains: Sequence[int] | None = None,
                  payload_kg: float | None = None) -> NDArray[np.int64]:
    """Goals (k,) that hold the arm where it is, ticks: ``present`` led by the static
    gravity lag 885·u(g(q))/KPP of a P loop (``present`` itself without gravity or arm)."""
    present = np.asarray(present, dtype=np.int64)
    if arm is None:
        return present.copy()
    q = ticks_to_radians(present, servos)
    tau = gravity_torque(rigid_chain(arm), q, payload_of(arm, payload_kg))
    p = _gains(servos, p_gains, DEFAULT_P_GAIN)
    out = present.astype(np.float64)
    for j, spec in enumerate(servos):
        motor = motor_of(spec.model)
        u = float(motor.duty_for(np.zeros(1), np.array([tau[j]]), np.zeros(1))[0])
        out[j] += spec.direction * PWM_FULL * u / (p[j] / 128.0) * spec.ticks_per_turn / 4096.0
    return np.clip(np.round(out), limits[:, 0], limits[:, 1]).astype(np.int64)


__all__ = ["GAP_TICKS", "compensated_ticks", "holding_goals", "lag_pulses", "limit_steps",
           "max_steps", "payload_of", "plan_load", "plan_torques"]
