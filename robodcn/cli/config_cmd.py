"""``robodcn check-config`` (validate an arm TOML and summarise it in degrees) and
``robodcn config example`` (print a packaged example arm)."""

from __future__ import annotations

import argparse
import json
import math
import sys

from robodcn.cli import motion_cmd, options
from robodcn.cli.dialogue import say
from robodcn.cli.exit_codes import Exit
from robodcn.cli.report_text import pose_text
from robodcn.config import Arm, load_arm
from robodcn.workflow.examples import EXAMPLES, example_text, resolve_arm_path


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "check-config", help="validate an arm TOML and summarise it",
        description="Validate FILE (or an example name) and print links, reach, joint and "
                    "tick ranges in degrees, the servo map and the bus, and per joint the "
                    "worst holding torque over its joint limits (gravity, --payload at the "
                    "tool point) beside the servo's stall torque and max_torque_nm, warning "
                    "above either and where (max_velocity, max_torque_nm) lies above the "
                    "servo's torque-speed line. --plot draws the reachable workspace (a "
                    "yawed arm's in its vertical plane).")
    p.add_argument("file", metavar="FILE", help="arm TOML file or example name")
    p.add_argument("--payload", type=options.non_negative_float, metavar="KG",
                   help="mass at the tool point for the holding torques, kg (default: the "
                        "arm's [dynamics] payload_kg)")
    p.add_argument("--plot", metavar="FILE.png", help="draw the workspace (needs matplotlib)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON (SI)")
    p.set_defaults(func=run_check)

    p = subparsers.add_parser(
        "config", help="example arm configs",
        description="robodcn config example [arm3r|arm2r] > my.toml writes an example arm to "
                    "edit.")
    csub = p.add_subparsers(dest="config_command", metavar="ACTION", required=True)
    ex = csub.add_parser("example", help="print an example arm TOML",
                         description="Print a packaged example arm: " + "; ".join(
                             f"{k}: {v}" for k, v in EXAMPLES.items()))
    ex.add_argument("name", nargs="?", default="arm3r", choices=tuple(EXAMPLES),
                    help="which example (default arm3r)")
    ex.set_defaults(func=run_config_example)


def summary_text(arm: Arm, payload_kg: float | None = None) -> str:
    """:func:`robodcn.workflow.check.summary` as lines for a terminal: metres, degrees,
    deg/s, ticks, N·m."""
    from robodcn.workflow.check import summary

    s = summary(arm, payload_kg)
    d = math.degrees
    if s["yawed"]:
        kind = "base yaw + chain in a vertical plane: poses x, y, z, pitch"
    else:
        kind = "full pose x, y, θ" if s["full_pose"] else "position x, y (θ free)"
    r = s["reach"]
    reach = (f"reach: wrist point {r['wrist_inner']:.3f}..{r['wrist_outer']:.3f} m from the "
             + ("shoulder" if s["yawed"] else "base") + f", tool up to {r['tool_max']:.3f} m"
             + (f" (shoulder {r['shoulder_height']:.3f} m above the base)" if s["yawed"]
                else "") + f"; elbow {s['elbow']}")
    lines = [f"{s['source']}: OK — arm {s['name']!r}, {s['dof']} joints ({kind})",
             "links: " + ", ".join(f"{v:.3f}" for v in s["links"]) + " m", reach,
             f"home: {pose_text(arm.pose_keys, s['home'])}"]
    if s["rest"] is not None:
        lines.append(f"rest: {pose_text(arm.pose_keys, s['rest'])}")
    lines.append(f"{'joint':<10} {'limits [°]':>17} {'vel [°/s]':>9} {'acc [°/s²]':>10}  "
                 f"{'id':>3} {'model':<11} {'zero':>5} {'dir':>3} {'ticks':>11} "
                 f"{'ticks as [°]':>17}")
    for j in s["joints"]:
        sv = j["servo"]
        lo, hi = j["tick_range_angles"]
        warn = "" if j["limits_inside_ticks"] else "  ! joint limits exceed the tick range"
        lines.append(f"{j['name']:<10} {d(j['min']):8.1f}..{d(j['max']):<7.1f} "
                     f"{d(j['max_velocity']):9.1f} {d(j['max_acceleration']):10.1f}  "
                     f"{sv['id']:>3} {sv['model']:<11} {sv['zero_offset']:>5} "
                     f"{sv['direction']:>+3d} {sv['min_tick']:>5}..{sv['max_tick']:<5} "
                     f"{d(lo):8.1f}..{d(hi):.1f}{warn}")
    lines += torque_lines(s)
    b = s["bus"]
    lines.append(f"bus: {b['port']} at {b['baud']} baud, protocol {b['protocol']:g}, stream "
                 f"{b['rate_hz']:g} Hz")
    g = s["gripper"]
    if g is not None:
        lines.append(f"gripper: servo {g['id']} ({g['model']}), jaws "
                     f"{1e3 * g['closed_width_m']:.0f}..{1e3 * g['open_width_m']:.0f} mm, grip "
                     f"current {g['grip_current_a']:.2f} A")
    if arm.workspace.zones:
        lines.append("keep-out: " + "; ".join(arm.workspace.describe(z)
                                              for z in arm.workspace.zones))
    return "\n".join(lines)


def torque_lines(s: dict) -> list[str]:
    """The holding-torque table of a summary: per joint the worst |gravity torque| over its
    joint limits with the payload, the stall torque, max_torque_nm and the torque the
    servo has at the joint's top speed; then one ``!`` line per warning. Nothing for an arm
    whose gravity is off and that sets no torque limit."""
    joints = s["joints"]
    if all(j["holding_torque_nm"] == 0.0 and j["max_torque_nm"] is None for j in joints):
        return []

    def nm(value) -> str:
        return "—" if value is None else f"{value:.2f}"

    lines = [f"holding torque over the joint limits with a {s['payload_kg']:g} kg payload "
             "(N·m):",
             f"{'joint':<10} {'holding':>8} {'stall':>6} {'max_torque':>10} "
             f"{'at top speed':>12}"]
    for j in joints:
        lines.append(f"{j['name']:<10} {j['holding_torque_nm']:8.2f} "
                     f"{nm(j['stall_torque_nm']):>6} {nm(j['max_torque_nm']):>10} "
                     f"{nm(j['available_torque_nm']):>12}")
    lines += [f"  ! {w}" for w in s["warnings"]]
    return lines


def run_check(args: argparse.Namespace) -> int:
    from robodcn.workflow.check import summary, workspace_samples

    motion_cmd.check_plot(args.plot)
    arm = load_arm(resolve_arm_path(args.file, option="FILE"))
    print(json.dumps(summary(arm, args.payload), indent=2) if args.json
          else summary_text(arm, args.payload))
    if args.plot:
        from robodcn.plots import plot_workspace

        plot_workspace(args.plot, arm, workspace_samples(arm))
        say(f"plot: {args.plot}")
    return Exit.DONE


def run_config_example(args: argparse.Namespace) -> int:
    sys.stdout.write(example_text(args.name))
    return Exit.DONE
