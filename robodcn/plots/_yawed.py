"""An arm with a base yaw, drawn as its owner looks at it: the vertical plane of the chain
(side view: r outward from the yaw axis, z up, the tool axis's pitch along the path) and
the top view of the yaw (x, y: the tool path, and the arm's plane at the start and the end).

The chain's joints in its plane follow :func:`robodcn.kinematics.plane_fk`: with the
servo angles q and the links' elevations at zero α (``Chain.offsets`` d = diff α), the
CCW link angles are ψ = cumsum(d − q) and the joints sit at (0, h) + cumsum(L·(cos ψ, sin ψ)).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import kinematics, servo_units
from robodcn.config import Arm
from robodcn.plots._marks import approach_end, waypoint_samples
from robodcn.plots._zones import draw_zones

#: Tool-axis ticks drawn along the path in the side view.
PITCH_TICKS = 16


def plane_points(arm: Arm, q: ArrayLike) -> NDArray[np.float64]:
    """The yaw axis at the base, the shoulder, each chain joint and the tool point (k + 2, 2)
    in the arm's vertical plane (r, z), m, at joints ``q`` (k + 1,) (yaw first)."""
    chain = arm.chain
    q = np.asarray(q, dtype=np.float64)
    psi = np.cumsum(chain.offsets - q[1:])
    steps = np.asarray(chain.lengths)[:, None] * np.stack([np.cos(psi), np.sin(psi)], axis=1)
    shoulder = np.array([0.0, chain.shoulder_height])
    return np.vstack([np.zeros(2), shoulder, shoulder + np.cumsum(steps, axis=0)])


def draw_side_arm(ax, arm: Arm, q: ArrayLike, color: str, label: str | None) -> None:
    """The chain at joints ``q`` in the side view."""
    pts = plane_points(arm, q)
    ax.plot(pts[:, 0], pts[:, 1], "-o", color=color, lw=2.5, ms=4, alpha=0.7, label=label)


