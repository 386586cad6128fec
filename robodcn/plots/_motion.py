"""Pictures of a motion and of an arm's workspace (matplotlib, imported only when drawing).

:func:`plot_motion` is the one plot behind ``plan``/``sim``/``move``/``run --plot``: on the
left the plane with the arm drawn at the start, at each via point and at the end, the
waypoints marked, orientation ticks along the tool path, the approach segment dashed, the
measured path, where a stop happened and where a limit came within 10 % (the report's
``near_limits``); on the right the joint velocities and accelerations
(finite differences at the sample rate, as the planner checks them) against ±their limits,
marked where the plan came within 10 % of them; a plan with a tool limit (``tool_speed``,
``tool_acceleration``) gets a panel of the tool point's speed against its limit, the span where
it binds shaded (:mod:`robodcn.planner.tool_peak`). Given an execution's trace
(:class:`robodcn.stream.ExecutionTrace`) two more panels on the same time axis show each
joint's measured |tracking error| (degrees, symlog: linear below one encoder tick) against
the tracking limit and its |current| (A) with the plan's predicted current, the current limit
and the collision stop; a near-limit mark goes on the panel of its quantity, and a table
under the path lists the per-joint peaks against their limits.
An arm with a base yaw gets its vertical plane (r, z: the side view, the tool axis's pitch
along the path) and a top view of the yaw (x, y) instead of the plane
(:mod:`robodcn.plots._yawed`). Planning never imports matplotlib: the import happens inside
the functions.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import kinematics, servo_units
from robodcn._files import replace_file
from robodcn.config import Arm
from robodcn.errors import InputError
from robodcn.plots._marks import approach_end, waypoint_samples

#: A limit counts as approached at this share of it (robodcn.stream.report.NEAR_SHARE; not
#: imported from there so that ``plan --plot`` does not load the streaming stack).
NEAR_SHARE = 0.9

#: Fewer feedback reads than this are drawn with a dot each.
FEW_READS = 30
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


def save_figure(fig: Any, plt: Any, path: str) -> None:
    """Save ``fig`` to ``path`` whole or not at all (:func:`robodcn._files.replace_file`), in
    the format the suffix names (matplotlib's ``savefig.format`` without one), and close it."""
    import os

    import matplotlib

    fmt = os.path.splitext(path)[1].lstrip(".").lower() or matplotlib.rcParams["savefig.format"]
    try:
        replace_file(path, lambda out: fig.savefig(out, format=fmt, dpi=110), field="--plot")
    finally:
        plt.close(fig)


def arm_points(links: Sequence[float], q: ArrayLike) -> NDArray[np.float64]:
    """Base, joints and tool point (k + 1, 2) of the arm at joints ``q`` (k,)."""
    phi = np.cumsum(np.asarray(q, dtype=np.float64))
    steps = np.asarray(links)[:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    return np.vstack([np.zeros(2), np.cumsum(steps, axis=0)])


def _draw_arm(ax, links: Sequence[float], q: ArrayLike, color: str, label: str | None) -> None:
    pts = arm_points(links, q)
    ax.plot(pts[:, 0], pts[:, 1], "-o", color=color, lw=2.5, ms=4, alpha=0.7, label=label)


def plot_motion(path: str, arm: Arm, traj, *,
                samples: Sequence[tuple[float, Sequence[int]]] | None = None,
                waypoints: ArrayLike | None = None, stop: dict[str, Any] | None = None,
                near_limits: Sequence[dict[str, Any]] = (), trace=None,
                title: str | None = None) -> None:
    """Draw ``traj`` for ``arm`` into the PNG ``path`` (module docstring).

    Parameters
    ----------
    traj : robodcn.planner.Trajectory (planned; may include an approach)
    samples : measured (elapsed s, present ticks) pairs, e.g. the CLI's progress records
    waypoints : (m, 3) poses to mark ((m, 4) x, y, z, pitch on a yawed arm); default the
        trajectory request's waypoints
    stop : where a stop happened: {"t": seconds, "reason": text}; marks the last measured
        pose (or the planned one at t) and a vertical line on the right-hand plots
    near_limits : the execution report's ``near_limits`` (joint, quantity, sample, ...):
        each is marked where it began, on the path and on the panel of its quantity
    trace : the execution report's :class:`~robodcn.stream.trace.ExecutionTrace`: adds the
        tracking error and (with currents) the current panels against their limits
    """
    plt = _pyplot()
    if waypoints is None and getattr(traj, "request", None) is not None:
        waypoints = np.asarray(traj.request.waypoints)
    width = len(arm.pose_keys)
    wp = None if waypoints is None else np.asarray(waypoints, dtype=np.float64).reshape(-1,
                                                                                       width)
    request = getattr(traj, "request", None)
    tool = 1 if request is not None and request.tool_limited else 0
    rows = 2 + tool + (0 if trace is None else (1 if trace.current_a is None else 2))
    fig = plt.figure(figsize=(13, 6) if rows == 2 else (14, 2.5 * rows + 0.8))
    grid = fig.add_gridspec(rows, 2, width_ratios=(1.1, 1))
    # The path keeps the height of the velocity and acceleration panels; below it, the
    # per-joint peaks against their limits.
    tall = 2 if trace is not None else rows  # without a trace's table, the whole height
    if arm.yawed:
        from robodcn.plots._yawed import draw_yawed_path

        # apart enough that the top view's y label stays clear of the side view
        left = grid[:tall, 0].subgridspec(1, 2, width_ratios=(1.4, 1), wspace=0.4)
        draw_yawed_path(fig.add_subplot(left[0, 0]), fig.add_subplot(left[0, 1]), arm, traj,
                        wp, samples, stop, near_limits, title)
    else:
        _draw_path(fig.add_subplot(grid[:tall, 0]), arm, traj, wp, samples, stop, near_limits,
                   title)
    ax_v = fig.add_subplot(grid[0, 1])
    right = [ax_v] + [fig.add_subplot(grid[r, 1], sharex=ax_v) for r in range(1, rows)]
    panels: dict[str, Any] = {}
    if tool:
        panels["tool_speed"] = right[2]
    if trace is not None:
        panels["tracking_error"] = right[2 + tool]
        if trace.current_a is not None:
            panels["current"] = panels["collision_current"] = right[3 + tool]

    first = approach_end(traj)
    names = [spec.name for spec in arm.joints]
    colors = _draw_kinematics(right[0], right[1], arm, traj)
    if tool:
        _draw_tool_speed(panels["tool_speed"], traj)
    if trace is not None:
        _draw_tracking(panels["tracking_error"], trace, colors, arm)
        if trace.current_a is not None:
            _draw_current(panels["current"], trace, traj, colors)
        _draw_summary(fig.add_subplot(grid[2:, 0]), arm, traj, trace, near_limits)
    _mark_near(panels, near_limits, names, traj, trace)
    for axis in right:
        if first > 0:
            axis.axvspan(0, traj.t[first], color="tab:gray", alpha=0.15, lw=0)
        if stop is not None:
            axis.axvline(stop["t"], color="crimson", lw=1.5)
        axis.grid(alpha=0.3)
        if axis is not right[-1]:
            axis.tick_params(labelbottom=False)
    right[-1].set_xlabel("t [s]")
    fig.tight_layout()
    save_figure(fig, plt, path)


def _draw_path(ax, arm: Arm, traj, wp, samples, stop, near_limits, title) -> None:
    """The plane: planned path, orientation ticks, arm poses, waypoints, measured, stop."""
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
    # quiver scales the view to the arrows' tails only: their tips are in view too
    ax.update_datalim(np.column_stack([p[:, 0] + length * np.cos(p[:, 2]),
                                       p[:, 1] + length * np.sin(p[:, 2])]))
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
    for k, mark in enumerate(near_limits):
        i = min(max(int(mark["sample"]), 0), len(traj.t) - 1)
        ax.plot(traj.poses[i, 0], traj.poses[i, 1], "x", color="tab:red", ms=9,
                label="limit within 10 %" if k == 0 else None)
        ax.annotate(f"{mark['joint']} {mark['quantity'].replace('_', ' ')}",
                    traj.poses[i, :2], fontsize="x-small", color="tab:red",
                    textcoords="offset points", xytext=(4, -10))
    ax.set(xlabel="x [m]", ylabel="y [m]", title=title or "tool path", aspect="equal")
    ax.grid(alpha=0.3)
    ax.margins(0.06)                      # room for the waypoint labels at the edges
    ax.autoscale_view()
    ax.legend(fontsize="small", loc="best")


def joint_rates(traj) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Joint velocity and acceleration (n, k) by finite differences at the sample rate, as
    the planner checks them (rad/s, rad/s²)."""
    rate = traj.rate_hz
    q = traj.joints
    padded = np.concatenate([q[:1], q, q[-1:]])
    vel = np.diff(padded, axis=0)[: len(q)] * rate
    acc = (padded[2:] - 2.0 * padded[1:-1] + padded[:-2]) * rate * rate
    return vel, acc


def _near_plan(values: NDArray[np.float64], limit: float) -> int | None:
    """First sample where |values| came within 10 % of ``limit`` (None: never)."""
    near = np.flatnonzero(np.abs(values) >= NEAR_SHARE * limit)
    return int(near[0]) if near.size else None


def _draw_kinematics(ax_v, ax_a, arm: Arm, traj) -> list[str]:
    """Planned joint velocity and acceleration against ±their limits, marked where they
    came within 10 % of them; returns the joint colours."""
    vel, acc = joint_rates(traj)
    colors = []
    for j, spec in enumerate(arm.joints):
        line, = ax_v.plot(traj.t, np.degrees(vel[:, j]), label=spec.name)
        c = line.get_color()
        colors.append(c)
        ax_a.plot(traj.t, np.degrees(acc[:, j]), color=c, label=spec.name)
        for axis, values, limit in ((ax_v, vel[:, j], spec.max_velocity),
                                    (ax_a, acc[:, j], spec.max_acceleration)):
            axis.axhline(math.degrees(limit), color=c, ls=":", lw=1)
            axis.axhline(-math.degrees(limit), color=c, ls=":", lw=1)
            i = _near_plan(values, limit)
            if i is not None:
                axis.plot(traj.t[i], math.degrees(values[i]), "x", color="tab:red", ms=8,
                          mew=2)
    ax_v.set(ylabel="velocity [°/s]",
             title="planned joint motion (dotted: limits, ✕: within 10 % of a limit)")
    ax_a.set(ylabel="acceleration [°/s²]")
    ax_v.legend(fontsize="small", loc="upper right", title="joint", title_fontsize="small")
    return colors


def _draw_tool_speed(ax, traj) -> None:
    """The tool point's planned speed (m/s) against the request's ``tool_speed`` (and its
    acceleration along the path against ``tool_acceleration`` on a second axis), the span
    where the speed limit binds shaded."""
    from robodcn.planner.tool_peak import tool_peak, tool_speeds

    speed, accel = tool_speeds(traj)
    peak = tool_peak(traj)
    ax.plot(traj.t, speed, color="tab:purple", label="tool speed")
    if peak.speed_limit is not None:
        ax.axhline(peak.speed_limit, color="tab:purple", ls=":", lw=1.2)
        ax.annotate(f"tool_speed {peak.speed_limit:g} m/s", (0.0, peak.speed_limit),
                    xycoords=("axes fraction", "data"), xytext=(4, -11),
                    textcoords="offset points", fontsize="small")
        if peak.binds_from is not None:
            ax.axvspan(peak.binds_from, peak.binds_to, color="tab:purple", alpha=0.08, lw=0,
                       label="speed limit binds")
    ax.plot(peak.t, peak.peak_speed, "v", color="tab:purple", ms=7,
            label=f"peak {peak.peak_speed:.4g} m/s")
    ax.set_ylim(0.0, 1.15 * max(peak.peak_speed, peak.speed_limit or 0.0, 1e-9))
    ax.set(ylabel="tool speed [m/s]", title="planned tool point speed (dotted: limit)")
    if peak.acceleration_limit is not None:
        twin = ax.twinx()
        twin.plot(traj.t, accel, color="tab:brown", lw=0.8, alpha=0.6)
        twin.axhline(peak.acceleration_limit, color="tab:brown", ls=":", lw=1)
        twin.set_ylim(0.0, 1.15 * max(float(accel.max()), peak.acceleration_limit))
        twin.set_ylabel("along-path accel. [m/s²]", color="tab:brown")
    ax.legend(fontsize="small", loc="upper right")


def _draw_tracking(ax, trace, colors: Sequence[str], arm: Arm) -> None:
    """|tracking error| per joint at each read (°) against the tracking limit."""
    error = np.degrees(np.abs(trace.tracking_error_rad))
    for j, name in enumerate(trace.joint_names):
        ax.plot(trace.t, error[:, j], color=colors[j], lw=1.2, label=name,
                marker=_few_reads(trace))
    top = float(error.max()) if error.size else 0.0
    if trace.tracking_limit_rad is not None:
        limit = math.degrees(trace.tracking_limit_rad)
        ax.axhline(limit, color="k", ls=":", lw=1.2)
        ax.annotate(f"tracking limit {limit:g}°", (0.0, limit), xycoords=("axes fraction",
                    "data"), xytext=(4, -11), textcoords="offset points", fontsize="small")
        top = max(top, limit)
    # Log above one encoder tick (the error's resolution), linear below it: an error of a
    # tick or two and one near the limit both read.
    tick = min(360.0 / s.ticks_per_turn for s in arm.servos)
    ax.set_yscale("symlog", linthresh=tick, linscale=0.6)
    decades = 10.0 ** np.arange(math.ceil(math.log10(tick)), math.log10(max(top, tick)) + 1)
    ax.set_yticks([0.0, *decades], labels=["0", *(f"{d:g}" for d in decades)])
    ax.yaxis.set_minor_locator(_ticker().NullLocator())
    ax.set_ylim(0.0, 1.6 * max(top, tick))
    ax.set(ylabel="|tracking error| [°]",
           title="measured tracking error (log scale above one encoder tick)")


def _few_reads(trace) -> str | None:
    """A dot on every read when they are few (``--feedback-every 0``: only the last one),
    so a lone read still shows."""
    return "o" if len(trace) < FEW_READS else None


def _ticker():
    import matplotlib.ticker

    return matplotlib.ticker


def _draw_current(ax, trace, traj, colors: Sequence[str]) -> None:
    """|current| per joint at each read (A), the plan's prediction, the current limit and
    the collision-stop threshold."""
    from matplotlib.lines import Line2D

    current = np.abs(trace.current_a)
    predicted = trace.predicted_current_a
    if predicted is not None and len(predicted) != len(traj.t):
        predicted = None   # predicted for another sampling of the motion
    limits = trace.current_limit_a
    same_limit = limits is not None and len(set(limits)) == 1
    for j, name in enumerate(trace.joint_names):
        ax.plot(trace.t, current[:, j], color=colors[j], lw=1.2, label=name,
                marker=_few_reads(trace))
        if predicted is not None:
            ax.plot(traj.t, np.abs(predicted[:, j]), color=colors[j], ls="--", lw=0.9)
        if limits is not None and not same_limit:
            ax.axhline(limits[j], color=colors[j], ls=":", lw=1.2)
        if trace.collision_threshold_a is not None and \
                trace.collision_threshold_a[j] is not None:
            ax.axhline(trace.collision_threshold_a[j], color=colors[j], ls="-.", lw=1)
    if same_limit:
        ax.axhline(limits[0], color="k", ls=":", lw=1.2)
    ax.set_ylim(bottom=0)
    styles = [Line2D([], [], color="k", lw=1.2, label="measured")]
    if predicted is not None:
        styles.append(Line2D([], [], color="k", ls="--", lw=0.9, label="predicted"))
    if limits is not None:
        styles.append(Line2D([], [], color="k", ls=":", lw=1.2, label="current limit"))
    if trace.collision_threshold_a is not None and \
            any(v is not None for v in trace.collision_threshold_a):
        styles.append(Line2D([], [], color="k", ls="-.", lw=1, label="collision stop"))
    ax.legend(handles=styles, fontsize="small", loc="center right", ncols=2)
    ax.set(ylabel="|current| [A]", title="measured current (colours: joints)")


def _draw_summary(ax, arm: Arm, traj, trace, near_limits: Sequence[dict[str, Any]]) -> None:
    """Per joint: planned peak velocity and acceleration as a share of the limit, measured
    peak tracking error and current against theirs; the near-limit marks listed."""
    vel, acc = joint_rates(traj)
    error = np.degrees(np.abs(trace.tracking_error_rad))
    current = None if trace.current_a is None else np.abs(trace.current_a)
    head = f"{'joint':<10} {'velocity':>9} {'accel.':>7} {'tracking':>9}"
    if current is not None:
        head += f" {'current':>8} {'limit':>6} {'stop':>6}"
    lines = ["peak per joint: planned velocity and acceleration as a share of",
             "the limit; measured tracking error and current (A) with the",
             "current limit and the collision stop (A)", "", head]
    for j, spec in enumerate(arm.joints):
        row = (f"{spec.name:<10} {np.abs(vel[:, j]).max() / spec.max_velocity:>8.0%} "
               f"{np.abs(acc[:, j]).max() / spec.max_acceleration:>7.0%} "
               f"{(error[:, j].max() if len(error) else 0.0):>8.3f}°")
        if current is not None:
            limit = "—" if trace.current_limit_a is None else f"{trace.current_limit_a[j]:.2f}"
            stop = None if trace.collision_threshold_a is None else \
                trace.collision_threshold_a[j]
            row += (f" {np.nanmax(current[:, j]) if len(current) else 0.0:>6.2f} A"
                    f" {limit:>6} {'off' if stop is None else f'{stop:.2f}':>6}")
        lines.append(row)
    if trace.tracking_limit_rad is not None:
        lines.append(f"tracking limit {math.degrees(trace.tracking_limit_rad):g}°")
    lines.append("")
    lines.append("within 10 % of a limit (✕):" if near_limits else
                 "no measured quantity came within 10 % of its limit")
    units = {"tracking_error": ("tracking error", "°", math.degrees(1.0)),
             "current": ("current", " A", 1.0),
             "collision_current": ("current vs collision stop", " A", 1.0)}
    for mark in near_limits:
        label, unit, factor = units.get(mark["quantity"],
                                        (mark["quantity"].replace("_", " "), "", 1.0))
        lines.append(f"  {mark['joint']} {label}: peak {factor * mark['peak']:.3g}{unit} of "
                     f"{factor * mark['limit']:.3g}{unit}, from t {mark['time_s']:.2f} s")
    ax.axis("off")
    ax.text(0.0, 0.95, "\n".join(lines), family="monospace", fontsize="medium", va="top",
            transform=ax.transAxes)


def _mark_near(panels: dict[str, Any], near_limits: Sequence[dict[str, Any]],
               names: Sequence[str], traj, trace) -> None:
    """Each near-limit mark on the panel of its quantity (where that panel is drawn), at
    the read where it began."""
    for mark in near_limits:
        axis = panels.get(mark["quantity"])
        if axis is None or mark["joint"] not in names:
            continue
        i = min(max(int(mark["sample"]), 0), len(traj.t) - 1)
        rows = np.flatnonzero(trace.sample == mark["sample"])
        x = trace.t[rows[0]] if rows.size else traj.t[i]
        y = math.degrees(mark["value"]) if mark["quantity"] == "tracking_error" \
            else mark["value"]
        axis.plot(x, y, "x", color="tab:red", ms=9, mew=2)
