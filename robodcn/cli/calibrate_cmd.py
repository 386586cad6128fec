"""``robodcn calibrate``: zero offsets, directions and ranges by moving the arm by hand.

The dialogue over :class:`robodcn.workflow.calibrate.Calibrator`: prompts on stderr, one
answer line each from stdin (:mod:`robodcn.cli.dialogue`); the diff of the arm TOML on
stdout; ``--out`` written only when confirmed (or ``--yes``). A joint that did not move
in the direction step is asked for again (``s`` skips it, keeping its configured direction
and range); the joints done so far are kept.
"""

from __future__ import annotations

import argparse
import sys

from robodcn.cli import options, releasing
from robodcn.cli.dialogue import confirm, say, stdin_prompt
from robodcn.cli.exit_codes import Exit
from robodcn.cli.output import save_work
from robodcn.cli.servo_session import add_bus_options, open_bus
from robodcn.errors import InputError

#: Answers that skip a joint's range step, or a joint that did not move.
SKIP_ANSWERS = ("s", "skip")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "calibrate", help="find zero offsets, directions and ranges by moving the arm by hand",
        description="Torque off (on an arm under gravity asked first, or --yes: it is "
                    "lowered to its [arm.rest] pose, then you hold it; however calibration "
                    "ends it then holds where it is, torque on); put the arm in its "
                    "reference pose (every joint angle 0) and press Enter: each servo's "
                    "tick becomes its zero_offset. Then, per joint, "
                    "turn it in its positive direction (sets direction) and, unless "
                    "--no-ranges, through its whole range (sets min_tick/max_tick with "
                    "--margin and the joint limits inside them). Writes --out, a copy of the "
                    "arm TOML with its comments and layout kept, after showing a diff. Answers "
                    "are read from stdin, one line per prompt.")
    options.add_arm_option(p)
    add_bus_options(p)
    p.add_argument("--out", required=True, metavar="NEW.toml", help="calibrated arm TOML")
    p.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    p.add_argument("--yes", action="store_true", help="write without asking; on an arm "
                   "under gravity also confirms torque off (lowered to [arm.rest] first)")
    p.add_argument("--no-ranges", dest="ranges", action="store_false",
                   help="skip the whole-range step (keep tick ranges and joint limits)")
    p.add_argument("--margin", type=options.positive_float, default=2.0, metavar="DEG",
                   help="tick range this far inside the range moved through (default 2°)")
    p.set_defaults(func=run)


def _ask(message: str) -> str:
    try:
        return stdin_prompt(message).strip().lower()
    except EOFError:
        raise InputError(f"input ended before calibration finished (at: {message!r}); "
                         "nothing was written", field="stdin", value=None) from None


def dialogue(calibrator, *, ranges: bool):
    """Drive ``calibrator`` (a :class:`~robodcn.workflow.calibrate.Calibrator`) through
    its steps; returns its :class:`~robodcn.workflow.calibrate.Calibration`."""
    arm = calibrator.arm
    held = "; hold it, gravity loads it" if releasing.falls(arm) else ""
    _ask(f"Torque is off{held}. Put the arm in its reference pose (every joint angle 0) and "
         "press Enter")
    calibrator.read_reference()
    for j, spec in enumerate(arm.joints):
        answer = _ask(f"Turn joint {spec.name!r} (servo {spec.servo.id}) a little in its "
                      "positive direction and press Enter (s: skip this joint)")
        if answer in SKIP_ANSWERS:
            calibrator.skip(j)
            continue
        motion = calibrator.motion(j)
        while motion.direction is None:
            answer = _ask(f"joint {spec.name!r} moved {motion.moved_ticks} ticks "
                          f"({motion.moved_deg:.1f}°): turn it at least "
                          f"{calibrator.min_motion_deg:g}° in its positive direction and press "
                          "Enter (s: skip this joint, keeping its direction and range)")
            if answer in SKIP_ANSWERS:
                calibrator.skip(j)
                break
            motion = calibrator.motion(j)
        if motion.direction is None:
            continue
        if ranges:
            with calibrator.sampling() as sampler:
                answer = _ask(f"Move joint {spec.name!r} slowly through its whole range and "
                              "press Enter (s: skip)")
            if answer not in SKIP_ANSWERS:
                calibrator.joint_range(j, sampler)
    if arm.gripper is not None:
        for end in ("open", "closed"):
            answer = _ask(f"Move the gripper's jaws by hand to fully {end} and press Enter "
                          "(s: skip the gripper)")
            if answer in SKIP_ANSWERS:
                calibrator.skip_gripper()
                break
            calibrator.gripper_end(end)
    return calibrator.result()


def _start(calibrator, yes: bool) -> None:
    """Torque off (:meth:`~robodcn.workflow.calibrate.Calibrator.start`): on an arm that
    would fall, asked first (``--yes`` answers), refused (exit 2, naming the joints and the
    flag) unless answered y."""
    from robodcn.errors import GravityReleaseError

    try:
        calibrator.start(confirm=yes, warn=releasing.warning)
    except GravityReleaseError as refusal:
        if not confirm(f"{refusal.message}. Go on, holding the arm when it is let go?"):
            raise releasing.asks(refusal) from None
        calibrator.start(confirm=True, warn=releasing.warning)


def run(args: argparse.Namespace) -> int:
    from robodcn.workflow.calibrate import Calibrator, diff, updated_toml
    from robodcn.workflow.examples import resolve_arm_path

    source = resolve_arm_path(args.arm)
    arm = options.load_arm(args)
    out = options.check_output_path(args.out, "--out", overwrite=args.force)
    text = source.read_text(encoding="utf-8")
    with open_bus(args, arm) as bus, Calibrator(bus, arm, margin_deg=args.margin) as cal:
        _start(cal, args.yes)
        try:
            result = dialogue(cal, ranges=args.ranges)
        finally:
            cal.close(failed=sys.exc_info()[0] is not None)     # held before it is said
            if cal.held:
                say("calibration: the arm holds where it is (torque on, position mode)")
    new = updated_toml(text, result, source=str(out))
    for note in result.notes:
        say(f"note: {note}")
    changes = diff(text, new, str(source), str(out))
    sys.stdout.write(changes or f"no changes to {source}\n")
    sys.stdout.flush()
    if not confirm(f"write {out}?", yes=args.yes):
        say(f"{out} not written")
        return Exit.DECLINED
    save_work(out, new, what="the calibrated config")
    say(f"wrote {out}" + ("" if cal.held else " (torque stays off)"))
    return 0
