"""Planning with ``profile="optimal"``: the geometric path timed by robodcn.path_timing.

The geometry is the method's (planner.path: segments, Bessel-tangent blending, branch-
continuous IK); only the time law differs from the uniform profiles.

* **Pieces.** The path is cut at every via where it stops (``blend=False``): ṡ = 0 there, so
  the time-optimal law of the whole path is the concatenation of the pieces' own
  rest-to-rest laws (the stops decouple them exactly); each piece is timed by
  :func:`robodcn.path_timing.time_optimal` on ``DENSE`` IK samples of its joint path q(s).
  With ``blend=True`` the whole path is one piece that passes every via. A joint-space
  approach from ``start_joints`` is a piece of its own (the straight joint line).
* **Sampling.** Each piece's law is sampled from its own t = 0 at the stream rate up to the
  first sample at or after its end (at rest there: a via is a sample at rest), the poses are
  the path at s(t) and the joints their branch-continuous IK — the same geometry as the
  dense samples the law was timed on.
* **Validation** stays sample by sample (planner.validate, jerk where set). The law is
  timed on a grid, so between grid points a limit can be passed by a little (curvature
  between stages); a piece whose samples fail is slowed by the failing ratio (a uniform
  stretch λ = r^(1/order), a few rounds) and sampled again; a moving first piece is re-timed
  with the limits scaled instead (a stretch would change its start speed). Nothing is
  clamped: a plan that still fails raises the first failing sample.
* **Fixed duration.** The pieces' optimal laws are stretched uniformly by one factor so that
  their whole periods add up to the duration; a duration shorter than the optimum
  compresses them alike, and validation names the first sample past a limit (as for the
  uniform laws). A fixed duration is never lengthened to pass validation. A moving start
  cannot be stretched (its start velocity would change), so a numeric duration with a
  moving ``start_state`` is refused (InputError on ``duration``).
* **Moving start** (``start_state``): the path runs from FK(q0) (the request's docstring);
  ṡ₀ is the least-squares projection of q̇0 on the path tangent q'(0),
  ṡ₀ = max(0, q'·q̇0 / |q'|²) (at most 95 % of the fastest start speed from which the path
  can still be followed, :func:`robodcn.path_timing.max_start_speed`), and s̈₀ likewise from
  q̈0 − q''ṡ₀² (without a jerk limit the acceleration may step at t = 0, so only the
  velocity must match: r_a = 0). What the projection leaves, r_v = q̇0 − q'ṡ₀ and
  r_a = q̈0 − q''ṡ₀² − q's̈(0),
  is blended out in joint space over the first T_b seconds by the quintic correction
  e(t) = T_b r_v h_v(t/T_b) + T_b² r_a h_a(t/T_b) with h_v = τ(1 − τ)³(1 + 3τ),
  h_a = τ²(1 − τ)³/2 (e(0) = 0, ė(0) = r_v, ë(0) = r_a, zero to second order at T_b): the
  plan starts exactly at the given joint state and is on the path from T_b on. The path is
  then timed with its limits scaled by k (velocity k, acceleration k²) and T_b is long
  enough that the correction's own acceleration peak 3.94 |r_v| / T_b stays within the
  remaining (1 − k²) a. Without a jerk limit the room is kept only inside the window
  (:func:`windowed_first`: per-sample limits up to the s the law reaches at T_b), and when
  that window would be longer than braking to rest (a goal off the current heading, a
  reversal) the plan brakes along the start velocity at the acceleration limits and goes
  from rest there (:func:`brake_then_go`) — also the fallback when the window fails
  validation. With a jerk limit k falls and T_b grows over a few tries (whole path scaled)
  until the sum passes validation, else the first failing sample is raised.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodcn import kinematics
from robodcn.contract import MAX_SAMPLES, intervals
from robodcn.errors import InputError, TooLargeError, Violation
from robodcn.path_timing import max_start_speed, path_derivatives, time_optimal
from robodcn.planner import search, validate
from robodcn.planner.path import (
    Path,
    Segment,
    blended_path,
    joints_of,
    segments_of,
    within_limits,
)
from robodcn.planner.request import PlanRequest

log = logging.getLogger(__name__)

#: IK samples per path segment the law is timed on (the whole path at most DENSE_MAX).
DENSE = 400
DENSE_MAX = 4000
#: Rounds of slowing a piece whose samples fail validation (grid effects) before raising.
RETRIES = 6
#: The law is timed with the limits × this (velocity; acceleration × its square, jerk × its
#: cube): the grid bounds the limits at the stages only, and between them the stream's
#: samples can pass them by about 0.1 %; a piece whose samples still fail is slowed (RETRIES)
GRID_MARGIN = 0.999
#: A moving start's first piece is first timed with its acceleration (and jerk) limits × this
#: square (cube), its velocity limits whole: the acceleration across the start mixes the
#: given state's and the law's
MOVING_SCALE = 0.995
#: The blend-out of a moving start ends within this share of the first piece's law.
BLEND_SHARE = 0.8
#: Share of the fastest admissible start speed a moving start may keep: without a jerk limit
#: the law may ride the controllable set's edge (rounding only), with one the jerk pass needs
#: room to ramp the acceleration.
START_SPEED_SHARE = 1.0 - 1e-6
START_SPEED_SHARE_JERK = 0.95
_ORDER = {"velocity": 1, "acceleration": 2, "jerk": 3}
# blend-out windows (s) tried for a non-tangent start, and the path's limit scale with each
_BLEND_TRIES = ((0.05, 0.9), (0.1, 0.8), (0.15, 0.7), (0.25, 0.6), (0.4, 0.5), (0.6, 0.4),
                (0.9, 0.3), (1.2, 0.2), (1.5, 0.12))
#: max |h_v''| over [0, 1] (at τ ≈ 0.243): the blend-out's acceleration is ≤ this r_v / T_b
_HV2_PEAK = 3.94
#: |h_v'''(0)| and |h_a'''(0)|: the blend-out's jerk is at most these × r_v/T_b², r_a/T_b
_HV3_PEAK, _HA3_PEAK = 36.0, 9.0
#: Without a jerk limit, a moving start's blend-out first runs in a window: the path's
#: limits are velocity v − |r_v| and acceleration (k a)² with this k only over the samples
#: the law passes before T_b, whole after it (the tries of _BLEND_TRIES scale the whole path)
WINDOW_SCALE = 0.75
#: shares of the projected start speed tried when the jerk pass finds no law from it
_START_SHARES = (1.0, 0.7, 0.4, 0.0)


@dataclass
class _Piece:
    """A stretch of the plan with its own law: path pieces map s → poses, the approach
    s → joints (s ∈ [0, 1])."""

    path: Path | None
    segment0: int  # index of the first waypoint segment (−1 on the approach)
    q_from: NDArray | None = None
    q_to: NDArray | None = None
    s: NDArray | None = None
    q: NDArray | None = None
    law: object = None
    count: int = 0

    def poses(self, s: NDArray, arm) -> NDArray:
        if self.path is None:
            return kinematics.fk(arm.links, self.joints_line(s))
        return self.path(np.clip(s, 0.0, 1.0))

    def joints_line(self, s: NDArray) -> NDArray:
        return self.q_from + np.outer(np.clip(s, 0.0, 1.0), self.q_to - self.q_from)


def limits(arm) -> tuple[NDArray, NDArray, NDArray | None]:
    """(v, a, j or None) of the arm's joints (j None when no joint sets a jerk limit)."""
    v, a, j = validate.dynamic_limits(arm)
    return v, a, (j if np.isfinite(j).any() else None)


