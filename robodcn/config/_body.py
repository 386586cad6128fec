"""The points of an arm the keep-out zones test, and the first one inside a zone.

The points (:func:`body_points`): every joint centre of the chain (a yawed arm's from the
shoulder; the yaw's own centre is the base), the tool point, and :data:`LINK_FRACTIONS`
of the way along each link (a link's middle can dip into a zone both its ends clear).
The base cylinder is where the arm is mounted: the shoulder on the yaw axis and the first
link's own root lie in it by construction, so they are not tested against it (only
against the floor and the boxes).

:func:`first_intrusion` measures every sample's points against every zone at once
(:meth:`Workspace.depths`, vectorised over the samples) and names the earliest sample
inside one: the deepest point there and its zone (an :class:`Intrusion`, data; the planner
words it as a :class:`~robodcn.errors.Violation`).

A motion may *start* inside a zone — the arm fell onto the table, a hand put it there, it
was powered up so — and must then be able to leave: a point inside a zone at the first
sample is allowed to stay in it while its depth never grows (it is on its way out, or
still), and from the first sample where it grows on it counts as entering (as does a
point that left and comes back). Every other point inside a zone fails at once. Samples
taken one by one (:func:`clear_of_zones`: a plot's grid, a pose to record) have no such
start.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodcn import kinematics
from robodcn.config._specs import Arm
from robodcn.config._zones import BASE

#: Where along each link (share of its length from its joint) points are tested too.
LINK_FRACTIONS = (0.25, 0.5, 0.75)
#: A point counts as inside a zone beyond this depth (m): float rounding only, so a pose
#: computed onto a zone's surface (a tool resting on the table) is allowed.
DEPTH_SLACK = 1e-9


@dataclass(frozen=True)
class Body:
    """The tested points of an arm: ``names`` (m,) — a joint's name for its centre,
    "tool", or "<a>–<b> link" for a point along a link — the joint index of each (None
    but for joint centres), ``weights`` (k + 1, m): each point as a combination of the
    chain's joint centres and tool point (:func:`robodcn.kinematics.yawed_points`), and
    ``tested`` (z, m): whether zone j (:attr:`Workspace.zones` order) tests point i."""

    names: tuple[str, ...]
    joints: tuple[int | None, ...]
    weights: NDArray[np.float64]
    tested: NDArray[np.bool_]


@dataclass(frozen=True)
class Intrusion:
    """The first sample of a motion with a point inside a keep-out zone (data, SI).

    sample : its index; point : the point's name (:class:`Body`); joint : the joint index
    of a joint centre, else None; zone : the zone's name; depth : how far inside (m);
    position : the point's base-frame (x, y, z) (m; a planar arm's z = 0)
    """

    sample: int
    point: str
    joint: int | None
    zone: str
    depth: float
    position: tuple[float, float, float]


_BODIES: dict[int, tuple[weakref.ref, Body]] = {}


def body_of(arm: Arm) -> Body:
    """The arm's tested points (module docstring), built once per arm."""
    hit = _BODIES.get(id(arm))
    if hit is not None and hit[0]() is arm:
        return hit[1]
    chain_names = arm.joint_names[1:] if arm.yawed else arm.joint_names
    first = 1 if arm.yawed else 0
    ends = [*chain_names, "tool"]
    k = len(chain_names)
    names = list(ends)
    joints: list[int | None] = [first + i for i in range(k)] + [None]
    columns = [np.eye(k + 1)[j] for j in range(k + 1)]
    on_first_link = [j == 0 for j in range(k + 1)]   # the shoulder (a yawed arm's base)
    for i in range(k):
        for f in LINK_FRACTIONS:
            names.append(f"{ends[i]}–{ends[i + 1]} link")
            joints.append(None)
            w = np.zeros(k + 1)
            w[i], w[i + 1] = 1.0 - f, f
            columns.append(w)
            on_first_link.append(i == 0)
    weights = np.column_stack(columns)
    zones = arm.workspace.zones
    tested = np.ones((len(zones), len(names)), dtype=bool)
    if BASE in zones:
        tested[zones.index(BASE), np.array(on_first_link)] = False
    for a in (weights, tested):
        a.setflags(write=False)
    body = Body(tuple(names), tuple(joints), weights, tested)
    key = id(arm)
    _BODIES[key] = (weakref.ref(arm, lambda _, key=key: _BODIES.pop(key, None)), body)
    return body


def _plane(arm: Arm, joints: NDArray[np.float64]
           ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None]:
    """(u, v, yaw): the tested points (n, m) in the chain's plane — a yawed arm's (r, z)
    and its yaw (n, 1), a planar arm's (x, y) and None."""
    body = body_of(arm)
    if arm.yawed:
        chain = arm.chain
        assert chain is not None
        ends = kinematics.yawed_points(chain, joints)
        yaw = joints[:, :1]
    else:
        ends = kinematics.planar_points(arm.links, joints)
        yaw = None
    return ends[:, :, 0] @ body.weights, ends[:, :, 1] @ body.weights, yaw


