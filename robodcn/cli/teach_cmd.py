"""``robodcn teach``: record waypoints by moving the arm by hand into a waypoints file.

The dialogue over :class:`robodcn.workflow.teach.Teaching`: Enter records the present pose,
``u`` undoes the last one, ``q`` (or end of input) finishes; the file is
:func:`robodcn.workflow.teach.waypoints_toml`, for ``robodcn run``.
"""

from __future__ import annotations

import argparse

from robodcn import contract
from robodcn.cli import options
from robodcn.cli.dialogue import say, stdin_prompt
from robodcn.cli.report_text import pose_text
from robodcn.cli.servo_session import add_bus_options, open_bus
from robodcn.errors import InputError

PROMPT = "Enter: record the present pose, u: undo the last one, q: finish"


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "teach", help="record waypoints by moving the arm by hand",
        description="Torque off; each Enter records the present pose (FK of the present "
                    "joints) as a waypoint, 'u' undoes the last one, 'q' (or end of input) "
                    "finishes and writes the waypoints file for 'robodcn run'.")
    options.add_arm_option(p)
    add_bus_options(p)
    p.add_argument("--out", required=True, metavar="POSES.toml", help="waypoints file")
    p.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    p.add_argument("--method", metavar="M[,M...]",
                   help="sclerp | kenlerp | seplerp | dlb, or one per segment, for the file")
    p.add_argument("--turn", metavar="T[,T...]", help="shortest | ccw | cw, or one per segment")
    p.add_argument("--beta", type=options.finite_float, help="KenLERP bias for the file's [plan]")
    p.set_defaults(func=run)


def choices(text: str | None, option: str, name: str) -> str | list[str] | None:
    """``--method``/``--turn`` as typed: one choice of the request field ``name``, or a comma
    list of them (one per segment: their count is checked once the segments are known)."""
    if text is None:
        return None
    items = options.choice_list(text, option, contract.cli_choices(name))
    return items[0] if len(items) == 1 else items


def record(teaching) -> None:
    """The Enter / u / q dialogue over ``teaching`` until q or end of input."""
    while True:
        try:
            answer = stdin_prompt(f"[{len(teaching)} recorded] {PROMPT}").strip().lower()
        except EOFError:
            return
        if answer == "":
            pose = teaching.record()
            say(f"waypoint {len(teaching) - 1}: {pose_text(teaching.arm.pose_keys, pose)}")
        elif answer == "u":
            say(f"undone; {len(teaching)} recorded" if teaching.undo() else "nothing to undo")
        elif answer == "q":
            return
        else:
            say(f"unknown answer {answer!r}: {PROMPT}")


def run(args: argparse.Namespace) -> int:
    from robodcn.workflow.teach import Teaching, waypoints_toml

    arm = options.load_arm(args)
    out = options.check_output_path(args.out, "--out", overwrite=args.force)
    method = choices(args.method, "--method", "method")
    turn = choices(args.turn, "--turn", "turn")
    with open_bus(args, arm) as bus:
        teaching = Teaching(bus, arm)
        record(teaching)
    poses = teaching.poses
    if len(poses) < 2:
        raise InputError(f"recorded {len(poses)} waypoint(s), a motion needs at least 2; "
                         f"{out} not written", field="waypoints", value=len(poses))
    for option, value in (("--method", method), ("--turn", turn)):
        if isinstance(value, list) and len(value) != len(poses) - 1:
            raise InputError(f"{option} lists {len(value)} values for {len(poses) - 1} "
                             f"segments; {out} not written", field=option.lstrip("-"),
                             value=value)
    out.write_text(waypoints_toml(poses, arm_name=arm.name, method=method, turn=turn,
                                  beta=args.beta, keys=arm.pose_keys), encoding="utf-8")
    say(f"wrote {len(poses)} waypoints to {out}")
    return 0