def _dense_s(path: Path, count: int) -> NDArray:
    """Path parameters for the dense samples: uniform per segment, every knot included."""
    knots = path.knots
    parts = [np.linspace(knots[i], knots[i + 1], count + 1)[:-1] for i in range(len(knots) - 1)]
    return np.concatenate([*parts, [1.0]])


def _pieces(req: PlanRequest, segments: list) -> list[_Piece]:
    if req.blend:
        start = None if req.start_state is None else req.start_state.arrays()[0]
        return [_Piece(blended_path(req, segments, start), 0)]
    return [_Piece(Path([seg], np.array([0.0, 1.0]), None), j)
            for j, seg in enumerate(segments)]


def _segments(req: PlanRequest) -> list:
    """The request's segments; with a start state, from FK(q0) first (request docstring):
    the prepended segment takes segment 0's method, turn and β, θ chained on from the arm's."""
    if req.start_state is None:
        return segments_of(req)
    from robodcn.interpolate import turn_angle

    q0 = req.start_state.arrays()[0]
    pose = kinematics.fk(req.arm.links, q0[None, :])[0]
    wp = req.waypoints_array
    if req.position_only:
        wp[:, 2] = 0.0
        pose[2] = 0.0
    gap = abs((wp[0, 2] - pose[2] + math.pi) % (2 * math.pi) - math.pi)
    close = np.abs(pose[:2] - wp[0, :2]).max() <= 1e-4 and gap <= 1.75e-4
    methods = [req.segment_method(j) for j in range(req.segments)]
    turns = [req.segment_turn(j) for j in range(req.segments)]
    betas = [req.segment_beta(j) for j in range(req.segments)]
    if close:
        wp = wp[1:]
    else:
        methods, turns, betas = ([methods[0], *methods], [turns[0], *turns],
                                 [betas[0], *betas])
    out = []
    start = pose.copy()
    for j in range(wp.shape[0]):
        end = wp[j].copy()
        end[2] = start[2] + turn_angle(start[2], wp[j, 2], turns[j])
        out.append(Segment(start, end, methods[j], turns[j], betas[j]))
        start = end
    return out