def _xyz(u: NDArray, v: NDArray, yaw: NDArray | None) -> tuple[NDArray, NDArray, NDArray]:
    if yaw is None:
        return u, v, np.zeros_like(u)
    return u * np.cos(yaw), u * np.sin(yaw), v


def _depths(arm: Arm, joints: NDArray[np.float64]
            ) -> tuple[list[NDArray[np.float64]], tuple[NDArray, NDArray, NDArray | None]]:
    """Per zone (:attr:`Workspace.zones` order) the depth (n, m) of each tested point
    (:meth:`Workspace.depths`' formulas; −inf where the zone does not test the point), and
    the points in the plane (:func:`_plane`). The floor and the base need only the plane
    (a yawed arm's ρ = |r|); the boxes the base frame."""
    ws, body = arm.workspace, body_of(arm)
    u, v, yaw = plane = _plane(arm, joints)
    out = []
    if ws.floor is not None:
        out.append(ws.floor - v)
    if ws.base_radius is not None:
        out.append(np.minimum(ws.base_radius - np.abs(u), ws.base_height - v))
    if ws.boxes:
        x, y, z = _xyz(u, v, yaw)
        for b in ws.boxes:
            d = np.minimum(x - b.low[0], b.high[0] - x)
            np.minimum(d, np.minimum(y - b.low[1], b.high[1] - y), out=d)
            np.minimum(d, np.minimum(z - b.low[2], b.high[2] - z), out=d)
            out.append(d)
    for j, d in enumerate(out):
        if not body.tested[j].all():
            d[:, ~body.tested[j]] = -np.inf
    return out, plane


def body_points(arm: Arm, joints: NDArray[np.float64]) -> NDArray[np.float64]:
    """The tested points (n, m, 3) (base frame, m; a planar arm's z = 0) of joint samples
    (n, k), in :func:`body_of`'s order: joint centres and tool, then along each link."""
    x, y, z = _xyz(*_plane(arm, np.asarray(joints, dtype=np.float64)))
    return np.stack([x, y, z], axis=-1)


def _leaving(d: NDArray[np.float64]) -> None:
    """Exempt (−inf, in place) the samples of the points that start inside the zone while
    their depth ``d`` (n, m) has not grown since the start (module docstring)."""
    start = d[0] > DEPTH_SLACK
    if not start.any():
        return
    cols = d[:, start]
    rose = np.logical_or.accumulate(np.diff(cols, axis=0) > DEPTH_SLACK, axis=0)
    leaving = np.concatenate([np.ones((1, cols.shape[1]), dtype=bool), ~rose])
    d[:, start] = np.where(leaving, -np.inf, cols)


def first_intrusion(arm: Arm, joints: NDArray[np.float64], *,
                    motion: bool = True) -> Intrusion | None:
    """The earliest sample of the motion ``joints`` (n, k) with a point entering a keep-out
    zone of ``arm`` (the deepest such point there), or None: every point of every sample
    clear (a point inside at the first sample may leave: module docstring).
    ``motion=False``: the samples are poses on their own (a pose to record, a home pose):
    any point inside a zone counts."""
    zones = arm.workspace
    if zones.empty or len(joints) == 0:
        return None
    depths, (u, v, yaw) = _depths(arm, np.asarray(joints, dtype=np.float64))
    if max(float(d.max()) for d in depths) <= DEPTH_SLACK:
        return None
    if motion:
        for d in depths:
            _leaving(d)
        if max(float(d.max()) for d in depths) <= DEPTH_SLACK:
            return None
    depth = np.stack(depths, axis=-1)                 # (n, m, z)
    inside = depth > DEPTH_SLACK
    i = int(np.argmax(inside.any(axis=(1, 2))))
    p, z = np.unravel_index(int(np.argmax(np.where(inside[i], depth[i], -np.inf))),
                            depth[i].shape)
    x, y, zz = _xyz(u[i:i + 1, p:p + 1], v[i:i + 1, p:p + 1],
                    None if yaw is None else yaw[i:i + 1])
    body = body_of(arm)
    return Intrusion(sample=i, point=body.names[p], joint=body.joints[p],
                     zone=zones.zones[z], depth=float(depth[i, p, z]),
                     position=(float(x[0, 0]), float(y[0, 0]), float(zz[0, 0])))


def clear_of_zones(arm: Arm, joints: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Per sample of ``joints`` (n, k) whether every tested point is outside every
    keep-out zone of ``arm`` (n,) (all True on an arm without zones)."""
    joints = np.asarray(joints, dtype=np.float64)
    if arm.workspace.empty:
        return np.ones(joints.shape[0], dtype=bool)
    depths, _ = _depths(arm, joints)
    return ~np.logical_or.reduce([(d > DEPTH_SLACK).any(axis=1) for d in depths])


__all__ = [
    "DEPTH_SLACK",
    "LINK_FRACTIONS",
    "Body",
    "Intrusion",
    "body_of",
    "body_points",
    "clear_of_zones",
    "first_intrusion",
]
