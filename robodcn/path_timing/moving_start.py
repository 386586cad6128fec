"""One moving start: from a joint state (q₀, q̇₀, q̈₀), brake along the present motion or
blend into the path to join.

API (joint space; the planner uses it for ``start_state`` plans, online retargets can too)
--------------------------------------------------------------------------------------
* :class:`JointState` — (q, q̇, q̈) at the start sample, (k,) each, rad, rad/s, rad/s².
* :func:`join` ``(state, q, s, limits, rate_hz, allow_brake=True) -> StartSegment`` — the
  start segment onto the path q(s) ((n, k) samples at (n,) parameters, C² between samples):

  - ``kind == "tangent"``: the state's velocity is (nearly) along the path: ``law`` is the
    path's law from the projected start speed, no correction;
  - ``kind == "blend"``: ``law`` is the path's law from the projected start and ``blend``
    a :class:`BlendOut` whose :meth:`BlendOut.correction` (added to q(s(t)) over its first
    ``blend.duration`` seconds) turns the state's velocity (and, with a jerk limit, its
    acceleration) into the path's;
  - ``kind == "brake"``: ``brake`` is a :class:`Brake`, the joint line along q̇₀ to rest at
    the acceleration limits (its ``law`` runs s ∈ [0, 1] from ṡ₀ = 1/T₀); the caller joins
    its path from rest at ``brake.q_stop`` (a path from there: ask :func:`join` again with
    ``allow_brake=False`` when none exists).

  Nothing raises for a start that cannot blend: the result says what to do.
* :func:`retry` ``(segment, state, q, s, limits, rate_hz) -> StartSegment | None`` — after
  a blend failed validation: the next, slower blend (lower path limits, longer window), or
  None when the tries are used up.
* :func:`brake_line` — the brake alone; :func:`timed` — a path's law on the planner's grid
  (limits × :data:`GRID_MARGIN`), from rest or from a start speed.

Maths (Lynch & Park's time scaling of a path; Pham & Pham 2018 for the reachability sets):
ṡ₀ is the least-squares projection of q̇₀ on the tangent q'(0), ṡ₀ = max(0, q'·q̇₀ / |q'|²)
(capped below the fastest start speed from which the path can still be followed,
:func:`~robodcn.path_timing.max_start_speed`), s̈₀ likewise from q̈₀ − q''ṡ₀². What it leaves,
r_v = q̇₀ − q'ṡ₀ and r_a = q̈₀ − q''ṡ₀² − q's̈(0), is blended out over T_b by the quintic
e(t) = T_b r_v h_v(t/T_b) + T_b² r_a h_a(t/T_b), h_v = τ(1 − τ)³(1 + 3τ), h_a = τ²(1 − τ)³/2
(e(0) = 0, ė(0) = r_v, ë(0) = r_a, zero to second order at T_b). The path is timed with its
limits scaled by k (velocity k, acceleration k²) and T_b is long enough that the
correction's acceleration peak 3.94 |r_v| / T_b stays within (1 − k²) a (and its jerk
36 |r_v| / T_b² + 9 |r_a| / T_b within half of (1 − k³) j). Without a jerk limit the room is
kept only inside the window (:func:`windowed`), and when that window is longer than braking
to rest (a goal off the present heading, a reversal) the start brakes instead.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from robodcn.errors import InputError
from robodcn.path_timing.law import PathTiming
from robodcn.path_timing.limits import JointLimits
from robodcn.path_timing.optimal import max_start_speed, time_optimal
from robodcn.path_timing.topp import path_derivatives

__all__ = [
    "GRID_MARGIN",
    "BlendOut",
    "Brake",
    "JointState",
    "StartSegment",
    "brake_line",
    "join",
    "retry",
    "timed",
]

#: A path is timed with its limits × this (velocity; acceleration × its square, jerk × its
#: cube): the grid bounds the limits at the stages only, and between them the stream's
#: samples can pass them by about 0.1 %.
GRID_MARGIN = 0.999
#: A moving start's path is first timed with its acceleration (and jerk) limits × this
#: square (cube), its velocity limits whole: the acceleration across the start mixes the
#: given state's and the law's.
MOVING_SCALE = 0.995
#: The blend-out ends within this share of the path's law.
BLEND_SHARE = 0.8
#: Share of the fastest admissible start speed a moving start may keep: without a jerk limit
#: the law may ride the controllable set's edge (rounding only), with one the jerk pass needs
#: room to ramp the acceleration.
START_SPEED_SHARE = 1.0 - 1e-6
START_SPEED_SHARE_JERK = 0.95
#: Blend-out windows (s) tried in turn, each with the path's limit scale k.
BLEND_TRIES = ((0.05, 0.9), (0.1, 0.8), (0.15, 0.7), (0.25, 0.6), (0.4, 0.5), (0.6, 0.4),
               (0.9, 0.3), (1.2, 0.2), (1.5, 0.12))
#: max |h_v''| over [0, 1] (at τ ≈ 0.243): the blend-out's acceleration is ≤ this r_v / T_b
HV2_PEAK = 3.94
#: |h_v'''(0)| and |h_a'''(0)|: the blend-out's jerk is at most these × r_v/T_b², r_a/T_b
HV3_PEAK, HA3_PEAK = 36.0, 9.0
#: Without a jerk limit the blend-out first runs in a window: the path's limits are
#: velocity k v and acceleration (k a)² with this k only over the samples the law passes
#: before T_b, whole after it.
WINDOW_SCALE = 0.75
#: A brake shorter than this (s) is no brake: the state has no velocity to lose.
MIN_BRAKE_S = 1e-9
#: Shares of the projected start speed tried when the jerk pass finds no law from it.
START_SHARES = (1.0, 0.7, 0.4, 0.0)


@dataclass(frozen=True)
class JointState:
    """A joint state at one sample: q (rad), q̇ (rad/s), q̈ (rad/s²), (k,) each."""

    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]

    @property
    def moving(self) -> bool:
        return bool(np.any(self.qd != 0.0) or np.any(self.qdd != 0.0))


@dataclass(frozen=True)
class BlendOut:
    """The joint-space correction e(t) from the state onto the path (module doc)."""

    rv: NDArray[np.float64]
    ra: NDArray[np.float64]
    duration: float

    def correction(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """e(t), (len(t), k), zero from t = T_b on."""
        tau = np.clip(t / self.duration, 0.0, 1.0)[:, None]
        hv = tau * (1 - tau) ** 3 * (1 + 3 * tau)
        ha = 0.5 * tau ** 2 * (1 - tau) ** 3
        tb = self.duration
        return tb * self.rv[None, :] * hv + tb * tb * self.ra[None, :] * ha


@dataclass(frozen=True)
class Brake:
    """Braking along the present motion: the joint line q(s) = q₀ + s (q_stop − q₀), s ∈ [0, 1],
    whose tangent is q̇₀ T₀, timed from ṡ₀ = 1/T₀ to rest at s = 1 (``law``)."""

    q0: NDArray[np.float64]
    q_stop: NDArray[np.float64]
    s: NDArray[np.float64]
    q: NDArray[np.float64]
    law: PathTiming


@dataclass(frozen=True)
class StartSegment:
    """How a moving start joins the path (module doc): ``kind`` and its data.

    ``law``: the path's law from the start ("tangent", "blend"); ``blend``: the correction
    ("blend"); ``brake``: the brake ("brake"); ``scale``: the path's limit scale k;
    ``sd0``: the start speed along the path; ``tries``: the blend tries left for
    :func:`retry`.
    """

    kind: Literal["tangent", "blend", "brake"]
    law: PathTiming | None = None
    blend: BlendOut | None = None
    brake: Brake | None = None
    scale: float = 1.0
    sd0: float = 0.0
    tries: tuple[tuple[float, float], ...] = BLEND_TRIES


def path_limits(limits: JointLimits, scale: float = 1.0, v_room: NDArray | None = None
                ) -> JointLimits:
    """The path's limits on the grid: velocity v − v_room (room left for a blend-out's
    velocity), or v k when there is none; acceleration a k², jerk j k³ (all × GRID_MARGIN's
    powers)."""
    m = GRID_MARGIN
    v = limits.v * scale * m if v_room is None else np.maximum(limits.v - v_room,
                                                               1e-9 * limits.v) * m
    return JointLimits(v, limits.a * (scale * m) ** 2,
                       None if limits.j is None else limits.j * (scale * m) ** 3,
                       None if limits.torque is None else limits.torque.shrunk(m),
                       None if limits.tool is None else limits.tool.scaled(scale * m))


def timed(q: NDArray, s: NDArray, limits: JointLimits, rate_hz: float, *,
          sd_start: float = 0.0, sdd_start: float = 0.0, scale: float = 1.0,
          v_room: NDArray | None = None) -> PathTiming | None:
    """The law of the path q(s) under :func:`path_limits` (C² path: ``smooth``); None when no
    joint moves along it. Raises the path timing's InputError when the start cannot be
    followed."""
    if not _moves(q):
        return None
    lim = path_limits(limits, scale, v_room)
    return time_optimal(q, s, lim.v, lim.a, lim.j, sd_start=sd_start, sdd_start=sdd_start,
                        rate_hz=rate_hz, smooth=True, torque=lim.torque, tool=lim.tool)


def _moves(q: NDArray) -> bool:
    """Whether a joint's range along q (n, k) exceeds 1e-12 rad (numpy.ptp as max − min).

    The range is at least |q_end − q_start| (both ends are in it, and rounding is monotone:
    fl(max − min) ≥ fl(|q_end − q_start|)), so a path whose ends differ by more moves: told
    from its two rows in plain floats; the reductions (along each joint's contiguous row: a
    reduction over the short axis of (n, k) is several times slower) only for a path that
    returns to where it started. A NaN range counts as moving."""
    first, last = q[0].tolist(), q[-1].tolist()
    if max(abs(b - a) for a, b in zip(first, last, strict=True)) > 1e-12:
        return True
    rows = np.ascontiguousarray(q.T)
    # a NaN range moves (time_optimal then names the bad q)
    return not float((np.maximum.reduce(rows, axis=1)
                      - np.minimum.reduce(rows, axis=1)).max()) <= 1e-12


def _tangent(q: NDArray, s: NDArray) -> NDArray:
    return path_derivatives(q, s, [], 1)[0][0]


def _projection(state: JointState, q: NDArray, s: NDArray, limits: JointLimits,
                scale: float, v_room: NDArray | None) -> tuple[float, float, NDArray, NDArray]:
    """(ṡ₀, s̈₀, r_v, r_a) of the state projected on the path (module doc)."""
    k = state.q.shape[0]
    if not state.moving:
        return 0.0, 0.0, np.zeros(k), np.zeros(k)
    qd0, qdd0 = state.qd, state.qdd
    d1, d2 = (d[0] for d in path_derivatives(q, s, [], 2))
    norm2 = float(d1 @ d1)
    sd0 = sdd0 = 0.0
    if norm2 > 0:
        lim = path_limits(limits, scale, v_room)
        sd0 = max(0.0, float(d1 @ qd0) / norm2)
        fastest = max_start_speed(q, s, lim.v, lim.a, torque=lim.torque, tool=lim.tool)
        sd0 = min(sd0, (START_SPEED_SHARE if lim.j is None else START_SPEED_SHARE_JERK)
                  * fastest)
        sdd0 = float(d1 @ (qdd0 - d2 * sd0 ** 2)) / norm2
        # the path's own start acceleration within its (scaled) limits: the rest is blended
        a_path = np.abs(d2 * sd0 ** 2 + d1 * sdd0)
        over = float(np.max(a_path / lim.a))
        if over > 1.0:
            sdd0 /= over
    return sd0, sdd0, qd0 - d1 * sd0, qdd0 - d2 * sd0 ** 2 - d1 * sdd0


def _from_projection(state: JointState, q: NDArray, s: NDArray, limits: JointLimits,
                     rate_hz: float, scale: float, blend: bool
                     ) -> tuple[PathTiming | None, float, NDArray, NDArray]:
    """The path's law from the projected start (limits × ``scale``): (law, ṡ₀, r_v, r_a), r_a
    from the law's own s̈(0) (without a jerk limit the law may start with any acceleration,
    so only the velocity is blended out: r_a = 0)."""
    # the first try (no blend-out) keeps the full velocity limits: a moving start may sit at
    # one; the blend-out tries scale velocity by k too (room for the blend-out's velocity)
    v_room = None if blend else np.zeros(state.q.shape[0])
    sd0, sdd0, rv, ra = _projection(state, q, s, limits, scale, v_room)
    law = None
    for share in START_SHARES:
        try:
            law = timed(q, s, limits, rate_hz, sd_start=sd0 * share, sdd_start=sdd0 * share,
                        scale=scale, v_room=v_room)
        except InputError:
            # the jerk pass found no law from this start (its filter needs room below the
            # controllable set's edge): start slower along the path; the blend-out carries
            # the rest of the velocity (from rest along the path at worst: share 0)
            if share == 0.0:
                raise
            continue
        if share != 1.0:
            sd0 *= share
            rv = state.qd - _tangent(q, s) * sd0
        break
    if state.moving and limits.j is None:
        ra = np.zeros_like(rv)
    elif state.moving:
        d1, d2 = (d[0] for d in path_derivatives(q, s, [], 2))
        sdd_law = 0.0 if law is None else float(law.at(np.array([0.0])).sdd[0])
        ra = state.qdd - d2 * sd0 ** 2 - d1 * sdd_law
    return law, sd0, rv, ra


def needs_blend(rv: NDArray, ra: NDArray, limits: JointLimits, rate_hz: float) -> bool:
    """Whether the projection's residual needs a blend-out: a velocity step of at most one
    sample of maximum acceleration (|r_v| ≤ a Δt, what rounding the start speed to the grid
    leaves at a velocity limit) is left as a step (validation checks the acceleration it
    makes across the start); an acceleration residual only matters with a jerk limit."""
    return bool((np.abs(rv) > limits.a / rate_hz).any() or (np.abs(ra) > 1e-4).any())


def blend_time(rv: NDArray, limits: JointLimits, scale: float, at_least: float = 0.0,
               ra: NDArray | None = None) -> float:
    """T_b: at least ``at_least``, and long enough that 3.94 |r_v| / T_b ≤ (1 − k²) a (and,
    with a jerk limit, 36 |r_v|/T_b² + 9 |r_a|/T_b within half of (1 − k³) j)."""
    ra = np.zeros_like(rv) if ra is None else ra
    tb = max(at_least,
             HV2_PEAK * float(np.max(np.abs(rv) / ((1.0 - scale ** 2) * limits.a))) * 1.05)
    if limits.j is not None:
        room = (1.0 - scale ** 3) * limits.j / 2.0
        tb = max(tb, float(np.sqrt(np.max(HV3_PEAK * np.abs(rv) / room))) * 1.05,
                 float(np.max(HA3_PEAK * np.abs(ra) / room)) * 1.05)
    return tb


def windowed(state: JointState, q: NDArray, s: NDArray, law: PathTiming | None, sd0: float,
             limits: JointLimits, rate_hz: float) -> tuple[PathTiming, BlendOut] | None:
    """Without a jerk limit: the path's law with room for the blend-out only inside its
    window, and the blend-out; None when it cannot (a jerk limit, no law, a window longer
    than BLEND_SHARE of the law, or no law from the start).

    The start speed is ṡ₀ capped so that the path's velocity q'ṡ₀ fits within
    WINDOW_SCALE v (the correction's velocity is at most |r_v|: max |h_v'| = 1). The window
    ends at the s the unwindowed law reaches at T_b: the windowed law is timed under limits
    no looser anywhere, so it reaches that s no earlier (Pham & Pham 2018: the greedy forward
    pass is the pointwise fastest profile within the controllable set).
    """
    if limits.j is not None or law is None:
        return None
    d1 = _tangent(q, s)
    m, k = GRID_MARGIN, WINDOW_SCALE
    v_w = limits.v * k * m
    sd0 = min(sd0, 0.999 * float(np.min(v_w / np.maximum(np.abs(d1), 1e-12))))
    rv = state.qd - d1 * sd0
    tb = blend_time(rv, limits, k)
    if tb > BLEND_SHARE * law.duration:
        return None
    s_b = float(law.at(np.array([tb])).s[0])
    n = s.shape[0]
    n_b = min(n, int(np.searchsorted(s, s_b)) + 2)
    v_s = np.tile(limits.v * m, (n, 1))
    a_s = np.tile(limits.a * (MOVING_SCALE * m) ** 2, (n, 1))
    v_s[:n_b] = v_w
    a_s[:n_b] = limits.a * (k * m) ** 2
    try:
        law = time_optimal(q, s, v_s, a_s, sd_start=sd0, rate_hz=rate_hz, smooth=True,
                           torque=None if limits.torque is None
                           else limits.torque.shrunk(MOVING_SCALE * m),
                           tool=None if limits.tool is None
                           else limits.tool.shrunk(MOVING_SCALE * m))
    except InputError:
        return None
    return law, BlendOut(rv, np.zeros_like(rv), tb)


def prefers_brake(state: JointState, q: NDArray, s: NDArray, limits: JointLimits,
                  rate_hz: float) -> bool:
    """Whether (no jerk limit) braking beats blending: the blend-out window T_b at
    WINDOW_SCALE is longer than braking to rest takes (max_j |q̇₀_j| / a_j) — the window's
    slower path then costs about as much as the braking, and a long window rarely fits."""
    d1 = _tangent(q, s)
    norm2 = float(d1 @ d1)
    sd0 = max(0.0, float(d1 @ state.qd) / norm2) if norm2 > 0 else 0.0
    if not needs_blend(state.qd - d1 * sd0, np.zeros_like(state.qd), limits, rate_hz):
        return False  # tangent already: the first try keeps the velocity as it is
    v_w = limits.v * WINDOW_SCALE * GRID_MARGIN
    sd0 = min(sd0, 0.999 * float(np.min(v_w / np.maximum(np.abs(d1), 1e-12))))
    rv = state.qd - d1 * sd0
    return blend_time(rv, limits, WINDOW_SCALE) > float(np.max(np.abs(state.qd) / limits.a))


def brake_line(state: JointState, limits: JointLimits, rate_hz: float) -> Brake:
    """Brake along the present motion: the line q(s) = q₀ + s q̇₀ T₀ with
    T₀ = max_j |q̇₀_j| / 2a_j (× 1.0001) at the acceleration limits × GRID_MARGIN² (a line:
    q'' = 0, no curvature between the stages), so ṡ₀ = 1/T₀ matches q̇₀ exactly and s = 1 is
    the braking distance; its law reaches rest there."""
    a_m = limits.a * GRID_MARGIN ** 2
    t0 = 1.0001 * float(np.max(np.abs(state.qd) / (2.0 * a_m)))
    s = np.linspace(0.0, 1.0, 3)
    if not t0 > MIN_BRAKE_S:
        # no velocity to brake (a braking pause's last sample: q̇ = 0, q̈ ≠ 0; without a jerk
        # limit the acceleration may step): at rest where it is, a law of no duration (and
        # no 1/T₀)
        still = PathTiming(np.zeros(2), np.array([0.0, 1.0]), np.zeros(2), np.zeros(1))
        return Brake(state.q, state.q.copy(), s, np.repeat(state.q[None, :], 3, axis=0), still)
    if limits.torque is not None:
        braked = _torque_brake(state, limits, a_m, t0, rate_hz)
        if braked is not None:
            return braked
    q_stop = state.q + state.qd * t0
    q = state.q + np.outer(s, q_stop - state.q)
    law = time_optimal(q, s, limits.v, a_m, sd_start=1.0 / t0, rate_hz=rate_hz)
    return Brake(state.q, q_stop, s, q, law)


#: Samples of a brake line timed with torque limits (M(q) and g(q) vary along it), and the
#: lengthenings of T₀ tried when the servos' torque cannot brake within the line
TORQUE_BRAKE_SAMPLES = 41
TORQUE_BRAKE_LONGER = (1.0, 1.3, 1.7, 2.2, 3.0, 4.0, 6.0)


def _torque_brake(state: JointState, limits: JointLimits, a_m: NDArray, t0: float,
                  rate_hz: float) -> Brake | None:
    """The brake line within the torque limits too: T₀ (so the line) lengthened until its
    law can stop within it; None when none can (the start needs more torque than the
    servos have: the caller brakes as without torque and validation names the sample)."""
    s = np.linspace(0.0, 1.0, TORQUE_BRAKE_SAMPLES)
    for k in TORQUE_BRAKE_LONGER:
        t = t0 * k
        q_stop = state.q + state.qd * t
        q = state.q + np.outer(s, q_stop - state.q)
        try:
            law = time_optimal(q, s, limits.v, a_m, sd_start=1.0 / t, rate_hz=rate_hz,
                               torque=limits.torque.shrunk(GRID_MARGIN))
        except InputError:
            continue
        return Brake(state.q, q_stop, s, q, law)
    return None


def _next_blend(state: JointState, q: NDArray, s: NDArray, limits: JointLimits,
                rate_hz: float, tries: Sequence[tuple[float, float]]) -> StartSegment | None:
    """The next try whose blend-out ends within BLEND_SHARE of its law (a shorter law cannot
    carry it: try the next, lower k); the last try when none fits; None when none is left."""
    last = None
    for i, (at_least, scale) in enumerate(tries):
        law, sd0, rv, ra = _from_projection(state, q, s, limits, rate_hz, scale, blend=True)
        tb = blend_time(rv, limits, scale, at_least, ra)
        last = StartSegment("blend", law, BlendOut(rv, ra, tb), scale=scale, sd0=sd0,
                            tries=tuple(tries[i + 1:]))
        if law is None or tb <= BLEND_SHARE * law.duration:
            return last
    return last


def join(state: JointState, q: NDArray, s: NDArray, limits: JointLimits, rate_hz: float,
         *, allow_brake: bool = True) -> StartSegment:
    """The start segment from ``state`` onto the path q(s) (module doc: tangent, blend or
    brake). ``limits`` are the arm's (:class:`JointLimits`); brake only when
    ``allow_brake`` (the caller found no path from a brake's end: blend instead)."""
    can_brake = allow_brake and limits.j is None
    if not state.moving:
        law = timed(q, s, limits, rate_hz)
        return StartSegment("tangent", law, scale=1.0)
    scale = MOVING_SCALE
    if can_brake and prefers_brake(state, q, s, limits, rate_hz):
        return StartSegment("brake", brake=brake_line(state, limits, rate_hz), scale=scale)
    law, sd0, rv, ra = _from_projection(state, q, s, limits, rate_hz, scale, blend=False)
    if not needs_blend(rv, ra, limits, rate_hz):
        return StartSegment("tangent", law, scale=scale, sd0=sd0)
    found = windowed(state, q, s, law, sd0, limits, rate_hz)
    if found is not None:
        return StartSegment("blend", found[0], found[1], scale=scale, sd0=sd0)
    if can_brake:
        return StartSegment("brake", brake=brake_line(state, limits, rate_hz), scale=scale)
    nxt = _next_blend(state, q, s, limits, rate_hz, BLEND_TRIES)
    assert nxt is not None  # BLEND_TRIES is not empty
    return nxt


def retry(segment: StartSegment, state: JointState, q: NDArray, s: NDArray,
          limits: JointLimits, rate_hz: float) -> StartSegment | None:
    """After ``segment`` failed validation: the next blend-out try (longer, lower limits), or
    None when the tries are used up (or it was a brake: nothing slower to try)."""
    if segment.kind == "brake":
        return None
    return _next_blend(state, q, s, limits, rate_hz, segment.tries)
