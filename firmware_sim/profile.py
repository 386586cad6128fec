"""X-series profile generator, evaluated analytically (no ticking).

Source: ROBOTIS e-manual, X-series "Profile Velocity(112)" / "Profile Acceleration(108)"
and "Drive Mode(10)"; summarised in /work/shared/dynamixel-notes.md §2.1.

Velocity-based profile (Drive Mode bit 2 = 0), V = Profile Velocity, A = Profile
Acceleration in control-table units:

* V = 0: step (the goal is taken at once);
* V > 0, A = 0: rectangle (constant velocity V);
* both > 0: trapezoid with accel time t1 = 64·V/A ms, cruise 64·|Δ|/V ms, or a triangle
  when V cannot be reached: total = 2·sqrt(|Δ|/a).

Units: the firmware's velocity unit is 1/64 pulse per ms = 15.625 pulse/s (the e-manual's
0.229 rpm = 15.633 pulse/s rounded to what the generator uses, which is what makes
t1 = 64·V/A ms exact) and its acceleration unit is that per 64 ms = 244.14 pulse/s²
(the e-manual's 214.577 rev/min²).

Time-based profile (Drive Mode bit 2 = 1): Profile Velocity = total time t3 [ms],
Profile Acceleration = acceleration time t1 [ms], t1 clamped to t3/2 (triangle then).

A new goal during motion re-plans from the present profile position *and velocity*, so
velocity stays continuous (e-manual "velocity override").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from firmware_sim.control_table import (
    MS_PROFILE_RECTANGLE,
    MS_PROFILE_TRAPEZOID,
    MS_PROFILE_TRIANGLE,
)

#: pulse/s per Profile/Goal/Present Velocity unit (1/64 pulse per ms).
VELOCITY_UNIT = 1000.0 / 64.0
#: pulse/s² per Profile Acceleration unit (one velocity unit per 64 ms).
ACCELERATION_UNIT = VELOCITY_UNIT / 0.064
#: Shortest ramp the generators build, s (far below the firmware's 1 ms resolution).
_MIN_RAMP_S = 1e-9
#: Moving Status bits for "no profile" (step).
PROFILE_STEP = 0x00


@dataclass(frozen=True)
class Segment:
    """Constant-acceleration piece: p(t) = p0 + v0·τ + a·τ²/2, τ = t - t0 in [0, dur]."""

    t0: float
    dur: float
    p0: float
    v0: float
    a: float

    def at(self, t: float) -> tuple[float, float]:
        tau = min(max(t - self.t0, 0.0), self.dur)
        return self.p0 + self.v0 * tau + 0.5 * self.a * tau * tau, self.v0 + self.a * tau


@dataclass(frozen=True)
class Profile:
    """A planned motion: segments in time order, then rest at ``final`` (or, for an
    endless last segment, constant velocity forever).

    Attributes
    ----------
    start : float
        Plan time (s).
    segments : tuple[Segment, ...]
    final : float
        Position after the last segment (the goal), pulses.
    end : float
        Time the profile completes, s (for an endless profile: the end of its ramp).
    kind : int
        Moving Status profile bits (0x30 trapezoid, 0x20 triangle, 0x10 rectangle, 0 step).
    endless : bool
        The last segment runs forever (velocity mode).
    key : tuple or None
        The request the plan answers, set by the caller.
    """

    start: float
    segments: tuple[Segment, ...]
    final: float
    end: float
    kind: int
    endless: bool = False
    #: What the plan was made from (the servo skips re-planning an identical request).
    key: tuple[object, ...] | None = None

    def state(self, t: float) -> tuple[float, float]:
        """(position pulses, velocity pulse/s) at time ``t``."""
        if self.endless and self.segments:
            last = self.segments[-1]
            if t >= last.t0:
                tau = t - last.t0
                return last.p0 + last.v0 * tau + 0.5 * last.a * tau * tau, last.v0 + last.a * tau
        elif t >= self.end:
            return self.final, 0.0
        for seg in self.segments:
            if t < seg.t0 + seg.dur:
                return seg.at(t)
        return self.final, 0.0

    def kinematics(self, t: float) -> tuple[float, float, float]:
        """(position pulses, velocity pulse/s, acceleration pulse/s²) at time ``t``."""
        if self.endless and self.segments:
            last = self.segments[-1]
            if t >= last.t0:
                tau = t - last.t0
                return (last.p0 + last.v0 * tau + 0.5 * last.a * tau * tau,
                        last.v0 + last.a * tau, last.a)
        elif t >= self.end:
            return self.final, 0.0, 0.0
        for seg in self.segments:
            if t < seg.t0 + seg.dur:
                p, v = seg.at(t)
                return p, v, seg.a
        return self.final, 0.0, 0.0

    def ongoing(self, t: float) -> bool:
        """Profile still running at ``t`` (for an endless profile: still accelerating)."""
        return t < self.end


def hold(t: float, position: float) -> Profile:
    """Stay at ``position`` from time ``t``."""
    return Profile(t, (), float(position), t, PROFILE_STEP)


class _Builder:
    def __init__(self, t: float, p: float, v: float) -> None:
        self.t, self.p, self.v = t, p, v
        self.segs: list[Segment] = []

    def add(self, dur: float, a: float) -> None:
        if dur <= 0:
            return
        seg = Segment(self.t, dur, self.p, self.v, a)
        self.segs.append(seg)
        self.p, self.v = seg.at(self.t + dur)
        self.t += dur


def plan_velocity_based(t: float, p: float, v: float, goal: float, vmax: float,
                        amax: float) -> Profile:
    """Velocity-based profile from state (p, v) at time t to rest at ``goal``.

    Parameters
    ----------
    t : float
        Start time, s.
    p, v : float
        Present profile position (pulse) and velocity (pulse/s).
    goal : float
        Target position, pulse.
    vmax : float
        Profile velocity, pulse/s (0 = step).
    amax : float
        Profile acceleration, pulse/s² (0 = rectangle).

    Returns
    -------
    Profile
        Step, rectangle, trapezoid or triangle (with a leading brake when the present
        velocity points away from the goal or cannot stop before it).
    """
    if vmax <= 0:
        return Profile(t, (), float(goal), t, PROFILE_STEP)
    d = goal - p
    if amax <= 0:
        dur = abs(d) / vmax
        seg = Segment(t, dur, p, math.copysign(vmax, d), 0.0)
        return Profile(t, (seg,) if dur > 0 else (), float(goal), t + dur, MS_PROFILE_RECTANGLE)
    b = _Builder(t, p, v)
    # brake first if moving away from the goal or too fast to stop before it
    s = math.copysign(1.0, d) if d != 0 else math.copysign(1.0, v)
    w = v * s
    if w < 0 or w * w / (2 * amax) > abs(d):
        b.add(abs(v) / amax, -math.copysign(amax, v))
        d = goal - b.p
        s = math.copysign(1.0, d)
        w = 0.0
    dist = abs(d)
    if dist == 0 and w == 0:
        return Profile(t, tuple(b.segs), float(goal), b.t, MS_PROFILE_TRAPEZOID if b.segs
                       else PROFILE_STEP)
    if w > vmax:           # slow down to the (new) profile velocity first
        peak = vmax
        kind = MS_PROFILE_TRAPEZOID
    else:
        peak = math.sqrt(amax * dist + 0.5 * w * w)
        kind = MS_PROFILE_TRIANGLE
        if peak >= vmax:
            peak = vmax
            kind = MS_PROFILE_TRAPEZOID
    ramp = abs(peak * peak - w * w) / (2 * amax)
    brake = peak * peak / (2 * amax)
    cruise = max(dist - ramp - brake, 0.0)
    b.add(abs(peak - w) / amax, s * amax * (1 if peak >= w else -1))
    if cruise > 0:
        b.add(cruise / peak, 0.0)
    b.add(peak / amax, -s * amax)
    return Profile(t, tuple(b.segs), float(goal), b.t, kind)


def plan_time_based(t: float, p: float, v: float, goal: float, total: float,
                    accel: float) -> Profile:
    """Time-based profile: reach ``goal`` at rest after ``total`` s, ramps of ``accel`` s.

    With initial velocity v the peak follows from Δ = v·t1/2 + vp·(t3 - t1); accel is
    clamped to total/2 (triangle). total = 0: step; accel = 0: rectangle.
    """
    if total <= 0:
        return Profile(t, (), float(goal), t, PROFILE_STEP)
    d = goal - p
    t1 = min(max(accel, 0.0), total / 2)
    b = _Builder(t, p, v)
    if t1 < _MIN_RAMP_S:        # a ramp shorter than this is a rectangle in floating point
        b.v = d / total
        b.add(total, 0.0)
        return Profile(t, tuple(b.segs), float(goal), t + total, MS_PROFILE_RECTANGLE)
    peak = (d - v * t1 / 2) / (total - t1)
    b.add(t1, (peak - v) / t1)
    b.add(total - 2 * t1, 0.0)
    b.add(t1, -peak / t1)
    kind = MS_PROFILE_TRIANGLE if 2 * t1 >= total else MS_PROFILE_TRAPEZOID
    return Profile(t, tuple(b.segs), float(goal), t + total, kind)


def plan_velocity_mode(t: float, p: float, v: float, target: float, amax: float) -> Profile:
    """Velocity mode: ramp from v to ``target`` pulse/s at ``amax`` (0 = at once), then keep it.

    The e-manual's t1 = 64·Goal Velocity/A ms is the ramp from rest.
    """
    b = _Builder(t, p, v)
    ramp = abs(target - v) / amax if amax > 0 else 0.0
    b.add(ramp, math.copysign(amax, target - v) if ramp else 0.0)
    b.v = target
    b.segs.append(Segment(b.t, math.inf, b.p, target, 0.0))
    return Profile(t, tuple(b.segs), math.nan, t + ramp, MS_PROFILE_TRAPEZOID if ramp
                   else MS_PROFILE_RECTANGLE, endless=True)
