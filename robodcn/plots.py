"""Pictures of a motion and of an arm's workspace (matplotlib, imported only when drawing).

:func:`plot_motion` is the one plot behind ``plan``/``sim``/``move``/``run --plot``: on the
left the plane with the arm drawn at the start, at each via point and at the end, the
waypoints marked, orientation ticks along the tool path, the approach segment dashed, the
measured path, where a stop happened and where a limit came within 10 % (the report's
``near_limits``); on the right the joint velocities and accelerations
(finite differences at the sample rate, as the planner checks them) against ±their limits.
:func:`plot_workspace` draws what ``check-config --plot`` shows. Planning never imports this
module's matplotlib: the import happens inside the functions.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import kinematics, servo_units
from robodcn.config import Arm
from robodcn.errors import InputError

#: Orientation ticks drawn along the tool path.
ORIENTATION_TICKS = 16


def require_matplotlib(option: str = "--plot") -> None:
    """InputError naming ``option`` when matplotlib is missing (check before any motion)."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise InputError(f"{option} needs matplotlib: pip install 'robodcn[plot]'",
                         field=option.lstrip("-")) from None


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def arm_points(links: Sequence[float], q: ArrayLike) -> NDArray[np.float64]:
    """Base, joints and tool point (k + 1, 2) of the arm at joints ``q`` (k,)."""
    phi = np.cumsum(np.asarray(q, dtype=np.float64))
    steps = np.asarray(links)[:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    return np.vstack([np.zeros(2), np.cumsum(steps, axis=0)])


def _draw_arm(ax, links: Sequence[float], q: ArrayLike, color: str, label: str | None) -> None:
    pts = arm_points(links, q)
    ax.plot(pts[:, 0], pts[:, 1], "-o", color=color, lw=2.5, ms=4, alpha=0.7, label=label)


def approach_end(traj) -> int:
    """Index of the first sample on the planned path (after a joint-space approach), 0 when
    the trajectory has no approach: the planner's record (``approach_samples``), else (an
    older trajectory) the first sample at the first waypoint."""
    recorded = int(getattr(traj, "approach_samples", 0) or 0)
    if recorded:
        return recorded
    request = getattr(traj, "request", None)
    if request is None or request.start_joints is None:
        return 0
    target = np.asarray(request.waypoints[0][:2])
    close = np.flatnonzero(np.hypot(*(traj.poses[:, :2] - target).T) < 1e-6)
    return int(close[0]) if close.size else 0


def waypoint_samples(traj, waypoints: NDArray[np.float64] | None) -> list[int]:
    """Sample indices nearest to each waypoint (in order along the path)."""
    if waypoints is None or len(waypoints) == 0:
        return [0, len(traj.t) - 1]
    out, start = [], approach_end(traj)
    for w in waypoints:
        d = np.hypot(*(traj.poses[start:, :2] - w[:2]).T)
        i = start + int(np.argmin(d))
        out.append(i)
        start = i
    return out


def plot_motion(path: str, arm: Arm, traj, *,
                samples: Sequence[tuple[float, Sequence[int]]] | None = None,
                waypoints: ArrayLike | None = None, stop: dict[str, Any] | None = None,
                near_limits: Sequence[dict[str, Any]] = (),
                title: str | None = None) -> None:
    """Draw ``traj`` for ``arm`` into the PNG ``path`` (module docstring).

    Parameters
    ----------
    traj : robodcn.planner.Trajectory (planned; may include an approach)
    samples : measured (elapsed s, present ticks) pairs, e.g. the CLI's progress records
    waypoints : (m, 3) poses to mark; default the trajectory request's waypoints
    stop : where a stop happened: {"t": seconds, "reason": text}; marks the last measured
        pose (or the planned one at t) and a vertical line on the right-hand plots
    near_limits : the execution report's ``near_limits`` (joint, quantity, sample, ...):
        each is marked where it began, on the path and on that joint's velocity curve
    """
    plt = _pyplot()
    if waypoints is None and getattr(traj, "request", None) is not None:
        waypoints = np.asarray(traj.request.waypoints)
    wp = None if waypoints is None else np.asarray(waypoints, dtype=np.float64).reshape(-1, 3)
    fig = plt.figure(figsize=(13, 6))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.1, 1))
    ax = fig.add_subplot(grid[:, 0])
    ax_v = fig.add_subplot(grid[0, 1])
    ax_a = fig.add_subplot(grid[1, 1], sharex=ax_v)

    first = approach_end(traj)
    if first > 0:
        ax.plot(traj.poses[: first + 1, 0], traj.poses[: first + 1, 1], "--", color="tab:gray",
                lw=1.5, label="approach (joint space)")
    ax.plot(traj.poses[first:, 0], traj.poses[first:, 1], "-", color="tab:blue", lw=1.5,
            label="planned path")
    ticks_at = np.linspace(first, len(traj.t) - 1, ORIENTATION_TICKS).round().astype(int)
    length = 0.06 * max(sum(arm.links), 1e-9)
    p = traj.poses[ticks_at]
    ax.quiver(p[:, 0], p[:, 1], np.cos(p[:, 2]), np.sin(p[:, 2]), angles="xy",
              scale_units="xy", scale=1.0 / length, width=0.003, color="tab:blue", alpha=0.6)
    marks = waypoint_samples(traj, wp)
    _draw_arm(ax, arm.links, traj.joints[0], "tab:green", "arm at start")
    for i in marks[1:-1]:
        _draw_arm(ax, arm.links, traj.joints[i], "tab:olive", None)
    _draw_arm(ax, arm.links, traj.joints[-1], "tab:red", "arm at end")
    if wp is not None:
        ax.plot(wp[:, 0], wp[:, 1], "kx", ms=9, mew=2, label="waypoints")
        for k, w in enumerate(wp):
            ax.annotate(str(k), w[:2], textcoords="offset points", xytext=(5, 5))
    if samples:
        q_meas = servo_units.ticks_to_radians(np.array([s[1] for s in samples]), arm.servos)
        p_meas = kinematics.fk(arm.links, q_meas)
        ax.plot(p_meas[:, 0], p_meas[:, 1], ".", color="tab:orange", ms=3, label="measured")
    if stop is not None:
        if samples:
            where = p_meas[-1]
        else:
            where = traj.poses[min(len(traj.t) - 1, round(stop["t"] * traj.rate_hz))]
        ax.plot(where[0], where[1], "X", color="crimson", ms=14,
                label=f"stop: {stop.get('reason', 'stopped')}")
    names = [spec.name for spec in arm.joints]
    for k, mark in enumerate(near_limits):
        i = min(max(int(mark["sample"]), 0), len(traj.t) - 1)
        ax.plot(traj.poses[i, 0], traj.poses[i, 1], "x", color="tab:red", ms=9,
                label="limit within 10 %" if k == 0 else None)
        ax.annotate(f"{mark['joint']} {mark['quantity'].replace('_', ' ')}",
                    traj.poses[i, :2], fontsize="x-small", color="tab:red",
                    textcoords="offset points", xytext=(4, -10))
    ax.set(xlabel="x [m]", ylabel="y [m]", title=title or "tool path", aspect="equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small", loc="best")

    rate = traj.rate_hz
    q = traj.joints
    padded = np.concatenate([q[:1], q, q[-1:]])
    vel = np.diff(padded, axis=0)[: len(q)] * rate
    acc = (padded[2:] - 2.0 * padded[1:-1] + padded[:-2]) * rate * rate
    for j, spec in enumerate(arm.joints):
        line, = ax_v.plot(traj.t, np.degrees(vel[:, j]), label=spec.name)
        c = line.get_color()
        ax_v.axhline(math.degrees(spec.max_velocity), color=c, ls=":", lw=1)
        ax_v.axhline(-math.degrees(spec.max_velocity), color=c, ls=":", lw=1)
        ax_a.plot(traj.t, np.degrees(acc[:, j]), color=c, label=spec.name)
        ax_a.axhline(math.degrees(spec.max_acceleration), color=c, ls=":", lw=1)
        ax_a.axhline(-math.degrees(spec.max_acceleration), color=c, ls=":", lw=1)
    for mark in near_limits:
        i = min(max(int(mark["sample"]), 0), len(traj.t) - 1)
        j = names.index(mark["joint"]) if mark["joint"] in names else None
        if j is not None:
            ax_v.plot(traj.t[i], np.degrees(vel[i, j]), "x", color="tab:red", ms=9)
    for axis in (ax_v, ax_a):
        if first > 0:
            axis.axvspan(0, traj.t[first], color="tab:gray", alpha=0.15, lw=0)
        if stop is not None:
            axis.axvline(stop["t"], color="crimson", lw=1.5)
        axis.grid(alpha=0.3)
    ax_v.set(ylabel="joint velocity [°/s]", title="velocity and acceleration (dotted: limits)")
    ax_a.set(xlabel="t [s]", ylabel="joint acceleration [°/s²]")
    ax_v.legend(fontsize="small", loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_workspace(path: str, arm: Arm, points: NDArray[np.float64]) -> None:
    """The tool points reachable inside the joint limits (``points`` (n, 3), e.g.
    :func:`robodcn.workflow.check.workspace_samples`), the wrist annulus and the arm at home."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.plot(points[:, 0], points[:, 1], ".", ms=1, color="tab:blue", alpha=0.3,
            label="tool points inside the joint limits")
    inner, outer = kinematics.workspace(arm.links)
    circle = np.linspace(0, 2 * np.pi, 361)
    for radius, name in ((outer, "wrist reach"), (inner, None)):
        if radius > 0:
            ax.plot(radius * np.cos(circle), radius * np.sin(circle), "--", color="tab:gray",
                    lw=1, label=name)
    home = kinematics.ik(arm.links, [arm.home], arm.elbow)[0]
    _draw_arm(ax, arm.links, home, "tab:green", "arm at home")
    ax.plot(arm.home[0], arm.home[1], "kx", ms=9, mew=2)
    ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal",
           title=f"arm {arm.name!r}: reachable workspace")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small", loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