def _radius(poses: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.hypot(poses[:, 0], poses[:, 1])


def draw_yawed_path(ax_side, ax_top, arm: Arm, traj, wp, samples, stop, near_limits,
                    title: str | None) -> None:
    """The side view (r, z) and the top view (x, y) of ``traj``'s poses (n, 4) (x, y, z,
    pitch): planned path, approach dashed, tool-axis ticks, the arm at the start, the via
    points and the end, the waypoints, the measured path, the stop and the near-limit
    marks (the plane view's marks of a planar arm)."""
    poses = traj.poses
    r, z = _radius(poses), poses[:, 2]
    first = approach_end(traj)
    for ax, (u, v) in ((ax_side, (r, z)), (ax_top, (poses[:, 0], poses[:, 1]))):
        if first > 0:
            ax.plot(u[: first + 1], v[: first + 1], "--", color="tab:gray", lw=1.5,
                    label="approach (joint space)")
        ax.plot(u[first:], v[first:], "-", color="tab:blue", lw=1.5, label="planned path")
    at = np.linspace(first, len(traj.t) - 1, PITCH_TICKS).round().astype(int)
    length = 0.06 * max(sum(arm.links), 1e-9)
    ax_side.quiver(r[at], z[at], np.cos(poses[at, 3]), np.sin(poses[at, 3]), angles="xy",
                   scale_units="xy", scale=1.0 / length, width=0.003, color="tab:blue",
                   alpha=0.6)
    # quiver scales the view to the arrows' tails only: their tips are in view too
    ax_side.update_datalim(np.column_stack([r[at] + length * np.cos(poses[at, 3]),
                                            z[at] + length * np.sin(poses[at, 3])]))
    marks = waypoint_samples(traj, wp)
    for i, color, label in ((0, "tab:green", "arm at start"),
                            *((m, "tab:olive", None) for m in marks[1:-1]),
                            (len(traj.t) - 1, "tab:red", "arm at end")):
        draw_side_arm(ax_side, arm, traj.joints[i], color, label)
        x, y = poses[i, :2]
        ax_top.plot([0.0, x], [0.0, y], "-o", color=color, lw=2.5, ms=4, alpha=0.7)
    if wp is not None:
        for ax, (u, v) in ((ax_side, (_radius(wp), wp[:, 2])), (ax_top, (wp[:, 0], wp[:, 1]))):
            ax.plot(u, v, "kx", ms=9, mew=2, label="waypoints")
            for k, point in enumerate(zip(u, v, strict=True)):
                ax.annotate(str(k), point, textcoords="offset points", xytext=(5, 5))
    measured = None
    if samples:
        q = servo_units.ticks_to_radians(np.array([s[1] for s in samples]), arm.servos)
        measured = kinematics.fk_yawed(arm.chain, q)
        ax_side.plot(_radius(measured), measured[:, 2], ".", color="tab:orange", ms=3,
                     label="measured")
        ax_top.plot(measured[:, 0], measured[:, 1], ".", color="tab:orange", ms=3)
    if stop is not None:
        where = measured[-1] if measured is not None else \
            poses[min(len(traj.t) - 1, round(stop["t"] * traj.rate_hz))]
        ax_side.plot(np.hypot(where[0], where[1]), where[2], "X", color="crimson", ms=14,
                     label=f"stop: {stop.get('reason', 'stopped')}")
        ax_top.plot(where[0], where[1], "X", color="crimson", ms=14)
    _mark_near(ax_side, near_limits, r, z, len(traj.t))
    ax_side.set(xlabel="r [m] (out from the yaw axis)", ylabel="z [m]", aspect="equal",
                title=title or "side view: the arm's vertical plane")
    ax_top.set(xlabel="x [m]", ylabel="y [m]", aspect="equal", title="top view: the yaw")
    ax_top.plot(0.0, 0.0, "k+", ms=10)
    for ax in (ax_side, ax_top):
        ax.grid(alpha=0.3)
        ax.margins(0.1)                   # room for the waypoint labels at the edges
        ax.autoscale_view()
    ax_side.legend(fontsize="small", loc="best")


def _mark_near(ax, near_limits: Sequence[dict[str, Any]], r, z, n: int) -> None:
    for k, mark in enumerate(near_limits):
        i = min(max(int(mark["sample"]), 0), n - 1)
        ax.plot(r[i], z[i], "x", color="tab:red", ms=9,
                label="limit within 10 %" if k == 0 else None)
        ax.annotate(f"{mark['joint']} {mark['quantity'].replace('_', ' ')}", (r[i], z[i]),
                    fontsize="x-small", color="tab:red", textcoords="offset points",
                    xytext=(4, -10))


def plot_plane_workspace(ax, arm: Arm, points: NDArray[np.float64]) -> None:
    """A yawed arm's workspace in its vertical plane: the tool points (n, 3) (r, z, pitch)
    reachable inside the chain's joint limits (:func:`robodcn.workflow.check.
    workspace_samples`), the wrist annulus about the shoulder and the arm at home and at
    rest, and the keep-out zones (:func:`robodcn.plots._zones.draw_zones`; the points
    keep the arm out of them). Points at r < 0 lie over the top, behind the yaw axis
    (refused by the IK)."""
    chain = arm.chain
    ax.plot(points[:, 0], points[:, 1], ".", ms=1, color="tab:blue", alpha=0.3,
            label="tool points inside the joint limits, clear of the keep-out zones")
    reach = sum(chain.lengths)
    floor = arm.workspace.floor
    draw_zones(ax, arm, (-reach, reach, (0.0 if floor is None else floor) - 0.05))
    inner, outer = chain.workspace()
    circle = np.linspace(0, 2 * np.pi, 361)
    for radius, name in ((outer, "wrist reach"), (inner, None)):
        if radius > 0:
            ax.plot(radius * np.cos(circle), chain.shoulder_height + radius * np.sin(circle),
                    "--", color="tab:gray", lw=1, label=name)
    ax.axvline(0.0, color="k", lw=0.8)
    ax.axhline(0.0, color="tab:brown", lw=1.5, label="mounting plate")
    for pose, color, label in ((arm.home, "tab:green", "arm at home"),
                               (arm.rest, "tab:purple", "arm at rest")):
        if pose is None:
            continue
        q = kinematics.ik_yawed(chain, np.array([pose]), arm.elbow)[0]
        draw_side_arm(ax, arm, q, color, label)
    ax.set(xlabel="r [m] (out from the yaw axis)", ylabel="z [m]", aspect="equal",
           title=f"arm {arm.name!r}: reachable workspace in its vertical plane")


__all__ = ["draw_side_arm", "draw_yawed_path", "plane_points", "plot_plane_workspace"]