def _scaled(arm, scale: float, v_room: NDArray | None
            ) -> tuple[NDArray, NDArray, NDArray | None]:
    """The path's limits: velocity v − v_room (room left for a blend-out's velocity), or
    v k when there is none; acceleration a k², jerk j k³ (all × GRID_MARGIN's powers)."""
    v, a, j = limits(arm)
    m = GRID_MARGIN
    v = v * scale * m if v_room is None else np.maximum(v - v_room, 1e-9 * v) * m
    return v, a * (scale * m) ** 2, None if j is None else j * (scale * m) ** 3


def _time(piece: _Piece, arm, rate: float, *, sd_start: float = 0.0, sdd_start: float = 0.0,
          scale: float = 1.0, v_room: NDArray | None = None):
    if float(np.ptp(piece.q, axis=0).max()) <= 1e-12:
        return None
    v, a, j = _scaled(arm, scale, v_room)
    return time_optimal(piece.q, piece.s, v, a, j, sd_start=sd_start, sdd_start=sdd_start,
                        rate_hz=rate, smooth=True)


def _sample(piece: _Piece, arm, rate: float, ref: NDArray | None, elbow: str
            ) -> tuple[NDArray, NDArray | None, int | None, NDArray]:
    """(poses, joints or None, first sample out of reach, s) of the piece's law."""
    if piece.law is None:  # nothing moves: held for one period
        s = np.zeros(2)
        piece.count = 1
        poses = piece.poses(s, arm)
        q, bad = (piece.joints_line(s), None) if piece.path is None else \
            joints_of(arm, poses, ref, elbow)
        return poses, q, bad, s
    m = piece.law.sample(rate)
    piece.count = m.t.shape[0] - 1
    if piece.path is None:
        q = piece.joints_line(m.s)
        return kinematics.fk(arm.links, q), q, None, m.s
    poses = piece.poses(m.s, arm)
    q, bad = joints_of(arm, poses, ref, elbow)
    if q is not None and arm.dof == 2:
        poses[:, 2] = q[:, 0] + q[:, 1]
    return poses, q, bad, m.s


def _needs_blend(req: PlanRequest, rv: NDArray, ra: NDArray) -> bool:
    """Whether the projection's residual needs a blend-out: a velocity step of at most one
    sample of maximum acceleration (|r_v| ≤ a Δt, what rounding the start speed to the grid
    leaves at a velocity limit) is tried as a step first, and validation checks the
    acceleration it makes across the start (a failure goes on to the blend-out); an
    acceleration residual only matters with a jerk limit (time_first zeroes it otherwise)."""
    _, a, _ = limits(req.arm)
    return bool((np.abs(rv) > a / req.rate_hz).any() or (np.abs(ra) > 1e-4).any())


def _next_blend(req: PlanRequest, first: _Piece, tries) -> tuple | None:
    """The next (T_b, k, r_v, r_a) whose blend-out ends within the first piece's law (a
    shorter law cannot carry it: try the next, lower k); the last try when none fits; None
    when the tries are used up."""
    last = None
    for tb, scale in tries:
        _, _, rv, ra = time_first(req, first, scale)
        tb = _window(tb, scale, rv, req.arm, ra)
        last = (tb, scale, rv, ra)
        if first.law is None or tb <= BLEND_SHARE * first.law.duration:
            return last
    return last


def _window(tb: float, scale: float, rv: NDArray, arm, ra: NDArray | None = None) -> float:
    """The blend-out time: at least ``tb``, and long enough that 3.94 |r_v| / T_b ≤ (1 − k²) a
    (module doc)."""
    _, a, j = limits(arm)
    ra = np.zeros_like(rv) if ra is None else ra
    tb = max(tb, _HV2_PEAK * float(np.max(np.abs(rv) / ((1.0 - scale ** 2) * a))) * 1.05)
    if j is not None:  # its jerk 36 r_v/T_b² + 9 r_a/T_b within half of (1 − k³) j
        room = (1.0 - scale ** 3) * j / 2.0
        tb = max(tb, float(np.sqrt(np.max(_HV3_PEAK * np.abs(rv) / room))) * 1.05,
                 float(np.max(_HA3_PEAK * np.abs(ra) / room)) * 1.05)
    return tb


def _correction(rv: NDArray, ra: NDArray, tb: float, t: NDArray) -> NDArray:
    """e(t) of the blend-out (module doc), zero from t = T_b on; (len(t), k)."""
    tau = np.clip(t / tb, 0.0, 1.0)[:, None]
    hv = tau * (1 - tau) ** 3 * (1 + 3 * tau)
    ha = 0.5 * tau ** 2 * (1 - tau) ** 3
    return tb * rv[None, :] * hv + tb * tb * ra[None, :] * ha


