"""The mechanics the servos drive: shafts (and an arm's rigid bodies), integrated lazily.

A :class:`Plant` owns the output-shaft angles θ (rad, continuous) and velocities ω of a
set of servos. Nothing ticks: whenever one of its servos is read or written, the plant
advances in fixed steps of ``PHYSICS_STEP_S`` up to that time. Each step solves, for the
shafts' velocities, the semi-implicit (backward in the damping) Euler equation::

    (A + h·C)·ω⁺ = A·ω + h·(τ₀ − b − τ_f),     θ⁺ = θ + h·ω⁺

A = diag(J_rotor·N² + a lone shaft's load) + the arm's mass matrix in shaft coordinates,
C = diag(c) the motors' back-EMF and viscous damping (:mod:`firmware_sim.drive`), b the
arm's Coriolis/centrifugal, yaw-coupling and gravity torques (:mod:`firmware_sim.chain`),
τ_f Coulomb friction with stiction: a shaft slower than ``STICTION_RAD_S`` whose net torque
(τ₀ − b, the motor's and the arm's) is within ±τ_c stays stuck (ω⁺ = 0), and so does one
whose step would reverse it.
An obstacle clamps a shaft at its angle and stops it (an inelastic stop).

An arm's mechanical end stops (:attr:`ArmModel.stops`, just beyond its joint limits) are
inelastic too, within the coupled step: a joint whose step would reach a stop moving into
it is held at the stop with ω⁺ = 0 and the others are solved again with it held (the stop
reacts whatever torque pushes into it; the momentum A·ω it had goes into the others as in
a plastic impact). An arm with a rest pose (:attr:`ArmModel.rest`) lies on its support
there: while every chain joint gravity loads is within ``REST_SUPPORT_RAD`` of its rest
angle, each is stopped at that angle on the side gravity turns it (the folded OM-X lying
on its links and base) — so an unpowered arm at rest stays at rest.

Joint i of an arm relates to its servo's shaft by θ = θ₀ + ρ·q with ρ = direction·
ticks_per_turn/4096 (θ₀ from zero_offset), so M_θ = R⁻¹·M_q·R⁻¹ and b_θ = R⁻¹·b_q, R = diag(ρ).

When every shaft is still and every drive is steady (:meth:`Drive.steady`) the plant skips
ahead in one call instead of stepping, so an idle bus costs nothing.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from firmware_sim.arm_model import ArmModel
from firmware_sim.drive import PULSES_PER_RAD, Drive

#: Integration step, s (the motors' mechanical time constants are 15-17 ms).
PHYSICS_STEP_S = 0.0005
#: Below this shaft speed, rad/s, static friction may hold the shaft.
STICTION_RAD_S = 1e-3
#: The rest support holds while every joint it holds is this close to its rest angle, rad.
REST_SUPPORT_RAD = math.radians(1.0)


def _into(theta: float, omega: float, wall: tuple[float, float]) -> bool:
    """Whether a shaft moving at ``omega`` reaches ``theta`` at or past a wall it runs into."""
    return (omega > 0 and theta >= wall[1]) or (omega < 0 and theta <= wall[0])


def _solve(a: list[list[float]], b: list[float]) -> list[float]:
    """x with a·x = b by Gaussian elimination with partial pivoting (n ≤ 6; a, b consumed)."""
    n = len(b)
    for col in range(n):
        piv, best = col, abs(a[col][col])       # the first row of the largest |a[r][col]|
        for r in range(col + 1, n):
            v = abs(a[r][col])
            if v > best:
                piv, best = r, v
        if piv != col:
            a[col], a[piv] = a[piv], a[col]
            b[col], b[piv] = b[piv], b[col]
        inv = 1.0 / a[col][col]
        for r in range(col + 1, n):
            f = a[r][col] * inv
            if f:
                row, prow = a[r], a[col]
                for k in range(col, n):
                    row[k] -= f * prow[k]
                b[r] -= f * b[col]
    x = [0.0] * n
    for r in range(n - 1, -1, -1):
        acc = b[r]
        row = a[r]
        for k in range(r + 1, n):
            acc -= row[k] * x[k]
        x[r] = acc / row[r]
    return x


class Plant:
    """Shafts driven by servos, optionally coupled through an arm.

    Parameters
    ----------
    drives : sequence of Drive
        One per shaft.
    theta : sequence of float
        Initial shaft angles, rad.
    t0 : float
        Plant time, s.
    arm : ArmModel, optional
        Couples the shafts (in the arm's joint order, which ``drives`` must follow).
    step : float
        Integration step, s.
    load_inertia : sequence of float, optional
        Per shaft, the inertia of what it carries besides an arm's bodies, kg·m² at the
        output (e.g. a gripper's jaws); default 0.
    """

    def __init__(self, drives: Sequence[Drive], theta: Sequence[float], t0: float,
                 arm: ArmModel | None = None, step: float = PHYSICS_STEP_S,
                 load_inertia: Sequence[float] | None = None) -> None:
        if arm is not None and arm.dof != len(drives):
            raise ValueError(f"arm has {arm.dof} joints but {len(drives)} servos were given")
        self.drives = list(drives)
        self.n = len(self.drives)
        self.theta = [float(x) for x in theta]
        self.omega = [0.0] * self.n
        self.t = float(t0)
        self.step = float(step)
        self.arm = arm
        loads = [0.0] * self.n if load_inertia is None else [float(x) for x in load_inertia]
        if len(loads) != self.n:
            raise ValueError(f"load_inertia needs {self.n} values, got {len(loads)}")
        rotor = [d.motor.inertia for d in self.drives]
        if arm is not None and arm.rotor_inertia is not None:
            rotor = list(arm.rotor_inertia)          # the arm file's J_rotor·N²
        #: Per shaft: the rotor's reflected inertia J_rotor·N² plus its own load, kg·m².
        self.inertia = [r + load for r, load in zip(rotor, loads, strict=True)]
        if arm is not None:
            self.rho = [jm.direction * jm.ticks_per_turn / 4096 for jm in arm.joints]
            self.theta0 = [jm.zero_offset / PULSES_PER_RAD for jm in arm.joints]
        else:
            self.rho = [1.0] * self.n
            self.theta0 = [2048 / PULSES_PER_RAD] * self.n
        #: Per shaft: None or (angle rad, side): side +1 blocks θ above it, -1 below.
        self.obstacles: list[tuple[float, int] | None] = [None] * self.n
        #: Per shaft: None or its end stops (low, high), shaft angles (rad).
        self.stops: list[tuple[float, float] | None] = [None] * self.n
        #: (shaft, angle, side) of the rest support, side +1 blocking above, -1 below.
        self.rest_support: list[tuple[int, float, int]] = []
        if arm is not None:
            self._arm_stops(arm)
        #: The servos whose shafts these are (they snapshot their settings before a step).
        self.owners: list = []
        self.steps_taken = 0

    def set_arm(self, arm: ArmModel) -> None:
        """Carry ``arm`` from now on (another payload, say): same joints, new bodies; the
        rest support follows its gravity. The caller advances the plant to now first."""
        if self.arm is None or arm.dof != self.n:
            raise ValueError(f"the plant carries no arm of {arm.dof} joints")
        self.arm = arm
        self.rest_support = []
        self._arm_stops(arm)

    def _arm_stops(self, arm: ArmModel) -> None:
        """The arm's end stops and its rest support in shaft angles."""
        for j, stop in enumerate(arm.stops or ()):
            if stop is not None:
                ends = sorted(self.shaft_angle(j, q) for q in stop)
                self.stops[j] = (ends[0], ends[1])
        if arm.rest is None:
            return
        _, bias = arm.dynamics(arm.rest, [0.0] * self.n)     # gravity alone at rest
        for j, b in enumerate(bias):
            if b:                     # gravity turns joint j towards −b: the arm lies there
                side = 1 if -b * self.rho[j] > 0 else -1
                self.rest_support.append((j, self.shaft_angle(j, arm.rest[j]), side))

    # ---- joints ---------------------------------------------------------------------
    def joint_angle(self, j: int) -> float:
        """Joint angle q_j, rad (θ = θ₀ + ρ·q)."""
        return (self.theta[j] - self.theta0[j]) / self.rho[j]

    def shaft_angle(self, j: int, q: float) -> float:
        return self.theta0[j] + self.rho[j] * q

    def set_obstacle(self, j: int, q_deg: float | None) -> None:
        """Block joint ``j`` beyond ``q_deg`` degrees, on the far side from where it is now
        (None removes it)."""
        if q_deg is None:
            self.obstacles[j] = None
            return
        wall = self.shaft_angle(j, math.radians(q_deg))
        side = 1 if wall >= self.theta[j] else -1
        self.obstacles[j] = (wall, side)

    # ---- time -----------------------------------------------------------------------
    def advance(self, t: float) -> None:
        """Step up to time ``t`` (the last partial step waits for the next call); the
        owners snapshot their control tables first (``configure_drive``)."""
        h = self.step
        steps = int((t - self.t) / h + 1e-9)
        if steps <= 0:
            return
        for owner in self.owners:
            owner.configure_drive()
        omega = self.omega
        drives = self.drives
        for k in range(steps):
            self._step()
            if not any(omega) and all(d.steady(self.t) for d in drives):
                self._skip((steps - k - 1) * h)
                return

    def _skip(self, dt: float) -> None:
        """Stay still for ``dt``: heat and timers advance exactly; time moves on. Stops at
        a temperature limit or the overload time so that the next step reports it."""
        if dt <= 0:
            return
        until = min([dt] + [d.time_to_overheat() for d in self.drives]
                    + [d.time_to_overload() for d in self.drives])
        until = math.floor(until / self.step) * self.step
        for d in self.drives:
            d.skip(until)
        self.t += until
        if until < dt:
            self.advance(self.t + (dt - until))

    def _step(self) -> None:
        h = self.step
        t = self.t
        n = self.n
        theta, omega = self.theta, self.omega
        drives = self.drives
        if n == 1:
            d = drives[0]
            tau0, c = d.torque(t, theta[0], omega[0], h)
            tc = d.motor.coulomb
            w = omega[0]
            j = self.inertia[0]
            if -STICTION_RAD_S < w < STICTION_RAD_S and -tc <= tau0 <= tc:
                w_new = 0.0
            else:
                fric = math.copysign(tc, w if abs(w) >= STICTION_RAD_S else tau0)
                w_new = (j * w + h * (tau0 - fric)) / (j + h * c)
                if w * w_new < 0.0 and -tc <= tau0 <= tc:
                    w_new = 0.0
            th = theta[0] + h * w_new
            obstacle = self.obstacles[0]
            if obstacle is not None:
                wall, side = obstacle
                if (th - wall) * side > 0:
                    th = wall
                    if w_new * side > 0:
                        w_new = 0.0
            theta[0] = th
            omega[0] = w_new
        else:
            self._step_coupled(t, h)
        self.t = t + h
        self.steps_taken += 1

    def _walls(self) -> list[tuple[float, float] | None]:
        """Per shaft the (low, high) angles it cannot pass now: its end stops, narrowed by
        the rest support while the arm lies at rest (module notes), or None."""
        walls = list(self.stops)
        rest = self.rest_support
        if rest and all(abs(self.theta[j] - wall) <= REST_SUPPORT_RAD for j, wall, _ in rest):
            for j, wall, side in rest:
                lo, hi = walls[j] or (-math.inf, math.inf)
                walls[j] = (lo, min(hi, wall)) if side > 0 else (max(lo, wall), hi)
        return walls

    def _step_coupled(self, t: float, h: float) -> None:
        n = self.n
        theta, omega, drives = self.theta, self.omega, self.drives
        tau0 = [0.0] * n
        damp = [0.0] * n
        for j, d in enumerate(drives):
            tau0[j], damp[j] = d.torque(t, theta[j], omega[j], h)
        a = [[0.0] * n for _ in range(n)]
        rhs = list(tau0)
        if self.arm is not None:
            rho = self.rho
            q = [(theta[j] - self.theta0[j]) / rho[j] for j in range(n)]
            qd = [omega[j] / rho[j] for j in range(n)]
            m, bias = self.arm.dynamics(q, qd)
            for i in range(n):
                for j in range(n):
                    a[i][j] = m[i][j] / (rho[i] * rho[j])
                rhs[i] -= bias[i] / rho[i]
        for j in range(n):
            a[j][j] += self.inertia[j]
        net = list(rhs)             # each joint's torque before friction: motor, arm's load
        free = []
        for j, d in enumerate(drives):
            tc = d.motor.coulomb
            w = omega[j]
            if abs(w) < STICTION_RAD_S:
                if abs(rhs[j]) <= tc:
                    continue                      # stuck
                rhs[j] -= math.copysign(tc, rhs[j])
            else:
                rhs[j] -= math.copysign(tc, w)
            free.append(j)
        walls = self._walls()
        locked: list[int] = []          # at an end stop, pushed into it: velocity 0
        while True:
            new = [0.0] * n
            moving = [j for j in free if j not in locked]
            if moving:
                af = [[a[i][j] for j in moving] for i in moving]
                bf = []
                for r, i in enumerate(moving):
                    af[r][r] += h * damp[i]
                    row, acc = a[i], 0.0
                    for k in range(n):
                        acc += row[k] * omega[k]
                    bf.append(acc + h * rhs[i])
                for i, w in zip(moving, _solve(af, bf), strict=True):
                    if omega[i] * w < 0.0 and abs(net[i]) <= drives[i].motor.coulomb:
                        w = 0.0         # friction stops a reversal it can hold (as stuck)
                    new[i] = w
            hit = [j for j in moving if walls[j] is not None
                   and _into(theta[j] + h * new[j], new[j], walls[j])]
            if not hit:
                break
            locked += hit
        for j in locked:
            lo, hi = walls[j]
            theta[j] = min(max(theta[j], lo), hi)
        for j in range(n):
            th = theta[j] + h * new[j]
            obstacle = self.obstacles[j]
            if obstacle is not None:
                wall, side = obstacle
                if (th - wall) * side > 0:
                    th = wall
                    if new[j] * side > 0:
                        new[j] = 0.0
            theta[j] = th
            omega[j] = new[j]
