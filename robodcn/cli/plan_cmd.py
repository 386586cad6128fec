"""``robodcn plan``: plan a trajectory and print it (table, JSON or CSV); no hardware."""

from __future__ import annotations

import argparse
import sys

from robodcn._files import write_file
from robodcn.cli import motion_cmd, options, planning
from robodcn.cli.output import emit
from robodcn.cli.report_text import plan_csv, plan_summary, plan_table


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "plan", help="print a planned trajectory (no hardware)",
        description="Plan a trajectory and print it: a table (t, pose, joints, ticks), the "
                    "Trajectory JSON, or CSV. A summary (duration, samples, each joint's peak "
                    "speed and acceleration against its limit) goes to stderr first. Nothing "
                    "is sent to any servo.")
    planning.add_motion_options(p, start_help="start pose (default: the arm's home pose)")
    p.add_argument("--format", choices=("table", "json", "csv"), default="table",
                   help="table (degrees), Trajectory JSON, or CSV (SI; headers carry the "
                        "units: t_s, x_m, y_m, theta_rad, q_<joint>_rad, tick_<id>)")
    p.add_argument("--out", metavar="FILE", help="write to FILE instead of standard output")
    p.add_argument("-q", "--quiet", action="store_true", help="no summary")
    motion_cmd.add_plot_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.out is not None:
        options.check_output_path(args.out, "--out")
    motion_cmd.check_plot(args.plot)
    arm = options.load_arm(args)
    request = planning.motion_request(args, arm)
    traj = planning.plan_motion(request, arm, request.start or tuple(arm.home))
    if not args.quiet:
        print(plan_summary(traj, arm), file=sys.stderr, flush=True)
    text = {"table": plan_table, "json": lambda tr: tr.to_json() + "\n",
            "csv": plan_csv}[args.format](traj)
    if args.out is not None:
        write_file(args.out, text, field="--out")
        print(f"wrote {len(traj.t)} samples ({traj.duration:.3f} s) to {args.out}",
              file=sys.stderr)
    else:
        emit(text)
    motion_cmd.plot(args.plot, arm, traj)
    return 0
