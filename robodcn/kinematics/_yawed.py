"""A base yaw turning a planar chain in a vertical plane (the OpenMANIPULATOR-X layout).

Frames and conventions (shared/omx.md): base frame origin on the yaw axis at the mounting
plate, z up, x forward at yaw 0. Joint 0 (yaw) turns counter-clockwise seen from above.
The chain joints 1..k turn about the plane's normal with ROBOTIS's sign: a positive angle
turns the arm forward and DOWN, i.e. clockwise in the arm's (r, z) plane (r outward, z up).
Link i is the vector v_i = (a_i, b_i) from its joint to the next at zero, of length L_i at
the angle α_i = atan2(b_i, a_i) above the horizontal; the first joint (shoulder) sits on
the yaw axis at the height h.

Forward kinematics::

    φ_i = q_1 + … + q_i,   ψ_i = α_i − φ_i                  (absolute angle of link i)
    r = Σ L_i cos ψ_i,     z = h + Σ L_i sin ψ_i,   pitch = ψ_k
    (x, y) = r·(cos yaw, sin yaw)

Pitch is the elevation of the tool axis (the last link) above the horizontal, positive up.

Inverse kinematics reduces the chain to the planar CCW chain of :mod:`._planar` with the
lengths L_i and the angles q̃ = d − q, d = (α_1, α_2 − α_1, …, α_k − α_{k−1}) (so Σ q̃ = ψ):
yaw = atan2(y, x), r = hypot(x, y), then the planar IK of (r, z − h, pitch), both branches.
Branch "up" is q̃_2 ≤ 0 (the elbow above the shoulder–wrist line; q_2 ≥ α_2 − α_1,
−79.38° on the OM-X, whose usual poses are all on it), "down" the other one. The "over the
top" solution (yaw + π, r < 0) is never used: a pose on the yaw axis (yaw undefined) or one
whose tool axis points back over the base (|pitch| > 90°) is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn.errors import InputError, UnreachableError
from robodcn.kinematics import _forward, _planar
from robodcn.kinematics._planar import ELBOWS, _joints, wrap

#: Distance (m) from the yaw axis under which a pose counts as on it: its yaw is undefined.
AXIS_TOLERANCE = 1e-6
#: Largest |pitch| (rad) of a pose: beyond ±90° the tool axis points back over the base.
MAX_PITCH = 0.5 * math.pi + 1e-9


@dataclass(frozen=True)
class Chain:
    """A base yaw and a planar chain of 2 or 3 links in its vertical plane.

    Parameters
    ----------
    links : (k, 2) link vectors (r, z) in metres from each joint to the next at zero.
    shoulder_height : height (m) of the first chain joint above the base, on the yaw axis.

    A 3-link chain reaches full poses (x, y, z, pitch); a 2-link one positions (pitch free:
    its IK ignores pitch and its FK reports the last link's elevation).
    """

    links: tuple[tuple[float, float], ...]
    shoulder_height: float

    def __post_init__(self) -> None:
        links = tuple((float(a), float(b)) for a, b in self.links)
        if len(links) not in (2, 3) or not all(
                np.isfinite([a, b]).all() and math.hypot(a, b) > 0.0 for a, b in links):
            raise InputError(f"chain links must be 2 or 3 non-zero (r, z) vectors, got "
                             f"{links!r}", field="links", value=links)
        if not math.isfinite(self.shoulder_height):
            raise InputError(f"shoulder_height must be finite, got {self.shoulder_height!r}",
                             field="shoulder_height", value=self.shoulder_height)
        object.__setattr__(self, "links", links)
        object.__setattr__(self, "shoulder_height", float(self.shoulder_height))

    @property
    def dof(self) -> int:
        """Joints of the arm: the yaw and the chain's."""
        return len(self.links) + 1

    @property
    def lengths(self) -> tuple[float, ...]:
        """Link lengths L_i = |v_i| (m)."""
        return tuple(math.hypot(a, b) for a, b in self.links)

    @property
    def angles(self) -> NDArray[np.float64]:
        """Link elevations at zero α_i = atan2(b_i, a_i) (k,), radians."""
        v = np.asarray(self.links)
        return np.arctan2(v[:, 1], v[:, 0])

    @property
    def offsets(self) -> NDArray[np.float64]:
        """d = (α_1, α_2 − α_1, …): the planar CCW angles are q̃ = d − q (k,)."""
        return np.diff(self.angles, prepend=0.0)

    def workspace(self) -> tuple[float, float]:
        """The annulus (|L1 − L2|, L1 + L2) about the shoulder the wrist point can reach."""
        return _planar.workspace(self.lengths)


def _poses(poses: ArrayLike) -> NDArray[np.float64]:
    poses = _checks.finite("poses", poses)
    if poses.ndim != 2 or poses.shape[1] != 4:
        raise InputError(f"poses must have shape (n, 4) (x, y, z, pitch), got {poses.shape}",
                         field="poses", value=poses)
    return poses


def to_plane(poses: ArrayLike) -> NDArray[np.float64]:
    """Base-frame poses (n, 4) (x, y, z, pitch) → the arm's plane (n, 4) (yaw, r, z, pitch).

    yaw = atan2(y, x) in [−π, π], r = hypot(x, y) ≥ 0; z and pitch unchanged. Unwrap the
    yaw along a path (:func:`unwrap_yaw`) before interpolating it.
    """
    p = _poses(poses)
    return np.stack([np.arctan2(p[:, 1], p[:, 0]), np.hypot(p[:, 0], p[:, 1]), p[:, 2], p[:, 3]],
                    axis=1)


def from_plane(plane_poses: ArrayLike) -> NDArray[np.float64]:
    """The arm's plane (n, 4) (yaw, r, z, pitch) → base frame (n, 4) (x, y, z, pitch):
    (x, y) = r·(cos yaw, sin yaw)."""
    p = _checks.finite("plane_poses", plane_poses)
    if p.ndim != 2 or p.shape[1] != 4:
        raise InputError(f"plane poses must have shape (n, 4) (yaw, r, z, pitch), got "
                         f"{p.shape}", field="plane_poses", value=p)
    return np.stack([p[:, 1] * np.cos(p[:, 0]), p[:, 1] * np.sin(p[:, 0]), p[:, 2], p[:, 3]],
                    axis=1)


def unwrap_yaw(yaw: ArrayLike, reference: float | None = None) -> NDArray[np.float64]:
    """Yaw angles (n,) along a path made continuous (every step wrapped into [−π, π]),
    shifted by a multiple of 2π so the first is nearest ``reference`` (as given when None)."""
    yaw = _checks.samples("yaw", yaw)
    if yaw.shape[0] == 0:
        return yaw.copy()
    out = _planar._unwrap(yaw)
    if reference is not None:
        out += 2.0 * np.pi * np.round((float(reference) - out[0]) / (2.0 * np.pi))
    return out


def plane_fk(chain: Chain, q: ArrayLike) -> NDArray[np.float64]:
    """The chain's tool point and pitch in its plane (n, 3) (r, z, pitch) for chain joints
    q (n, k): r = Σ L_i cos ψ_i, z = h + Σ L_i sin ψ_i, pitch = ψ_k wrapped into [−π, π],
    ψ = α − cumsum(q)."""
    q = _joints(q, len(chain.links))
    out = _forward.fk(chain.lengths, chain.offsets - q)
    out[:, 1] += chain.shoulder_height
    out[:, 2] = wrap(out[:, 2])
    return out


def fk_yawed(chain: Chain, q: ArrayLike) -> NDArray[np.float64]:
    """Forward kinematics (n, 4) (x, y, z, pitch) of joints q (n, k+1) (yaw first):
    the chain in its plane (:func:`plane_fk`), then (x, y) = r·(cos yaw, sin yaw)."""
    q = _joints(q, chain.dof)
    rzp = plane_fk(chain, q[:, 1:])
    return np.stack([rzp[:, 0] * np.cos(q[:, 0]), rzp[:, 0] * np.sin(q[:, 0]), rzp[:, 1],
                     rzp[:, 2]], axis=1)


def _plane_targets(chain: Chain, plane_poses: NDArray[np.float64]) -> NDArray[np.float64]:
    """(r, z − h, pitch) rows (n, 3): the planar chain's targets about the shoulder."""
    return np.stack([plane_poses[:, 1], plane_poses[:, 2] - chain.shoulder_height,
                     plane_poses[:, 3]], axis=1)


def wrist_radius_yawed(chain: Chain, poses: ArrayLike) -> NDArray[np.float64]:
    """Distance (n,) of each pose's wrist point from the shoulder, in the arm's plane."""
    return _planar.wrist_radius(chain.lengths, _plane_targets(chain, to_plane(poses)))


def reachable_yawed(chain: Chain, poses: ArrayLike) -> NDArray[np.bool_]:
    """Whether each pose (n, 4) has an IK solution off the yaw axis and not over the top:
    r ≥ AXIS_TOLERANCE, |pitch| ≤ 90° (3-link chains) and the wrist point in the annulus."""
    plane = to_plane(poses)
    ok = _planar.reachable(chain.lengths, _plane_targets(chain, plane))
    ok &= plane[:, 1] >= AXIS_TOLERANCE
    if len(chain.links) == 3:
        ok &= np.abs(wrap(plane[:, 3])) <= MAX_PITCH
    return ok


def why_unreachable(chain: Chain, pose: ArrayLike) -> str | None:
    """Why one pose (x, y, z, pitch) cannot be reached, as a phrase ("is on the yaw axis
    …", "points the tool back over the base …", "is out of reach: …"); None if it can."""
    pose = _poses(np.reshape(_checks.finite("pose", pose), (1, 4)))
    if reachable_yawed(chain, pose)[0]:
        return None
    x, y, _, pitch = (float(v) for v in pose[0])
    r = math.hypot(x, y)
    if r < AXIS_TOLERANCE:
        return (f"is on the yaw axis (r = {r:.2g} m from it): its yaw is undefined; move it "
                f"at least {AXIS_TOLERANCE:g} m off the axis")
    if len(chain.links) == 3 and abs(float(wrap(pitch))) > MAX_PITCH:
        return ("points the tool back over the base (|pitch| > 90°): the arm does not reach "
                "over the top; turn the yaw instead")
    inner, outer = chain.workspace()
    w = float(wrist_radius_yawed(chain, pose)[0])
    return (f"is out of reach: the wrist point is {w:.4f} m from the shoulder, the arm "
            f"reaches {inner:.4f}..{outer:.4f} m")


def unreachable_error(chain: Chain, poses: ArrayLike, i: int) -> UnreachableError:
    """The error (not raised) saying why pose ``i`` of ``poses`` (n, 4) cannot be reached."""
    poses = _poses(poses)
    x, y, z, pitch = (float(v) for v in poses[i])
    where = (f"sample {i} (x={x:.4f} m, y={y:.4f} m, z={z:.4f} m, "
             f"pitch={math.degrees(pitch):.1f}°)")
    why = why_unreachable(chain, poses[i]) or "cannot be reached"
    return UnreachableError(f"{where} {why}", field="poses", value=poses[i].tolist(),
                            sample=i, pose=poses[i].tolist())


def _raise_first(chain: Chain, poses: NDArray[np.float64], ok: NDArray[np.bool_]) -> None:
    if not ok.all():
        raise unreachable_error(chain, poses, int(np.argmin(ok)))


def ik_yawed_branches(chain: Chain, poses: ArrayLike
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Both IK solutions (yaw first) of every pose (n, 4).

    Returns
    -------
    up, down : (n, k+1) joint angles in [−π, π] of the elbow-up and elbow-down branches
        (module notes); NaN rows where the pose cannot be reached.
    ok : (n,) bool, :func:`reachable_yawed`.
    """
    poses = _poses(poses)
    plane = to_plane(poses)
    ok = reachable_yawed(chain, poses)
    up_t, down_t, _ = _planar.ik_branches(chain.lengths, _plane_targets(chain, plane))
    d = chain.offsets
    up = np.hstack([plane[:, :1], wrap(d - up_t)])
    down = np.hstack([plane[:, :1], wrap(d - down_t)])
    up[~ok] = np.nan
    down[~ok] = np.nan
    return up, down, ok


def ik_yawed(chain: Chain, poses: ArrayLike, elbow: str = "up") -> NDArray[np.float64]:
    """One IK branch (n, k+1) of poses (n, 4) (x, y, z, pitch), yaw first, angles in [−π, π].

    yaw = atan2(y, x); the chain from the planar IK of (r, z − h, pitch) (module notes).

    Raises
    ------
    UnreachableError
        At the first pose on the yaw axis, over the top or out of reach (named, with why).
    """
    _checks.one_of("elbow", elbow, ELBOWS)
    up, down, ok = ik_yawed_branches(chain, poses)
    _raise_first(chain, _poses(poses), ok)
    return up if elbow == "up" else down


def try_ik_yawed_path(chain: Chain, poses: ArrayLike, *, reference: ArrayLike | None = None,
                      elbow: str = "up", limits: ArrayLike | None = None
                      ) -> tuple[NDArray[np.float64] | None, int | None]:
    """Branch-continuous, unwrapped IK along a sampled path of poses (n, 4), as data:
    (joints (n, k+1), None), or (None, index of the first pose that cannot be reached).

    The chain joints follow :func:`robodcn.kinematics.try_ik_path` on the planar chain
    (reference and limits mapped through q̃ = d − q), the yaw is atan2(y, x) unwrapped
    along the path; each joint starts nearest ``reference`` ((k+1,), the present joints),
    or without one nearest the middle of ``limits`` ((k+1, 2) rows (min, max); 0 if None).
    """
    poses = _poses(poses)
    _checks.one_of("elbow", elbow, ELBOWS)
    k = len(chain.links)
    if reference is not None:
        reference = _checks.finite("reference", reference)
        if reference.shape != (k + 1,):
            raise InputError(f"reference joints must have shape ({k + 1},), got "
                             f"{reference.shape}", field="start_joints", value=reference)
    if limits is not None:
        limits = _checks.finite("limits", limits)
        if limits.shape != (k + 1, 2):
            raise InputError(f"limits must have shape ({k + 1}, 2), got {limits.shape}",
                             field="limits", value=limits)
    ok = reachable_yawed(chain, poses)
    if not ok.all():
        return None, int(np.argmin(ok))
    if poses.shape[0] == 0:
        return np.empty((0, k + 1)), None
    plane = to_plane(poses)
    d = chain.offsets
    chain_q, bad = _planar.ik_path_unchecked(
        _planar._links(chain.lengths), _plane_targets(chain, plane),
        None if reference is None else d - reference[1:], elbow,
        None if limits is None else d[:, None] - limits[1:, ::-1])
    if chain_q is None:  # pragma: no cover - reachable_yawed checked the same annulus
        return None, bad
    if reference is not None:
        yaw_target = float(reference[0])
    else:
        yaw_target = 0.0 if limits is None else float(limits[0].mean())
    yaw = unwrap_yaw(plane[:, 0], yaw_target)
    return np.hstack([yaw[:, None], d - chain_q]), None


def ik_yawed_path(chain: Chain, poses: ArrayLike, *, reference: ArrayLike | None = None,
                  elbow: str = "up", limits: ArrayLike | None = None) -> NDArray[np.float64]:
    """:func:`try_ik_yawed_path`, raising UnreachableError at the first pose it cannot reach
    (sample index, pose and why named)."""
    q, bad = try_ik_yawed_path(chain, poses, reference=reference, elbow=elbow, limits=limits)
    if q is None:
        raise unreachable_error(chain, poses, int(bad))
    return q

