"""What the command line prints about a plan and a run, in degrees and deg/s.

``report_text`` never says more than happened: the headline comes from the run's outcome
("done" | "degraded" | "stopped" | "fault" | "collision"), so a run that skipped samples says
how many, and one that came to rest off its goal names each joint's error in degrees. Per
joint it gives the tracking error (max, RMS) and, with the servos' feedback block, the peak
velocity and current against the current limit, the plan's predicted current and the
collision-stop threshold; then where a limit came within 10 %.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

_FAULTS = {"comm_failure": "bus fault", "hardware_alert": "hardware alert",
           "tracking_error": "tracking error"}


def approach_seconds(report: Any, traj: Any = None) -> float:
    """Duration of the joint-space approach before the path (0 if none): the one the streamer
    inserted (``report.approach``), else the one planned into ``traj``
    (:func:`robodcn.present.approach_of`)."""
    from robodcn.present import approach_of

    approach = report.approach if report is not None else None
    if approach is None and traj is not None:
        approach = approach_of(traj)
    return 0.0 if approach is None else float(approach.duration_s)


def headline(report: Any) -> str:
    """``report.headline``, naming the kind of fault ("bus fault after 12 of 200 samples:
    ..."), with what to try when samples were skipped."""
    if report.outcome == "fault":
        kind = _FAULTS.get(report.stop_reason, "fault")
        detail = getattr(report, "stop_detail", None)
        if detail and detail.get("quantity") == "tracking_error":
            # The stream words its stop in SI; the CLI speaks the config's degrees.
            return (f"{kind} after {report.samples_sent} of {report.samples_total} samples: "
                    f"tracking error {math.degrees(detail['value']):.2f}° "
                    f"({detail['ticks']} ticks) at joint {detail['joint']!r}, sample "
                    f"{detail['sample']}, limit {math.degrees(detail['limit']):.2f}° "
                    "(--tracking-limit)")
        return f"{kind} {report.headline.removeprefix('fault ')}"
    if report.outcome == "degraded":
        hints = []
        if report.skipped:
            hints.append(f"the stream fell behind its {report.rate_hz:g} Hz schedule; try a "
                         "lower --rate")
        if report.out_of_position:
            hints.append("the arm came to rest off its goal: a load the plan did not "
                         "expect (--payload), or a joint held back")
        return f"{report.headline} ({'; '.join(hints)})"
    return report.headline


#: How a near-limit quantity is shown: (label, unit, factor from the report's SI value).
_NEAR_UNITS = {"tracking_error": ("tracking error", "°", math.degrees(1.0)),
               "current": ("current", " A", 1.0),
               "collision_current": ("current vs the collision stop", " A", 1.0)}


def _amps(value: float | None) -> str:
    return "off" if value is None else f"{value:.2f} A"


def near_limit_line(near: dict[str, Any]) -> str:
    """One ``near_limits`` entry in the user's units (degrees, A)."""
    label, unit, factor = _NEAR_UNITS.get(near["quantity"],
                                          (near["quantity"].replace("_", " "), "", 1.0))
    return (f"  near limit: {near['joint']} {label} peak {factor * near['peak']:.3g}{unit} of "
            f"{factor * near['limit']:.3g}{unit} (from t {near['time_s']:.3f} s)")


def sim_payload_text(carried: float, planned: float | None) -> str:
    """What the simulated arm carried, against the payload the plan declared."""
    text = f"simulated arm carried {carried:g} kg at the tool point"
    if planned is None or planned == carried:
        return text + " (the payload the plan declares)"
    return text + f", the plan declares {planned:g} kg"


def report_text(report: Any, approach_s: float = 0.0) -> str:
    """The execution report, a headline and indented detail lines."""
    r = report.to_dict()
    lines = [headline(report),
             f"  samples sent {r['samples_sent']}/{r['samples_total']} in "
             f"{r['duration_s']:.3f} s, rate {r['rate_hz']:g} Hz, achieved "
             f"{r['achieved_rate_hz']:.1f} Hz"]
    for warning in report.warnings:
        lines.append(f"  warning: {warning['message']}")
    carried = r.get("sim_payload_kg")
    if carried is not None:
        lines.append("  " + sim_payload_text(carried, r.get("planned_payload_kg")))
    if approach_s > 0:
        lines.append(f"  approach {approach_s:.3f} s: a joint-space move from the present pose "
                     "to the start, before the path")
    jitter = {k: v for k, v in r.items() if k.startswith("jitter_")}
    if jitter:
        lines.append("  period jitter " + ", ".join(
            f"{k.removeprefix('jitter_').removesuffix('_s')} {1e3 * v:.3f} ms"
            for k, v in jitter.items()))
    lines.append(f"  overruns {r['overruns']}, skipped {report.skipped}, retries "
                 f"{r['retries']}, comm failures {r['comm_failures']}, fast read "
                 f"{'yes' if r.get('fast_read') else 'no'}, compensation "
                 f"{'on' if r.get('compensation') else 'off'}")
    for name, mx, rms, mxt in zip(r["joint_names"], r["tracking_error_max_rad"],
                                  r["tracking_error_rms_rad"], r["tracking_error_max_ticks"],
                                  strict=True):
        lines.append(f"  tracking {name:<10} max {math.degrees(mx):6.3f}° ({mxt} ticks), rms "
                     f"{math.degrees(rms):6.3f}°")
    peaks = r.get("current_peak_a")
    if peaks is not None:
        predicted = r.get("predicted_current_peak_a") or [None] * len(peaks)
        thresholds = r.get("collision_threshold_a") or [None] * len(peaks)
        for j, name in enumerate(r["joint_names"]):
            expected = "" if predicted[j] is None else f", predicted {predicted[j]:.2f} A"
            lines.append(f"  {name:<10} peak {math.degrees(r['velocity_peak_rad_s'][j]):6.1f}"
                         f"°/s, current {peaks[j]:.2f} A (limit {r['current_limit_a'][j]:.2f} "
                         f"A{expected}, collision stop {_amps(thresholds[j])})")
    for near in r.get("near_limits", []):
        lines.append(near_limit_line(near))
    if r.get("collision"):
        c = r["collision"]
        lines.append(f"  collision at {c['joint']}: {c['current_a']:.2f} A above "
                     f"{c['threshold_a']:.2f} A at sample {c['sample']} (t {c['time_s']:.3f} s)")
    for rec in r.get("recovered", []):
        done = "rebooted and holding" if rec.get("recovered") else rec.get("error")
        lines.append(f"  overload recovery of servo {rec['servo_id']}: {done}")
    if r.get("final_error_ticks") is not None:
        lines.append("  final error (ticks) " + ", ".join(map(str, r["final_error_ticks"])))
    if r.get("out_of_position"):
        from robodcn.stream.in_position import misses_text

        lines.append("  out of position: " + misses_text(r["out_of_position"]))
    if r.get("hardware_errors"):
        lines.append("  hardware errors " + ", ".join(
            f"servo {k}: {v}" for k, v in r["hardware_errors"].items()))
    return "\n".join(lines)


def report_dict(report: Any, approach_s: float = 0.0) -> dict[str, Any]:
    """``report.to_dict()`` (outcome, headline, ...) with ``approach_s``."""
    return {**report.to_dict(), "approach_s": approach_s}


def plan_summary(traj: Any, arm: Any, approach_s: float = 0.0) -> str:
    """One screen: duration, samples, and each joint's peak speed and acceleration against
    its limit (deg/s, deg/s², % of the limit), from
    :func:`robodcn.workflow.summary.trajectory_summary`."""
    from robodcn.workflow.summary import trajectory_summary

    s = trajectory_summary(traj, arm)
    methods = s["method"] if isinstance(s["method"], str) else ", ".join(s["method"])
    request = getattr(traj, "request", None)
    segments = len(request.waypoints) - 1 if request is not None else None
    lines = [f"plan: {s['duration_s']:.3f} s, {s['samples']} samples at {s['rate_hz']:g} Hz, "
             + (f"{segments} segment{'s' if segments != 1 else ''}, " if segments else "")
             + f"method {methods}"]
    if approach_s > 0:
        lines.append(f"  approach {approach_s:.3f} s from the present joints, before the path")
    lines.append(f"  {'joint':<10} {'peak velocity, of the limit':<31}   peak acceleration, of the "
                 "limit")
    for spec, j in zip(arm.joints, s["joints"], strict=True):
        lines.append(
            f"  {j['name']:<10} {math.degrees(j['peak_velocity']):8.1f} deg/s of "
            f"{math.degrees(spec.max_velocity):6.1f} ({100 * j['velocity_fraction']:3.0f}%)"
            f"   {math.degrees(j['peak_acceleration']):9.1f} deg/s² of "
            f"{math.degrees(spec.max_acceleration):7.1f}"
            f" ({100 * j['acceleration_fraction']:3.0f}%)")
    lines.append(tool_line(s["tool"], getattr(traj, "pose_keys", None)))
    return "\n".join(lines)


def tool_line(tool: dict[str, Any], keys: Any = None) -> str:
    """The tool point's peak speed, when and where, and — with a ``--tool-speed`` — the
    share of its limit and the span where it binds (a summary's ``tool``)."""
    where = pose_text(keys, tool["pose"]) if keys else ""
    text = (f"  tool       peak {tool['peak_speed']:.4f} m/s at t={tool['t']:.3f} s"
            + (f" ({where})" if where else ""))
    limit = tool["speed_limit"]
    if limit is not None:
        text += f", {100 * tool['peak_speed'] / limit:.0f}% of --tool-speed {limit:g} m/s"
        if tool["binds_from"] is not None:
            text += (f"; binds {tool['binds_from']:.3f}..{tool['binds_to']:.3f} s "
                     f"({100 * tool['binding_share']:.0f}% of the samples)")
    if tool["acceleration_limit"] is not None:
        text += (f"; peak acceleration {tool['peak_acceleration']:.3g} m/s² of "
                 f"{tool['acceleration_limit']:g}")
    return text


def _pose_columns(traj: Any) -> tuple[str, ...]:
    """The pose keys of ``traj``'s pose rows: x, y, θ (planar) or x, y, z, pitch (yawed)."""
    from robodcn.workflow.poses import keys_of_width

    return keys_of_width(np.asarray(traj.poses).shape[1])


def plan_table(traj: Any) -> str:
    """``plan --format table``: t, the pose (m, degrees), the joints (degrees), the ticks."""
    from robodcn.workflow.poses import ANGLE_KEYS, SYMBOLS

    names = list(traj.joint_names)
    keys = _pose_columns(traj)
    pose_head = " ".join(f"{SYMBOLS[k] + ' [°]':>8}" if k in ANGLE_KEYS else
                         f"{SYMBOLS[k] + ' [m]':>9}" for k in keys)
    head = (f"{'t [s]':>8} {pose_head}  "
            + "  ".join(f"{n[:9] + ' [°]':>13}" for n in names) + "  ticks")
    methods = traj.method if isinstance(traj.method, str) else ", ".join(traj.method)
    lines = [f"# {len(traj.t)} samples, {traj.duration:.3f} s at {traj.rate_hz:g} Hz, "
             f"method {methods}", head]
    for t, pose, q, ticks in zip(traj.t, traj.poses, traj.joints, traj.ticks, strict=True):
        cells = " ".join(f"{math.degrees(v):8.2f}" if k in ANGLE_KEYS else f"{v:9.4f}"
                         for k, v in zip(keys, pose, strict=True))
        lines.append(f"{t:8.3f} {cells}  "
                     + "  ".join(f"{math.degrees(a):13.3f}" for a in q) + "  "
                     + ",".join(str(int(k)) for k in ticks))
    return "\n".join(lines) + "\n"


def plan_csv(traj: Any) -> str:
    """``plan --format csv``: :meth:`robodcn.planner.Trajectory.to_csv` (one row per sample,
    SI at full precision, every header naming its unit; a move's record has the same
    columns)."""
    return traj.to_csv()


def pose_text(keys: Any, pose: Any, *, signed: bool = False) -> str:
    """A pose in the user's units, one key each: ``x=0.1218 m, y=0.0000 m, z=0.2409 m,
    pitch=0.00°`` (a yawed arm) or ``x=…, y=…, θ=…°``."""
    from robodcn.workflow.poses import ANGLE_KEYS, SYMBOLS

    sign = "+" if signed else ""
    return ", ".join(f"{SYMBOLS[k]}={math.degrees(v):{sign}.2f}°" if k in ANGLE_KEYS else
                     f"{SYMBOLS[k]}={v:{sign}.4f} m"
                     for k, v in zip(keys, np.asarray(pose, dtype=float).tolist(), strict=True))


__all__ = ["approach_seconds", "headline", "near_limit_line", "plan_csv", "plan_summary",
           "plan_table", "pose_text", "report_dict", "report_text", "tool_line"]
