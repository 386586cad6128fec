"""Servo administration: ``robodcn pose``, ``torque``, ``reboot`` and ``servo info | set-id |
set-baud`` over :mod:`robodcn.workflow.admin`; the tables and lines printed are made here.

``pose``, ``torque`` and ``servo info`` warn (one line per servo, on stderr) when a servo
answers as another model than the config's, and carry on: they are how one finds out.
"""

from __future__ import annotations

import argparse
import json
import math
import time

from robodcn.cli import options, releasing
from robodcn.cli.dialogue import confirm, say
from robodcn.cli.exit_codes import Exit
from robodcn.cli.report_text import pose_text
from robodcn.cli.servo_session import (
    add_bus_options,
    baud_of,
    check_models,
    device_of,
    open_bus,
    warn_models,
)
from robodcn.config import Arm
from robodcn.errors import InputError, StoppedError


def register(subparsers: argparse._SubParsersAction) -> None:
    for add in (_add_pose, _add_torque, _add_reboot, _add_servo):
        add(subparsers)


# -- pose ----------------------------------------------------------------------------------------

def _add_pose(sub) -> None:
    p = sub.add_parser("pose", help="print the present joints, ticks and pose",
                       description="Read every servo's Present Position and print the joint "
                                   "angles (degrees), ticks and the tool pose (FK).")
    options.add_arm_option(p)
    add_bus_options(p)
    p.add_argument("--watch", action="store_true", help="refresh until Ctrl-C")
    p.add_argument("--interval", type=options.positive_float, default=0.5, metavar="SECONDS",
                   help="refresh period with --watch (default 0.5 s)")
    p.add_argument("--count", type=options.positive_int, metavar="N",
                   help="with --watch: stop after N")
    p.add_argument("--json", action="store_true", help="one JSON object (SI) per reading")
    p.set_defaults(func=run_pose)


def pose_line(arm: Arm, state) -> str:
    """One reading: the pose (m, °; x, y, z, pitch on a yawed arm), the joints (°) and the
    ticks."""
    joints = ", ".join(f"{n} {math.degrees(q):8.2f}°" for n, q in
                       zip(arm.joint_names, state.joints, strict=True))
    jaws = "" if getattr(state, "gripper", None) is None else (
        f"  |  gripper {1e3 * state.gripper.width_m:.1f} mm"
        + (", holding an object" if state.gripper.holding else ""))
    return (f"{pose_text(arm.pose_keys, state.pose)}  |  {joints}  |  ticks "
            + ",".join(str(int(t)) for t in state.ticks) + jaws)


