"""``robodcn gripper open|close|WIDTH_MM``: the arm's ``[gripper]`` over
:mod:`robodcn.workflow.gripper` (current-based position mode, the goal current below the
servo's limit: an object in the jaws is held without an overload alert)."""

from __future__ import annotations

import argparse
import json

from robodcn.cli import options
from robodcn.cli.exit_codes import Exit
from robodcn.cli.servo_session import add_bus_options, open_bus
from robodcn.errors import InputError


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "gripper", help="open or close the gripper, or set its jaw width",
        description="Drive the arm's [gripper] servo to open, close or a jaw width in mm "
                    "(within its stroke), in current-based position mode with the "
                    "[gripper] grip_current as the goal current: closing on an object holds "
                    "it with that current (no overload alert). Prints where the jaws came "
                    "to rest and whether an object stopped them. The arm's joints are not "
                    "touched, and the payload the planner assumes does not change.")
    p.add_argument("command", metavar="open|close|WIDTH_MM",
                   help="open, close, or the jaw width in millimetres")
    options.add_arm_option(p)
    add_bus_options(p)
    p.add_argument("--sim", action="store_true",
                   help="an in-process simulated arm (firmware_sim physics) instead of the "
                        "servos")
    p.add_argument("--json", action="store_true", help="print the result as JSON (SI)")
    p.set_defaults(func=run)


def goal_of(text: str) -> dict:
    """``open``/``close`` → {"command": …}; a number of mm → {"width_m": mm / 1000}."""
    word = text.strip().lower()
    if word in ("open", "close"):
        return {"command": word}
    try:
        width_mm = options.number(word, "COMMAND")
    except InputError:
        raise InputError(f"COMMAND must be open, close or a jaw width in mm, got {text!r}",
                         field="command", value=text) from None
    return {"width_m": width_mm / 1000.0}


def result_line(result) -> str:
    """One line: where the jaws went, where they are, and what they hold."""
    held = (f"an object stopped the jaws at {1e3 * result.final_width_m:.1f} mm, held with "
            f"{result.grip_current_a:.2f} A" if result.blocked else
            f"jaws at {1e3 * result.final_width_m:.1f} mm")
    settled = "" if result.settled else " (still moving when the wait ended)"
    return (f"gripper {result.command} (goal {1e3 * result.goal_width_m:.1f} mm): {held}, "
            f"present current {result.present_current_a:.2f} A{settled}")


def run(args: argparse.Namespace) -> int:
    from robodcn.workflow.gripper import actuate, gripper_goal

    arm = options.load_arm(args)
    if arm.gripper is None:
        raise InputError(f"arm {arm.name!r} has no [gripper] table", field="gripper",
                         value=arm.name)
    goal = goal_of(args.command)
    try:
        gripper_goal(arm.gripper, goal.get("command"), width_m=goal.get("width_m"))
    except InputError as exc:
        if exc.field != "width_m":
            raise
        raise width_error(arm.gripper, args.command) from None
    if args.sim:
        from robodcn.simulated import simulated_arm

        with simulated_arm(arm, timing="fast") as sim:
            result = actuate(sim.bus, arm.gripper, goal.get("command"),
                             width_m=goal.get("width_m"))
    else:
        with open_bus(args, arm) as bus:
            result = actuate(bus, arm.gripper, goal.get("command"),
                             width_m=goal.get("width_m"))
    print(json.dumps(result.to_dict()) if args.json else result_line(result))
    return Exit.DONE if result.settled else Exit.FAULT


def width_error(gripper, typed: str) -> InputError:
    """A jaw width outside the stroke, echoed as typed (millimetres), with the width in
    millimetres when the number looks like metres (``gripper 0.04``)."""
    low, high = sorted((gripper.closed_width * 1e3, gripper.open_width * 1e3))
    value = options.number(typed.strip(), "WIDTH_MM")
    hint = (f"; in metres that is {value * 1e3:g} mm: type {value * 1e3:g}"
            if low <= value * 1e3 <= high else "")
    return InputError(f"WIDTH_MM {typed.strip()} mm is outside the gripper's stroke "
                      f"{low:g}..{high:g} mm{hint}", field="width_m", value=value / 1e3)


__all__ = ["goal_of", "register", "result_line", "run", "width_error"]
