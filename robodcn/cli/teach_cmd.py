"""``robodcn teach``: record waypoints by moving the arm by hand into a waypoints file.

The dialogue over :class:`robodcn.workflow.teach.Teaching`: Enter records the present pose,
``o`` / ``c`` open / close the gripper there (the waypoint gets ``gripper = "open" |
"close"``), ``u`` undoes the last one, ``q`` (or end of input) finishes; the file is
:func:`robodcn.workflow.teach.waypoints_toml`, for ``robodcn run``.

Torque goes off so a hand moves the arm — on an arm under gravity only with ``--yes``
(:mod:`robodcn.cli.releasing`: it is lowered to its rest pose first), and however the
session ends it holds where it is (torque on, position mode). ``--float`` holds a vertical
arm in float mode instead (:class:`robodcn.workflow.teach.FloatSession`: current control
with torque on and the present pose's gravity currents, refreshed on its own thread while
the prompt waits): it stays where the hand leaves it — said once the servos read back
current control with torque on — and at the end holds there in position mode (read back
too); ``--release`` then lets it go (``--yes``; lowered to ``[arm.rest]`` first).
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

from robodcn import contract
from robodcn._files import rescue
from robodcn.cli import options, planning, releasing
from robodcn.cli.dialogue import say, stdin_prompt
from robodcn.cli.output import save_work
from robodcn.cli.report_text import pose_text
from robodcn.cli.servo_session import add_bus_options, open_bus
from robodcn.errors import InputError, KeepOutError

PROMPT = "Enter: record the present pose, u: undo the last one, q: finish"
GRIPPER_PROMPT = ("Enter: record the present pose, o/c: open/close the gripper here, "
                  "u: undo the last one, q: finish")
#: The dialogue's gripper keys → the command a waypoint records.
GRIPPER_KEYS = {"o": "open", "c": "close"}


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "teach", help="record waypoints by moving the arm by hand",
        description="Torque off (an arm under gravity falls: --yes, or --float); each "
                    "Enter records the present pose (FK of the present joints) as a "
                    "waypoint, 'o'/'c' open/close the gripper and mark the waypoint there "
                    "gripper = \"open\"/\"close\" (run comes to rest and acts on it), 'u' "
                    "undoes the last one, 'q' (or end of input) finishes and writes the "
                    "waypoints file for 'robodcn run'.")
    options.add_arm_option(p)
    add_bus_options(p)
    p.add_argument("--float", action="store_true", dest="float_mode",
                   help="hold a vertical arm in float mode (current control with the "
                        "gravity current of the present pose, refreshed at >= 50 Hz) while "
                        "a hand moves it: it stays where it is left, and holds there in "
                        "position mode at the end")
    p.add_argument("--release", action="store_true",
                   help="with --float: torque off at the end (an arm under gravity needs "
                        "--yes; lowered to its [arm.rest] pose first)")
    releasing.add_yes_option(p, what="torque off (teach without --float, or --release)")
    p.add_argument("--out", required=True, metavar="POSES.toml", help="waypoints file")
    p.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    p.add_argument("--method", metavar="M[,M...]",
                   help="sclerp | kenlerp | seplerp | dlb, or one per segment, for the file")
    p.add_argument("--turn", metavar="T[,T...]", help="shortest | ccw | cw, or one per segment")
    p.add_argument("--beta", type=options.finite_float, help="KenLERP bias for the file's [plan]")
    # the lowering to the rest pose before torque goes off moves the arm near a hand
    planning.add_tool_options(p.add_argument_group("lowering"), hands_on=True)
    p.set_defaults(func=run)


def choices(text: str | None, option: str, name: str) -> str | list[str] | None:
    """``--method``/``--turn`` as typed: one choice of the request field ``name``, or a comma
    list of them (one per segment: their count is checked once the segments are known)."""
    if text is None:
        return None
    items = options.choice_list(text, option, contract.cli_choices(name))
    return items[0] if len(items) == 1 else items


def record(teaching) -> None:
    """The Enter / o / c / u / q dialogue over ``teaching`` until q or end of input."""
    has_gripper = teaching.arm.gripper is not None
    prompt = GRIPPER_PROMPT if has_gripper else PROMPT
    while True:
        try:
            answer = stdin_prompt(f"[{len(teaching)} recorded] {prompt}").strip().lower()
        except EOFError:
            return
        if answer == "":
            try:
                pose = teaching.record()
            except KeepOutError as exc:
                say(f"not recorded: {exc.message}")
                continue
            say(f"waypoint {len(teaching) - 1}: {pose_text(teaching.arm.pose_keys, pose)}")
        elif answer in GRIPPER_KEYS and has_gripper:
            try:
                _gripper(teaching, GRIPPER_KEYS[answer])
            except KeepOutError as exc:
                say(f"not recorded: {exc.message}")
        elif answer == "u":
            say(f"undone; {len(teaching)} recorded" if teaching.undo() else "nothing to undo")
        elif answer == "q":
            return
        else:
            say(f"unknown answer {answer!r}: {prompt}")


def _gripper(teaching, command: str) -> None:
    from robodcn.cli.gripper_cmd import result_line

    index, result = teaching.gripper(command)
    pose = teaching.poses[index]
    say(f"{result_line(result)}\nwaypoint {index}: "
        f"{pose_text(teaching.arm.pose_keys, pose)}, gripper = {command!r}")


def _check_segments(method, turn, count: int, out, text: str) -> None:
    """``--method``/``--turn`` lists against the taught segments; on a mismatch the poses
    (``text``, the file without those lists) are saved elsewhere and the error says where."""
    for option, value in (("--method", method), ("--turn", turn)):
        if isinstance(value, list) and len(value) != count - 1:
            saved = rescue(out, text)
            where = (f"the {count} taught waypoints are saved in {saved} (without "
                     f"{option})" if isinstance(saved, Path) else f"{out} not written")
            raise InputError(f"{option} lists {len(value)} values for {count - 1} "
                             f"segments; {where}", field=option.lstrip("-"), value=value)


def _teach(args: argparse.Namespace, arm, bus, lowering: dict[str, float]):
    """The dialogue on ``bus``: floating (--float) or with torque off; the Teaching. However
    it ends, an arm under gravity is left holding where it is (torque on, position mode).
    ``lowering``: the plan options of a lowering to the rest pose (the hands-on tool
    speed)."""
    from robodcn.present import present_joints
    from robodcn.workflow.teach import FloatSession, Teaching

    gravity = releasing.falls(arm)
    if args.float_mode:
        if args.release and gravity:
            releasing.confirm_release(arm, present_joints(arm, bus), args.yes)
        with FloatSession(bus, arm, joints=arm.joint_names) as session:   # the yaw too
            say(_floating_line(session.float))
            teaching = Teaching(bus, arm, torque_off=False, run=session.call)
            record(teaching)
        _float_end(session.report)
        if args.release:
            _release_at_end(args, arm, bus, lowering)
        return teaching
    if gravity and not args.yes:
        say("robodcn: teach --float holds a vertical arm while a hand moves it")
        releasing.confirm_release(arm, present_joints(arm, bus), args.yes, what="teach")
    with Teaching(bus, arm, confirm=args.yes, warn=releasing.warning,
                  plan_options=lowering) as teaching:
        record(teaching)
    if teaching.held:
        say("teach: the arm holds where it is (torque on, position mode)")
    return teaching


def _floating_line(float_teach) -> str:
    """What the float does, once it reads back current control with torque on: the joints
    whose gravity current is above their Current Limit sag, the others stay."""
    latest = float_teach.latest
    over = float_teach.report().clipped if latest is not None else ()
    stays = ("it stays where you leave it" if not over else
             f"it stays where you leave it, except {', '.join(over)} (above the current "
             "limit: it sags)")
    return (f"float: joints {', '.join(float_teach.joint_names)} hold against gravity "
            f"(current control, torque on); move the arm by hand, {stays}")


def _float_end(report) -> None:
    """The float's last line: what it did and, read back, whether the arm holds."""
    if report is None:
        return
    clipped = (f"; above the current limit (sagged): {', '.join(report.clipped)}"
               if report.clipped else "")
    held = ("the arm holds where it was left (position mode)" if report.held else
            "robodcn: warning: position mode with torque on could not be read back on "
            "every joint: hold the arm")
    say(f"float off: {report.cycles} refreshes at {report.rate_hz:.0f} Hz{clipped}; {held}")