def windowed_first(req: PlanRequest, first: _Piece, sd0: float
                   ) -> tuple[float, NDArray, NDArray] | None:
    """Time the first piece of a moving start (no jerk limit) with room for its blend-out
    only inside the blend-out window; (T_b, r_v, r_a) or None when it cannot (a jerk limit,
    or no law from the start: the whole-path tries take over).

    The start speed is the projection ṡ₀ capped so that the path's velocity q'ṡ₀ fits
    within v − |r_v| (the correction's velocity is at most |r_v|: max |h_v'| = 1); T_b is
    :func:`_window`'s at k = WINDOW_SCALE. The window ends at the s the first (no blend-out)
    law reaches at T_b: the windowed law is timed under limits no looser anywhere, so its
    ṡ(s) is no higher and it reaches that s no earlier than T_b (Pham & Pham 2018: the
    greedy forward pass is the pointwise fastest profile within the controllable set).
    """
    v, a, j = limits(req.arm)
    if j is None and first.law is not None and first.path is not None:
        _, qd0, _ = req.start_state.arrays()
        d1 = path_derivatives(first.q, first.s, [], 1)[0][0]
        m, k = GRID_MARGIN, WINDOW_SCALE
        # the path's velocity within k v there (the correction's own is at most |r_v| and
        # decays as the path's grows; validation checks the sum sample by sample)
        v_w = v * k * m
        sd0 = min(sd0, 0.999 * float(np.min(v_w / np.maximum(np.abs(d1), 1e-12))))
        rv = qd0 - d1 * sd0
        tb = _window(0.0, k, rv, req.arm)
        if tb > BLEND_SHARE * first.law.duration:
            return None
        s_b = float(first.law.at(np.array([tb])).s[0])
        n_b = min(first.s.shape[0], int(np.searchsorted(first.s, s_b)) + 2)
        n = first.s.shape[0]
        v_s = np.tile(v * m, (n, 1))
        a_s = np.tile(a * (MOVING_SCALE * m) ** 2, (n, 1))
        v_s[:n_b] = v_w
        a_s[:n_b] = a * (k * m) ** 2
        try:
            first.law = time_optimal(first.q, first.s, v_s, a_s, sd_start=sd0,
                                     rate_hz=req.rate_hz, smooth=True)
        except InputError:
            return None
        return tb, rv, np.zeros_like(rv)
    return None


def _prefer_brake(req: PlanRequest, first: _Piece, scale: float) -> bool:
    """Whether a moving start (no jerk limit) brakes and goes rather than blends out: when
    the blend-out window T_b (:func:`_window` at WINDOW_SCALE, from the projection's
    residual) is longer than braking to rest would take (max_j |q̇0_j| / a_j) — the window's
    slower path then costs about as much as the braking, and a long window rarely fits."""
    _, qd0, _ = req.start_state.arrays()
    v, a, _ = limits(req.arm)
    if first.path is None:
        return False
    d1 = path_derivatives(first.q, first.s, [], 1)[0][0]
    norm2 = float(d1 @ d1)
    sd0 = max(0.0, float(d1 @ qd0) / norm2) if norm2 > 0 else 0.0
    if not _needs_blend(req, qd0 - d1 * sd0, np.zeros_like(qd0)):
        return False  # tangent already: the first try keeps the velocity as it is
    v_w = v * WINDOW_SCALE * GRID_MARGIN
    sd0 = min(sd0, 0.999 * float(np.min(v_w / np.maximum(np.abs(d1), 1e-12))))
    rv = qd0 - d1 * sd0
    return _window(0.0, WINDOW_SCALE, rv, req.arm) > float(np.max(np.abs(qd0) / a))


