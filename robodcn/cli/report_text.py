"""What the command line prints about a plan and a run, in degrees and deg/s.

``report_text`` never says more than happened: the headline comes from the run's outcome
("done" | "degraded" | "stopped" | "fault"), so a run that skipped samples says how many.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from robodcn.cli.exit_codes import report_outcome, skipped_count

_FAULTS = {"comm_failure": "bus fault", "hardware_alert": "hardware alert",
           "tracking_error": "tracking error"}


def approach_seconds(report: Any, traj: Any = None) -> float:
    """Duration of the joint-space approach inserted before the path (0 if none).

    ``report.approach`` when the streamer gives it as a duration; otherwise the time at which
    a trajectory planned with ``start_joints`` first reaches its first waypoint.
    """
    approach = getattr(report, "approach", None) if report is not None else None
    seconds = getattr(approach, "duration_s", approach)  # an Approach, or a number
    if isinstance(seconds, int | float) and not isinstance(seconds, bool) and seconds > 0:
        return float(seconds)
    if traj is None:
        return 0.0
    try:
        from robodcn.present import approach_of
    except ImportError:
        approach_of = None
    if approach_of is not None:
        found = approach_of(traj)
        return 0.0 if found is None else float(found.duration_s)
    request = getattr(traj, "request", None)
    if request is None or request.start_joints is None:
        return 0.0
    first = np.asarray(request.waypoints[0])
    # An approach ends exactly at the IK of waypoints[0]; the path itself starts there.
    at = np.flatnonzero(np.all(np.abs(traj.poses[:, :2] - first[:2]) < 1e-9, axis=1))
    return float(traj.t[at[0]]) if at.size else 0.0


def headline(report: Any) -> str:
    outcome = report_outcome(report)
    total = report.samples_total
    if outcome == "done":
        return f"completed: all {total} samples sent"
    if outcome == "degraded":
        return (f"completed with {skipped_count(report)} of {total} samples skipped (the "
                f"stream fell behind its {report.rate_hz:g} Hz schedule; try a lower --rate)")
    what = "stopped" if outcome == "stopped" else _FAULTS.get(report.stop_reason,
                                                                report.stop_reason)
    return f"{what}: {report.message}" if report.message else what


def report_text(report: Any, approach_s: float = 0.0) -> str:
    """The execution report, a headline and indented detail lines."""
    r = report.to_dict()
    lines = [headline(report),
             f"  samples sent {r['samples_sent']}/{r['samples_total']} in "
             f"{r['duration_s']:.3f} s, rate {r['rate_hz']:g} Hz, achieved "
             f"{r['achieved_rate_hz']:.1f} Hz"]
    for warning in getattr(report, "warnings", None) or ():
        text = warning.get("message", "") if isinstance(warning, dict) else str(warning)
        lines.append(f"  warning: {text}")
    if approach_s > 0:
        lines.append(f"  approach {approach_s:.3f} s: a joint-space move from the present pose "
                     "to the start, before the path")
    jitter = {k: v for k, v in r.items() if k.startswith("jitter_")}
    if jitter:
        lines.append("  period jitter " + ", ".join(
            f"{k.removeprefix('jitter_').removesuffix('_s')} {1e3 * v:.3f} ms"
            for k, v in jitter.items()))
    lines.append(f"  overruns {r['overruns']}, skipped {skipped_count(report)}, retries "
                 f"{r['retries']}, comm failures {r['comm_failures']}, fast read "
                 f"{'yes' if r.get('fast_read') else 'no'}")
    for name, mx, rms, mxt in zip(r["joint_names"], r["tracking_error_max_rad"],
                                  r["tracking_error_rms_rad"], r["tracking_error_max_ticks"],
                                  strict=True):
        lines.append(f"  tracking {name:<10} max {math.degrees(mx):6.3f}° ({mxt} ticks), rms "
                     f"{math.degrees(rms):6.3f}°")
    if r.get("final_error_ticks") is not None:
        lines.append("  final error (ticks) " + ", ".join(map(str, r["final_error_ticks"])))
    if r.get("hardware_errors"):
        lines.append("  hardware errors " + ", ".join(
            f"servo {k}: {v}" for k, v in r["hardware_errors"].items()))
    return "\n".join(lines)


def report_dict(report: Any, approach_s: float = 0.0) -> dict[str, Any]:
    """``report.to_dict()`` with ``outcome`` and ``approach_s`` (when the report lacks them)."""
    data = report.to_dict()
    data.setdefault("outcome", report_outcome(report))
    data.setdefault("approach_s", approach_s)
    return data


def peaks(traj: Any) -> tuple[np.ndarray, np.ndarray]:
    """Peak |velocity| and |acceleration| per joint (rad/s, rad/s²) by finite differences at
    the sample rate, the arm at rest before and after (the planner's validation rule)."""
    q = np.concatenate([traj.joints[:1], traj.joints, traj.joints[-1:]])
    vel = np.diff(q, axis=0) * traj.rate_hz
    acc = np.diff(vel, axis=0) * traj.rate_hz
    return np.abs(vel).max(axis=0), np.abs(acc).max(axis=0)


def plan_summary(traj: Any, arm: Any, approach_s: float = 0.0) -> str:
    """One screen: duration, samples, and each joint's peak speed and acceleration against
    its limit (deg/s, deg/s², % of the limit)."""
    methods = traj.method if isinstance(traj.method, str) else ", ".join(traj.method)
    request = getattr(traj, "request", None)
    segments = len(request.waypoints) - 1 if request is not None else None
    lines = [f"plan: {traj.duration:.3f} s, {len(traj.t)} samples at {traj.rate_hz:g} Hz, "
             + (f"{segments} segment{'s' if segments != 1 else ''}, " if segments else "")
             + f"method {methods}"]
    if approach_s > 0:
        lines.append(f"  approach {approach_s:.3f} s from the present joints, before the path")
    vel, acc = peaks(traj)
    lines.append(f"  {'joint':<10} {'peak velocity, of the limit':<31}   peak acceleration, of the "
                 "limit")
    for joint, v, a in zip(arm.joints, vel, acc, strict=True):
        lines.append(
            f"  {joint.name:<10} {math.degrees(v):8.1f} deg/s of "
            f"{math.degrees(joint.max_velocity):6.1f} ({100 * v / joint.max_velocity:3.0f}%)"
            f"   {math.degrees(a):9.1f} deg/s² of {math.degrees(joint.max_acceleration):7.1f}"
            f" ({100 * a / joint.max_acceleration:3.0f}%)")
    return "\n".join(lines)


def plan_table(traj: Any) -> str:
    names = list(traj.joint_names)
    head = (f"{'t [s]':>8} {'x [m]':>9} {'y [m]':>9} {'θ [°]':>8}  "
            + "  ".join(f"{n[:9] + ' [°]':>13}" for n in names) + "  ticks")
    methods = traj.method if isinstance(traj.method, str) else ", ".join(traj.method)
    lines = [f"# {len(traj.t)} samples, {traj.duration:.3f} s at {traj.rate_hz:g} Hz, "
             f"method {methods}", head]
    for t, pose, q, ticks in zip(traj.t, traj.poses, traj.joints, traj.ticks, strict=True):
        lines.append(f"{t:8.3f} {pose[0]:9.4f} {pose[1]:9.4f} {math.degrees(pose[2]):8.2f}  "
                     + "  ".join(f"{math.degrees(a):13.3f}" for a in q) + "  "
                     + ",".join(str(int(k)) for k in ticks))
    return "\n".join(lines) + "\n"


__all__ = ["approach_seconds", "headline", "peaks", "plan_summary", "plan_table",
           "report_dict", "report_text"]