def _release_at_end(args: argparse.Namespace, arm, bus, lowering: dict[str, float]
                    ) -> None:
    say(releasing.release_line(releasing.guarded(args, arm, bus, plan_options=lowering)))


def run(args: argparse.Namespace) -> int:
    from robodcn.workflow.teach import waypoints_toml

    arm = options.load_arm(args)
    out = options.check_output_path(args.out, "--out", overwrite=args.force)
    method = choices(args.method, "--method", "method")
    turn = choices(args.turn, "--turn", "turn")
    if args.release and not args.float_mode:
        raise InputError("--release applies to teach --float (without it torque is already "
                         "off)", field="release", value=True)
    lowering = planning.tool_keywords(args, arm, hands_on=True)
    with open_bus(args, arm) as bus:
        teaching = _teach(args, arm, bus, lowering)
    poses = teaching.poses
    if len(poses) < 2:
        raise InputError(f"recorded {len(poses)} waypoint(s), a motion needs at least 2; "
                         f"{out} not written", field="waypoints", value=len(poses))
    toml = functools.partial(waypoints_toml, poses, arm_name=arm.name, beta=args.beta,
                             keys=arm.pose_keys, extras=teaching.actions)
    _check_segments(method, turn, len(poses), out, toml(method=None, turn=None))
    save_work(out, toml(method=method, turn=turn), what=f"the {len(poses)} taught waypoints")
    say(f"wrote {len(poses)} waypoints to {out}")
    return 0