def brake_then_go(req: PlanRequest) -> list[_Piece] | None:
    """A moving start's pieces as "brake along the start velocity, then go": a joint line
    q(s) = q0 + s q̇0 T0 that brakes to rest at the acceleration limit (T0 = max_j |q̇0_j| /
    2a_j: the line's tangent is q̇0, so ṡ₀ = 1/T0 matches the given velocity exactly and
    s = 1 is the braking distance), then the request's path planned from rest there. Its
    duration is the bound any blend-out must beat; None when the path from there leaves the
    workspace."""
    import dataclasses

    from robodcn.planner.request import StartState

    q0, qd0, _ = req.start_state.arrays()
    v, a, _ = limits(req.arm)
    a_m = a * GRID_MARGIN ** 2  # a line: q'' = 0, no curvature between the stages
    t0 = 1.0001 * float(np.max(np.abs(qd0) / (2.0 * a_m)))
    q_stop = q0 + qd0 * t0
    waypoints = [list(w) for w in req.waypoints]
    here, there = kinematics.fk(req.arm.links, np.vstack([q0, q_stop]))
    gap = abs((waypoints[0][2] - here[2] + math.pi) % (2 * math.pi) - math.pi)
    if np.abs(here[:2] - np.asarray(waypoints[0][:2])).max() <= 1e-4 and (
            req.position_only or gap <= 1.75e-4):
        # the path was to start here: it starts where the braking ends instead
        waypoints[0] = [float(x) for x in there]
        if req.position_only:
            waypoints[0][2] = req.waypoints[0][2]
    still = (0.0,) * q0.shape[0]
    rest = dataclasses.replace(req, waypoints=waypoints,
                               start_state=StartState(tuple(q_stop), still, still))
    pieces, _ = build_pieces(rest)
    if pieces is None:
        return None
    for piece in pieces:  # from rest
        piece.law = _time(piece, req.arm, req.rate_hz)
    brake = _Piece(None, -1, q_from=q0, q_to=q_stop)
    brake.s = np.linspace(0.0, 1.0, 3)
    brake.q = brake.joints_line(brake.s)
    brake.law = time_optimal(brake.q, brake.s, v, a_m, sd_start=1.0 / t0, rate_hz=req.rate_hz)
    return [brake, *pieces]


