"""``robodcn check-config`` (validate an arm TOML and summarise it in degrees) and
``robodcn config example`` (print a packaged example arm)."""

from __future__ import annotations

import argparse
import json
import math
import sys

from robodcn.cli import motion_cmd
from robodcn.cli.dialogue import say
from robodcn.cli.exit_codes import Exit
from robodcn.config import Arm, load_arm
from robodcn.workflow.examples import EXAMPLES, example_text, resolve_arm_path


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "check-config", help="validate an arm TOML and summarise it",
        description="Validate FILE (or an example name) and print links, reach, joint and "
                    "tick ranges in degrees, the servo map and the bus. --plot draws the "
                    "reachable workspace.")
    p.add_argument("file", metavar="FILE", help="arm TOML file or example name")
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


def summary_text(arm: Arm) -> str:
    """:func:`robodcn.workflow.check.summary` as lines for a terminal: metres, degrees,
    deg/s, ticks."""
    from robodcn.workflow.check import summary

    s = summary(arm)
    d = math.degrees
    kind = "full pose x, y, θ" if s["full_pose"] else "position x, y (θ free)"
    lines = [f"{s['source']}: OK — arm {s['name']!r}, {s['dof']} joints ({kind})",
             "links: " + ", ".join(f"{v:.3f}" for v in s["links"]) + " m",
             f"reach: wrist point {s['reach']['wrist_inner']:.3f}..{s['reach']['wrist_outer']:.3f}"
             f" m from the base, tool up to {s['reach']['tool_max']:.3f} m; elbow {s['elbow']}",
             f"home: x={s['home'][0]:.3f} m, y={s['home'][1]:.3f} m, θ={d(s['home'][2]):.1f}°",
             f"{'joint':<10} {'limits [°]':>17} {'vel [°/s]':>9} {'acc [°/s²]':>10}  "
             f"{'id':>3} {'model':<11} {'zero':>5} {'dir':>3} {'ticks':>11} {'ticks as [°]':>17}"]
    for j in s["joints"]:
        sv = j["servo"]
        lo, hi = j["tick_range_angles"]
        warn = "" if j["limits_inside_ticks"] else "  ! joint limits exceed the tick range"
        lines.append(f"{j['name']:<10} {d(j['min']):8.1f}..{d(j['max']):<7.1f} "
                     f"{d(j['max_velocity']):9.1f} {d(j['max_acceleration']):10.1f}  "
                     f"{sv['id']:>3} {sv['model']:<11} {sv['zero_offset']:>5} "
                     f"{sv['direction']:>+3d} {sv['min_tick']:>5}..{sv['max_tick']:<5} "
                     f"{d(lo):8.1f}..{d(hi):.1f}{warn}")
    b = s["bus"]
    lines.append(f"bus: {b['port']} at {b['baud']} baud, protocol {b['protocol']:g}, stream "
                 f"{b['rate_hz']:g} Hz")
    return "\n".join(lines)


def run_check(args: argparse.Namespace) -> int:
    from robodcn.workflow.check import summary, workspace_samples

    motion_cmd.check_plot(args.plot)
    arm = load_arm(resolve_arm_path(args.file, option="FILE"))
    print(json.dumps(summary(arm), indent=2) if args.json else summary_text(arm))
    if args.plot:
        from robodcn.plots import plot_workspace

        plot_workspace(args.plot, arm, workspace_samples(arm))
        say(f"plot: {args.plot}")
    return Exit.DONE


def run_config_example(args: argparse.Namespace) -> int:
    sys.stdout.write(example_text(args.name))
    return Exit.DONE