def run_pose(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import present_state

    arm = options.load_arm(args)
    with open_bus(args, arm) as bus:
        check_models(bus, arm)
        n = 0
        try:
            while True:
                state = present_state(bus, arm)
                print(json.dumps(state.to_dict(arm)) if args.json else pose_line(arm, state),
                      flush=True)
                n += 1
                if not args.watch or (args.count is not None and n >= args.count):
                    return Exit.DONE
                time.sleep(args.interval)
        except KeyboardInterrupt:
            return Exit.DONE     # the way out of --watch


# -- torque, reboot ------------------------------------------------------------------------------

def _add_torque(sub) -> None:
    p = sub.add_parser("torque", help="switch servo torque on or off",
                       description="Torque Enable on or off, on every joint or one (--joint). "
                                   "Off releases the arm: an arm under gravity falls, so "
                                   "off on a joint gravity loads needs --yes there (exit 2 "
                                   "without it, nothing changes) and first lowers the arm "
                                   "to its [arm.rest] pose (where it cannot, hold it). On "
                                   "holds the present position.")
    p.add_argument("state", choices=("on", "off"), help="on or off")
    p.add_argument("--joint", metavar="NAME", help="only this joint (default: every joint)")
    releasing.add_yes_option(p, what="torque off")
    options.add_arm_option(p)
    add_bus_options(p)
    p.set_defaults(func=run_torque)


def run_torque(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import joint_ids, set_torque

    arm = options.load_arm(args)
    ids = joint_ids(arm, args.joint)
    with open_bus(args, arm) as bus:
        check_models(bus, arm)
        if args.state == "on":
            set_torque(bus, arm, True, args.joint)
            print(f"torque on: servo(s) {', '.join(map(str, ids))}")
            return Exit.DONE
        result = releasing.guarded(args, arm, bus, ids=ids, verify=False,   # models: warned
                                   switch_off=lambda: set_torque(bus, arm, False, args.joint))
    print(releasing.release_line(result).removeprefix("robodcn: "))
    return Exit.DONE if result.released else Exit.FAULT


def _add_reboot(sub) -> None:
    p = sub.add_parser("reboot", help="reboot servos (clears a hardware error)",
                       description="REBOOT every servo or one joint's (--joint) and wait until "
                                   "it answers. Clears Hardware Error Status (overload, "
                                   "overheating); the servo comes back with torque off, so "
                                   "on an arm under gravity it needs --yes (exit 2 without "
                                   "it, nothing changes) and first lowers the arm to its "
                                   "[arm.rest] pose.")
    p.add_argument("--joint", metavar="NAME", help="only this joint (default: every joint)")
    releasing.add_yes_option(p, what="the reboot")
    options.add_arm_option(p)
    add_bus_options(p)
    p.set_defaults(func=run_reboot)


def run_reboot(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import joint_ids, reboot

    arm = options.load_arm(args)
    ids = joint_ids(arm, args.joint)
    with open_bus(args, arm) as bus:
        result = releasing.guarded(args, arm, bus, ids=ids, what="reboot", verify=False,
                                   switch_off=lambda: reboot(bus, arm, args.joint))
    if not result.released:
        say(releasing.release_line(result, "reboot"))
        return Exit.FAULT
    lowered = ", the arm lowered to its rest pose first" if result.lowered else ""
    print(f"rebooted servo(s) {', '.join(map(str, ids))} (torque is off{lowered})")
    return Exit.DONE


def _guard_servos(args: argparse.Namespace, arm: Arm, ids, what: str) -> None:
    """The gravity guard before ``servo set-id``/``set-baud`` switch torque off on ``ids``
    (:func:`robodcn.cli.releasing.guarded` on the arm's bus, closed again before the
    change). When the arm's servos cannot all be read, a joint of ``ids`` on an arm under
    gravity still needs --yes, and the user holds the arm."""
    from robodcn.errors import BusError
    from robodcn.workflow.release import ReleaseCheck, refusal

    joints = tuple(j.name for j in arm.chain_joints if j.servo.id in ids)
    if not joints or not releasing.falls(arm):
        return
    try:
        with open_bus(args, arm) as bus:
            releasing.guarded(args, arm, bus, ids=ids, what=what, verify=False)
        return
    except BusError as exc:
        hold = f"the arm's servos cannot be read ({exc.message})"
    if not args.yes:
        check = ReleaseCheck(arm.name, True, joints, arm.joint_names, None, arm.rest)
        raise releasing.asks(refusal(check, what=what, hold=hold))
    releasing.warning(f"{what} may let arm {arm.name!r} fall under gravity and it cannot "
                      f"be lowered first ({hold}): hold it")


# -- servo ---------------------------------------------------------------------------------------

def _add_servo(sub) -> None:
    p = sub.add_parser("servo", help="servo info, set-id, set-baud",
                       description="Servo administration on --device.")
    ssub = p.add_subparsers(dest="servo_command", metavar="ACTION", required=True)
    info = ssub.add_parser("info", help="model, firmware, id, baud, mode, errors, voltage, "
                                        "temperature of the arm's servos",
                           description="Ping and read every servo of the arm.")
    options.add_arm_option(info)
    add_bus_options(info)
    info.add_argument("--json", action="store_true", help="print JSON")
    info.set_defaults(func=run_servo_info)
    sid = ssub.add_parser("set-id", help="change a servo's id",
                          description="Give the servo at id OLD the id NEW. Refused when no "
                                      "servo answers at OLD or NEW is taken. Only that servo "
                                      "is touched (torque off, then the EEPROM ID item).")
    sid.add_argument("old", type=options.servo_id, metavar="OLD", help="present id")
    sid.add_argument("new", type=options.servo_id, metavar="NEW", help="new id, 0..252, free")
    options.add_arm_option(sid)
    add_bus_options(sid)
    sid.add_argument("--yes", action="store_true", help="do not ask for confirmation (also "
                     "confirms torque off on a joint under gravity: the arm is lowered to "
                     "its [arm.rest] pose first)")
    sid.set_defaults(func=run_servo_set_id)
    sb = ssub.add_parser("set-baud", help="change the baud rate of the arm's servos",
                         description="Switch every servo of the arm from --baud to BAUD. "
                                     "Refused when a servo with one of the arm's ids already "
                                     "answers at BAUD. Update [bus] baud in the arm TOML after.")
    sb.add_argument("new_baud", type=options.baud, metavar="BAUD", help="new baud rate")
    options.add_arm_option(sb)
    add_bus_options(sb)
    sb.add_argument("--yes", action="store_true", help="do not ask for confirmation (also "
                    "confirms torque off on an arm under gravity: it is lowered to its "
                    "[arm.rest] pose first)")
    sb.set_defaults(func=run_servo_set_baud)


def servo_table(arm: Arm, rows: list[dict]) -> str:
    """:func:`robodcn.workflow.admin.servo_info`'s rows as a table, one line per servo."""
    names = dict(zip(arm.servo_ids, arm.joint_names, strict=True))
    lines = [f"{'ID':>3} {'joint':<10} {'model':<11} {'fw':>3} {'baud':>8} {'mode':<18} "
             f"{'torque':<6} {'volt':>5} {'temp':>5}  errors"]
    for r in rows:
        if not r["answered"]:
            lines.append(f"{r['id']:>3} {names[r['id']]:<10} no answer")
            continue
        lines.append(f"{r['id']:>3} {names[r['id']]:<10} {r['model'] or r['model_number']!s:<11} "
                     f"{r['firmware']:>3} {r['baud']:>8} {r['operating_mode_name']:<18} "
                     f"{'on' if r['torque'] else 'off':<6} {r['voltage_v']:5.1f} "
                     f"{r['temperature_c']:4d}°  {r['hardware_error_names'] or 'none'}")
    return "\n".join(lines)


def run_servo_info(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import model_mismatches, servo_info

    arm = options.load_arm(args)
    with open_bus(args, arm) as bus:
        rows = servo_info(bus)
    warn_models(model_mismatches(arm, {r["id"]: r["model_number"] for r in rows
                                       if r["answered"]}))
    if args.json:
        print(json.dumps({"device": device_of(args, arm), "servos": rows}, indent=2))
    else:
        print(servo_table(arm, rows))
    return Exit.DONE if all(r["answered"] for r in rows) else Exit.FAULT


def run_servo_set_id(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import set_id

    arm = options.load_arm(args)
    if args.old == args.new:
        raise InputError(f"NEW must differ from OLD, both are {args.old}", field="new",
                         value=args.new)
    device, baud = device_of(args, arm), baud_of(args, arm)
    _guard_servos(args, arm, (args.old,), f"servo set-id {args.old} {args.new}")
    if not confirm(f"change servo id {args.old} to {args.new} on {device}?", yes=args.yes):
        raise StoppedError("not changed", field="yes")
    set_id(device, baud, args.old, args.new)
    print(f"servo {args.old} is now id {args.new}")
    return Exit.DONE


def run_servo_set_baud(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import set_baud

    arm = options.load_arm(args)
    device, baud = device_of(args, arm), baud_of(args, arm)
    if args.new_baud == baud:
        raise InputError(f"BAUD {baud} is the present baud rate already", field="baud",
                         value=baud)
    _guard_servos(args, arm, arm.servo_ids, f"servo set-baud {args.new_baud}")
    if not confirm(f"switch servo(s) {list(arm.servo_ids)} on {device} from {baud} to "
                   f"{args.new_baud} baud?", yes=args.yes):
        raise StoppedError("not changed", field="yes")
    set_baud(device, baud, args.new_baud, arm.servo_ids)
    print(f"servo(s) {', '.join(map(str, arm.servo_ids))} now at {args.new_baud} baud; set "
          f"[bus] baud = {args.new_baud} in the arm TOML")
    return Exit.DONE