def build_pieces(req: PlanRequest) -> tuple[list[_Piece] | None, NDArray | None]:
    """The pieces with their dense joint paths (None, first bad pose if the path leaves the
    workspace)."""
    arm = req.arm
    segments = _segments(req)
    pieces = _pieces(req, segments)
    state = req.start_state
    ref = None if state is None else state.arrays()[0]
    if req.start_joints is not None:
        ref = np.asarray(req.start_joints)
    limits_ = [(jt.min_angle, jt.max_angle) for jt in arm.joints]
    # dense geometry, branch-continuous across pieces
    per = max(16, min(DENSE, DENSE_MAX // max(1, len(segments))))
    first_q = None
    for piece in pieces:
        s = _dense_s(piece.path, per)
        poses = piece.path(s)
        q, bad = joints_of(arm, poses, ref, req.branch)
        if q is None:
            return None, poses[bad]
        if first_q is None:
            first_q = q[0]
        piece.s, piece.q = s, q
        ref = q[-1]
    # a piece along which no joint moves (coincident waypoints) takes no time: drop it
    moving_pieces = [p for p in pieces if float(np.ptp(p.q, axis=0).max()) > 1e-12]
    pieces = moving_pieces or pieces[:1]
    if req.start_joints is not None:
        start = np.asarray(req.start_joints)
        target = within_limits(first_q, limits_)
        tolerance = min(math.pi / jt.servo.ticks_per_turn for jt in arm.joints)
        if np.max(np.abs(target - start)) > tolerance:
            if np.max(np.abs(target - first_q)) > 0:  # the path's turn follows the approach
                shift = target - first_q
                for piece in pieces:
                    piece.q = piece.q + shift
            approach = _Piece(None, -1, q_from=start, q_to=target)
            approach.s = np.linspace(0.0, 1.0, 3)
            approach.q = approach.joints_line(approach.s)
            pieces.insert(0, approach)
    return pieces, None


def project_start(req: PlanRequest, first: _Piece, scale: float = 1.0,
                  v_room: NDArray | None = None) -> tuple[float, float, NDArray, NDArray]:
    """(ṡ₀, s̈₀, r_v, r_a) of a moving start on the first piece (module doc), under the
    path's limits :func:`_scaled` (scale, v_room)."""
    k = req.arm.dof
    state = req.start_state
    if state is None or not state.moving:
        return 0.0, 0.0, np.zeros(k), np.zeros(k)
    _, qd0, qdd0 = state.arrays()
    d1, d2 = (d[0] for d in path_derivatives(first.q, first.s, [], 2))
    norm2 = float(d1 @ d1)
    sd0 = sdd0 = 0.0
    if norm2 > 0:
        v, a, j = _scaled(req.arm, scale, v_room)
        sd0 = max(0.0, float(d1 @ qd0) / norm2)
        fastest = max_start_speed(first.q, first.s, v, a)
        sd0 = min(sd0, (START_SPEED_SHARE if j is None else START_SPEED_SHARE_JERK) * fastest)
        sdd0 = float(d1 @ (qdd0 - d2 * sd0 ** 2)) / norm2
        # the path's own start acceleration within its (scaled) limits: the rest is blended
        a_path = np.abs(d2 * sd0 ** 2 + d1 * sdd0)
        over = float(np.max(a_path / a))
        if over > 1.0:
            sdd0 /= over
    return sd0, sdd0, qd0 - d1 * sd0, qdd0 - d2 * sd0 ** 2 - d1 * sdd0


def time_pieces(req: PlanRequest, pieces: list[_Piece], scale: float = 1.0
                ) -> tuple[float, float, NDArray, NDArray]:
    """Time every piece; the first from the start state's projection (limits × ``scale``).
    Returns :func:`project_start`'s (ṡ₀, s̈₀, r_v, r_a)."""
    for piece in pieces[1:]:
        piece.law = _time(piece, req.arm, req.rate_hz)
    return time_first(req, pieces[0], scale, blend=False)


def time_first(req: PlanRequest, first: _Piece, scale: float, blend: bool = True
               ) -> tuple[float, float, NDArray, NDArray]:
    """Time the first piece from the projected start; r_a from the law's own s̈(0) (without
    a jerk limit the law may start with any acceleration, not the projected s̈₀)."""
    # the first try (no blend-out) keeps the full velocity limits: a moving start may sit at
    # one; the blend-out tries scale velocity by k too (room for the blend-out's velocity)
    v_room = None if blend else np.zeros(req.arm.dof)
    sd0, sdd0, rv, ra = project_start(req, first, scale, v_room)
    for share in _START_SHARES:
        try:
            first.law = _time(first, req.arm, req.rate_hz, sd_start=sd0 * share,
                              sdd_start=sdd0 * share, scale=scale, v_room=v_room)
        except InputError as exc:
            # the jerk pass found no law from this start (its filter needs room below the
            # controllable set's edge): start slower along the path; the blend-out carries
            # the rest of the velocity (from rest along the path at worst: share 0)
            if exc.field not in ("sd_start", "sdd_start") or share == 0.0:
                raise
            log.debug("optimal: no jerk-limited law from ṡ₀ = %.4g: trying slower", sd0 * share)
            continue
        if share != 1.0:
            qd0 = req.start_state.arrays()[1]
            d1 = path_derivatives(first.q, first.s, [], 1)[0][0]
            sd0 *= share
            rv = qd0 - d1 * sd0
        break
    if req.start_state is not None and req.start_state.moving and limits(req.arm)[2] is None:
        # without a jerk limit the acceleration may step at t = 0 (within its limits, which
        # validation checks across the start): only the velocity is blended out
        ra = np.zeros_like(rv)
    elif req.start_state is not None and req.start_state.moving:
        d1, d2 = (d[0] for d in path_derivatives(first.q, first.s, [], 2))
        sdd_law = 0.0 if first.law is None else float(first.law.at(np.array([0.0])).sdd[0])
        ra = req.start_state.arrays()[2] - d2 * sd0 ** 2 - d1 * sdd_law
    return sd0, sdd0, rv, ra


def fit_duration(req: PlanRequest, pieces: list[_Piece]) -> None:
    """Stretch every piece by one factor so the whole periods add up to req.duration."""
    rate = req.rate_hz
    total = intervals(req.duration, rate)
    need = [0.0 if p.law is None else p.law.duration for p in pieces]
    optimum = sum(math.ceil(d * rate - 1e-9) for d in need)
    if req.start_state is not None and req.start_state.moving:
        raise InputError("duration: a fixed duration cannot be combined with a moving "
                         "start_state (stretching the optimal law would change the start "
                         "velocity): use duration=\"auto\"", field="duration",
                         value=req.duration)
    if total < optimum:
        # shorter than the optimum: the laws compressed uniformly to it, so validation names
        # the first sample past a limit (as for the uniform profiles), nothing is clamped
        lam = total / optimum
        for piece in pieces:
            if piece.law is not None:
                piece.law = _compressed(piece.law, lam)
        return
    shares = search.split(total, need)
    # each share covers its piece's optimum (largest remainder may round one down: fix up)
    shares = [max(n, math.ceil(d * rate - 1e-9)) for n, d in zip(shares, need, strict=True)]
    while sum(shares) > total:
        spare = [n - math.ceil(d * rate - 1e-9) for n, d in zip(shares, need, strict=True)]
        shares[int(np.argmax(spare))] -= 1
    for piece, n in zip(pieces, shares, strict=True):
        if piece.law is not None:
            piece.law = piece.law.stretch(max(n / rate, piece.law.duration))


def stretch_factors(req: PlanRequest, joints: NDArray, history: NDArray | None) -> NDArray:
    """Per sample, the uniform stretch λ that brings its finite differences within the limits:
    max(|q̇|/v, √(|q̈|/a), ∛(|q⃛|/j)) over the joints, charged as validation charges them
    (to the last sample of each difference), and spread back over the samples they span."""
    v, a, j = validate.dynamic_limits(req.arm)
    rate = req.rate_hz
    f = np.ones(joints.shape[0])
    for order, lim in ((1, v), (2, a), (3, j)):
        if not np.isfinite(lim).any():
            continue
        d = validate._differences(joints, order, history) * rate ** order
        r = (d / lim).max(axis=1) ** (1.0 / order)
        for back in range(order + 1):  # every sample the difference spans
            f[:f.shape[0] - back] = np.maximum(f[:f.shape[0] - back], r[back:])
    return f


def _compressed(law, lam: float):
    """``law`` run λ < 1 times its duration (the inverse of PathTiming.stretch)."""
    from robodcn.path_timing import ChainTiming, PathTiming

    if isinstance(law, ChainTiming):
        return ChainTiming([_compressed(p, lam) for p in law.pieces])
    return PathTiming(law._tb, law._sb, law._vb, law._u, window=law.window,
                      s_start=law.s_start, stretch_factor=law.stretch_factor * lam)


def _slow(piece: _Piece, factor: float) -> None:
    if piece.law is None or factor <= 1.0:
        return
    factor *= 1.001
    piece.law = piece.law.stretch(piece.law.duration * factor)
    log.debug("optimal: piece slowed by %.4f (its samples passed a limit between the grid's "
              "stages)", factor)


def plan(req: PlanRequest):
    """The validated Trajectory of ``req`` with profile "optimal" (module docstring)."""
    from robodcn.planner import build
    from robodcn.planner.trajectory import Trajectory

    arm = req.arm
    rate = req.rate_hz
    validate.check_waypoints(req)
    pieces, bad_pose = build_pieces(req)
    if pieces is None:
        return _unreachable(req, bad_pose)
    tries = iter(_BLEND_TRIES)
    tb, scale, braking = 0.0, 1.0, False
    if req.start_state is not None and req.start_state.moving:
        scale = MOVING_SCALE
    if scale != 1.0 and limits(arm)[2] is None and _prefer_brake(req, pieces[0], scale):
        braked = brake_then_go(req)
        if braked is not None:
            pieces, braking = braked, True
    blend_out = False
    if not braking:
        sd0, _, rv, ra = time_pieces(req, pieces, scale)
        # a residual below this (rad/s, rad/s²) is rounding of the projection, left as it
        # is: validation checks the start's differences against the given state anyway
        blend_out = _needs_blend(req, rv, ra)
    if blend_out:
        windowed = windowed_first(req, pieces[0], sd0)
        if windowed is not None:
            tb, rv, ra = windowed
        elif limits(arm)[2] is None and (braked := brake_then_go(req)) is not None:
            pieces, braking, blend_out = braked, True, False
        else:
            tb, scale, rv, ra = _next_blend(req, pieces[0], tries)
    if req.duration != "auto":
        fit_duration(req, pieces)
    state = req.start_state
    moving = state is not None and state.moving
    history = None
    if state is not None:
        q0, qd0, qdd0 = state.arrays()
        history = validate.start_history(q0, qd0, qdd0, rate)
    for _ in range(RETRIES + len(_BLEND_TRIES)):
        sampled = _sample_all(req, pieces)
        if isinstance(sampled, Violation):
            validate.raise_for(sampled)
        poses, joints, segment_of, marks, starts = sampled
        if blend_out:
            # the blend-out ends within the first piece (at rest at its end when it stops)
            tb = min(tb, pieces[0].count / rate)
            n_b = min(joints.shape[0], math.ceil(tb * rate) + 1)
            t = np.arange(n_b) / rate
            joints[:n_b] += _correction(rv, ra, tb, t)
            poses[:n_b] = kinematics.fk(arm.links, joints[:n_b])
        if state is not None:
            joints[0] = q0  # exactly the given state (IK of FK(q0) rounds)
        ticks, violation = validate.check(req, poses, joints, marks=marks,
                                          segment_of=segment_of, history=history)
        if violation is None:
            break
        if violation.quantity not in _ORDER or req.duration != "auto":
            # a fixed duration is the caller's: never lengthened to pass
            validate.raise_for(violation)
        log.debug("optimal: %s %.4g > %.4g at sample %d of %d (piece starts %s)",
                  violation.quantity, violation.value, violation.limit, violation.sample,
                  joints.shape[0], starts.tolist())
        # the differences of a violation span the samples sample − order .. sample
        lo = violation.sample - _ORDER[violation.quantity]
        span = np.searchsorted(starts, [max(lo, 0), violation.sample], side="right") - 1
        which = int(max(0, min(span[0], len(pieces) - 1)))
        if moving and which == 0 and not braking and limits(arm)[2] is None and (
                braked := brake_then_go(req)) is not None:
            # the blend-out window failed between samples: brake and go instead
            pieces, braking, blend_out = braked, True, False
            continue
        if moving and which == 0 and braking:
            validate.raise_for(violation)
        if moving and which == 0:
            # a moving start cannot be stretched: blend out over longer and time the path
            # with lower limits (the residual of the projection grows as ṡ₀ falls)
            log.debug("optimal: moving start fails %s %.4g > %.4g at sample %d (blend-out %.3f s,"
                      " scale %.2f): next try", violation.quantity, violation.value,
                      violation.limit, violation.sample, tb, scale)
            nxt = _next_blend(req, pieces[0], tries)
            if nxt is None:
                validate.raise_for(violation)
            tb, scale, rv, ra = nxt
            blend_out = True
            continue
        factors = stretch_factors(req, joints, history)
        edges = [*starts.tolist(), joints.shape[0] - 1]
        for p, piece in enumerate(pieces):
            if not (moving and p == 0):
                _slow(piece, float(factors[edges[p]:edges[p + 1] + 1].max()))
    else:
        validate.raise_for(violation)
    t = np.arange(joints.shape[0]) / rate
    elbow, switches = validate.elbow_branches(joints)
    approach = pieces[0].count if pieces[0].path is None else 0
    if switches:
        build.warn_switches(switches, rate)
    return Trajectory(t, poses, joints, ticks, arm.joint_names, arm.servo_ids, rate,
                      req.method if isinstance(req.method, str) else list(req.method),
                      req, elbow, switches, approach, state)


def _sample_all(req: PlanRequest, pieces: list[_Piece]):
    """Every piece sampled in turn (module doc): (poses, joints, segment_of, marks, the
    first sample of each piece), or a reach Violation."""
    arm = req.arm
    rate = req.rate_hz
    ref = None
    if req.start_state is not None:
        ref = req.start_state.arrays()[0]
    elif req.start_joints is not None:
        ref = np.asarray(req.start_joints)
    poses_l, joints_l, seg_l = [], [], []
    marks: dict[int, int] = {}
    starts = []
    offset = 0
    for piece in pieces:
        p, q, bad, s = _sample(piece, arm, rate, ref, req.branch)
        if q is None:
            pose = tuple(float(x) for x in p[bad])
            r = float(kinematics.wrist_radius(arm.links, [pose])[0])
            inner, outer = kinematics.workspace(arm.links)
            return Violation(sample=offset + bad, t=(offset + bad) / rate, pose=pose,
                             quantity="reach", value=r, limit=outer if r > outer else inner,
                             unit="m", field="waypoints")
        if piece.path is None:
            seg = np.full(s.shape[0], -1, dtype=np.int64)
        else:
            inner = np.searchsorted(piece.path.knots[1:-1], s, side="right")
            seg = piece.segment0 + np.minimum(inner, len(piece.path.segments) - 1)
            marks[offset] = piece.segment0
            marks[offset + piece.count] = piece.segment0 + len(piece.path.segments)
        lo = 0 if offset == 0 else 1
        starts.append(offset)
        poses_l.append(p[lo:])
        joints_l.append(q[lo:])
        seg_l.append(seg[lo:])
        offset += piece.count
        ref = q[-1]
        if offset + 1 > MAX_SAMPLES:
            raise TooLargeError(f"the plan needs more than {MAX_SAMPLES} samples at {rate:g} "
                                "Hz: lower rate_hz or shorten the motion", field="duration",
                                value=req.duration)
    return (np.concatenate(poses_l), np.concatenate(joints_l), np.concatenate(seg_l), marks,
            np.asarray(starts))


def _unreachable(req: PlanRequest, pose: NDArray):
    """The path leaves the workspace: the uniform planner names the first sample out of
    reach (timed by its estimate); failing that (a prepended segment from a moving start),
    the pose itself."""
    import dataclasses

    from robodcn.errors import (
        AccelerationLimitError,
        JerkLimitError,
        UnreachableError,
        VelocityLimitError,
    )
    from robodcn.planner import build

    if req.start_state is None:
        try:
            build.plan_request(dataclasses.replace(req, profile="quintic"))
        except (VelocityLimitError, AccelerationLimitError, JerkLimitError):
            if req.duration != "auto":  # a fixed duration's earlier failure is real
                raise
            # its retiming never sampled the gap (the joints race near it, a jerk limit
            # most of all): the pose out of reach is what is wrong, said below
            pass
    inner, outer = kinematics.workspace(req.arm.links)
    r = float(kinematics.wrist_radius(req.arm.links, [pose])[0])
    raise UnreachableError(f"the path leaves the workspace at {validate.fmt_pose(pose)}: the "
                           f"wrist point is {r:.4f} m from the base, the arm reaches "
                           f"{inner:.4f}..{outer:.4f} m", field="waypoints",
                           value=[float(x) for x in pose], pose=[float(x) for x in pose])


__all__ = ["DENSE", "RETRIES", "build_pieces", "fit_duration", "limits", "plan",
           "time_pieces"]
