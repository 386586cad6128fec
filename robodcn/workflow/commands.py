"""The workflow subcommands of ``robodcn``: calibrate, teach, run, pose, torque, reboot,
servo info / set-id / set-baud, check-config and config example.

:func:`register` adds them to the CLI's subparsers. Every command that talks to servos takes
``--device`` (serial port), ``--baud`` and ``--arm`` (a TOML file or an example name:
``arm3r``, ``arm2r``). Exit codes as the rest of the CLI (:mod:`robodcn.cli.exit_codes`): 0
done, 2 bad usage or input, 3 infeasible, 4 servo or bus fault, 5 completed with samples
skipped, 130 stopped by the user. Arguments, input files and
output paths are checked before the bus is opened. Prompts go to stderr and answers come
from stdin, one line each, so every dialogue can be scripted.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from robodcn.cli import motion_cmd, options
from robodcn.config import BAUD_RATES, Arm, load_arm
from robodcn.errors import InputError, RobodcnError, StoppedError
from robodcn.workflow.examples import EXAMPLES, example_text, resolve_arm_path

# -- argument types and shared options -------------------------------------------------------------

def _baud(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value not in BAUD_RATES or value == 4_500_000:
        raise argparse.ArgumentTypeError(
            f"must be one of {', '.join(str(b) for b in BAUD_RATES if b != 4_500_000)}, got "
            f"{text!r}")
    return value


def _servo_id(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= 252:
        raise argparse.ArgumentTypeError(f"must be a servo id 0..252, got {text!r}")
    return value


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer ≥ 1, got {text!r}")
    return value


def _rate(text: str) -> float:
    value = _positive(text)
    if not 1.0 <= value <= 1000.0:
        raise argparse.ArgumentTypeError(f"must be within 1..1000 Hz, got {text!r}")
    return value


def _add_bus(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("bus")
    g.add_argument("--device", metavar="DEV",
                   help="serial device of the servos (default: the arm's [bus] port)")
    g.add_argument("--baud", type=_baud, help="baud rate (default: the arm's [bus] baud)")


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def stdin_prompt(message: str) -> str:
    """Show ``message`` on stderr and read one line from stdin (EOFError at its end)."""
    sys.stderr.write(f"{message}: ")
    sys.stderr.flush()
    line = sys.stdin.readline()
    if not line:
        sys.stderr.write("\n")
        raise EOFError
    return line.rstrip("\r\n")


def _confirm(args: argparse.Namespace, question: str) -> bool:
    if getattr(args, "yes", False):
        return True
    try:
        return stdin_prompt(f"{question} [y/N]").strip().lower() in ("y", "yes")
    except EOFError:
        return False


def check_output_path(path: str, option: str, force: bool) -> Path:
    """An output path that may be written: its directory exists, and it does not exist
    unless ``force``."""
    out = Path(path)
    if out.exists() and not force:
        raise InputError(f"{option}: {path!r} exists; pass --force to overwrite it",
                         field=option.lstrip("-"), value=path)
    if out.is_dir():
        raise InputError(f"{option}: {path!r} is a directory", field=option.lstrip("-"),
                         value=path)
    if not out.resolve().parent.is_dir():
        raise InputError(f"{option}: directory {str(out.parent)!r} does not exist",
                         field=option.lstrip("-"), value=path)
    return out


def open_bus(args: argparse.Namespace, arm: Arm):
    """A ServoBus on ``--device`` (or the arm's port) at ``--baud`` (or the arm's), opened.

    Sets the USB latency timer to 1 ms first when its sysfs file is writable, and says so.
    """
    from robodcn.bus import ServoBus, lower_latency_timer

    device = args.device or arm.bus.port
    note = lower_latency_timer(device).message(device)
    if note:
        _say(f"robodcn: {note}")
    return ServoBus(device, args.baud or arm.bus.baud, servos=arm.servos, retries=3).open()


# -- calibrate ----------------------------------------------------------------------------------

def _add_calibrate(sub) -> None:
    p = sub.add_parser(
        "calibrate", help="find zero offsets, directions and ranges by moving the arm by hand",
        description="Torque off; put the arm in its reference pose (every joint angle 0) and "
                    "press Enter: each servo's tick becomes its zero_offset. Then, per joint, "
                    "turn it in its positive direction (sets direction) and, unless "
                    "--no-ranges, through its whole range (sets min_tick/max_tick with "
                    "--margin and the joint limits inside them). Writes --out, a copy of the "
                    "arm TOML with its comments and layout kept, after showing a diff. Answers "
                    "are read from stdin, one line per prompt.")
    options.add_arm_option(p)
    _add_bus(p)
    p.add_argument("--out", required=True, metavar="NEW.toml", help="calibrated arm TOML")
    p.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    p.add_argument("--yes", action="store_true", help="write without asking")
    p.add_argument("--no-ranges", dest="ranges", action="store_false",
                   help="skip the whole-range step (keep tick ranges and joint limits)")
    p.add_argument("--margin", type=_positive, default=2.0, metavar="DEG",
                   help="tick range this far inside the range moved through (default 2°)")
    p.set_defaults(func=cmd_calibrate)


def cmd_calibrate(args: argparse.Namespace) -> int:
    from robodcn.workflow.calibrate import calibrate, diff, updated_toml

    source = resolve_arm_path(args.arm)
    arm = options.load_arm(args)
    out = check_output_path(args.out, "--out", args.force)
    text = source.read_text(encoding="utf-8")
    with open_bus(args, arm) as bus:
        result = calibrate(bus, arm, stdin_prompt, ranges=args.ranges, margin_deg=args.margin)
    new = updated_toml(text, result, source=str(out))
    for note in result.notes:
        _say(f"note: {note}")
    changes = diff(text, new, str(source), str(out))
    sys.stdout.write(changes or f"no changes to {source}\n")
    sys.stdout.flush()
    if not _confirm(args, f"write {out}?"):
        raise StoppedError(f"{out} not written", field="out", value=str(out))
    out.write_text(new, encoding="utf-8")
    _say(f"wrote {out} (torque stays off)")
    return 0


# -- teach --------------------------------------------------------------------------------------

def _add_teach(sub) -> None:
    p = sub.add_parser(
        "teach", help="record waypoints by moving the arm by hand",
        description="Torque off; each Enter records the present pose (FK of the present "
                    "joints) as a waypoint, 'u' undoes the last one, 'q' (or end of input) "
                    "finishes and writes the waypoints file for 'robodcn run'.")
    options.add_arm_option(p)
    _add_bus(p)
    p.add_argument("--out", required=True, metavar="POSES.toml", help="waypoints file")
    p.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    p.add_argument("--method", metavar="M[,M...]",
                   help="sclerp | kenlerp | seplerp | dlb, or one per segment, for the file")
    p.add_argument("--turn", metavar="T[,T...]", help="shortest | ccw | cw, or one per segment")
    p.add_argument("--beta", type=float, help="KenLERP bias for the file's [plan]")
    p.set_defaults(func=cmd_teach)


def _split(text: str | None, option: str, allowed: tuple[str, ...]) -> str | list[str] | None:
    if text is None:
        return None
    items = [t.strip() for t in text.split(",")]
    for item in items:
        if item not in allowed:
            raise InputError(f"{option}: {item!r} is not one of {', '.join(allowed)}",
                             field=option.lstrip("-"), value=text)
    return items[0] if len(items) == 1 else items


def cmd_teach(args: argparse.Namespace) -> int:
    from robodcn.dcn import TURNS
    from robodcn.interpolate import METHODS
    from robodcn.workflow.teach import teach, waypoints_toml

    arm = options.load_arm(args)
    out = check_output_path(args.out, "--out", args.force)
    method = _split(args.method, "--method", METHODS)
    turn = _split(args.turn, "--turn", TURNS)
    if args.beta is not None and not math.isfinite(args.beta):
        raise InputError(f"--beta must be finite, got {args.beta}", field="beta",
                         value=args.beta)
    with open_bus(args, arm) as bus:
        poses = teach(bus, arm, stdin_prompt, say=_say)
    if len(poses) < 2:
        raise InputError(f"recorded {len(poses)} waypoint(s), a motion needs at least 2; "
                         f"{out} not written", field="waypoints", value=len(poses))
    for option, value in (("--method", method), ("--turn", turn)):
        if isinstance(value, list) and len(value) != len(poses) - 1:
            raise InputError(f"{option} lists {len(value)} values for {len(poses) - 1} "
                             f"segments; {out} not written", field=option.lstrip("-"),
                             value=value)
    out.write_text(waypoints_toml(poses, arm_name=arm.name, method=method, turn=turn,
                                  beta=args.beta), encoding="utf-8")
    _say(f"wrote {len(poses)} waypoints to {out}")
    return 0


# -- run ----------------------------------------------------------------------------------------

def _add_run(sub) -> None:
    p = sub.add_parser(
        "run", help="play a waypoints file, a saved Trajectory JSON or a JointTrajectory JSON",
        description="FILE is a waypoints TOML (robodcn teach), a Trajectory JSON (robodcn plan "
                    "--format json) or a JointTrajectory JSON (ROS trajectory_msgs shape: "
                    "joint_names, points with positions, optional velocities/accelerations, "
                    "time_from_start {sec, nanosec}), resampled at the stream rate. Everything "
                    "is checked against the arm's limits before anything moves; the arm "
                    "approaches the first pose from where it is. Ctrl-C stops and holds.")
    p.add_argument("file", metavar="FILE", help="waypoints .toml, Trajectory or "
                                                "JointTrajectory .json")
    options.add_arm_option(p)
    _add_bus(p)
    p.add_argument("--sim", action="store_true",
                   help="run against an in-process simulated bus (servos start at home)")
    g = p.add_argument_group("plan (waypoints files; override the file's [plan])")
    g.add_argument("--method", metavar="M[,M...]", help="sclerp | kenlerp | seplerp | dlb")
    g.add_argument("--beta", type=options.finite_floats, metavar="B[,B...]",
                   help="KenLERP bias, or one per segment")
    g.add_argument("--turn", metavar="T[,T...]", help="shortest | ccw | cw")
    g.add_argument("--duration", metavar="SECONDS|auto", help="total duration or auto")
    g.add_argument("--profile", choices=("quintic", "trapezoid", "linear"), help="time law")
    g.add_argument("--blend", action="store_true", default=None,
                   help="pass through via poses without stopping")
    g.add_argument("--rate", type=_rate, metavar="HZ",
                   help="stream rate, 1..1000 Hz (default: the file's, else the arm's)")
    motion_cmd.add_execution_options(p)
    p.set_defaults(func=cmd_run)


def _duration(text: str | None) -> float | str | None:
    if text is None or text == "auto":
        return text
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"--duration must be a positive number of seconds or 'auto', got "
                         f"{text!r}", field="duration", value=text)
    return value


@contextlib.contextmanager
def _naming_file(path: str) -> Iterator[None]:
    """Prefix a planner error (which names waypoints[i]) with the waypoints file."""
    try:
        yield
    except RobodcnError as exc:
        if not exc.message.startswith(path):
            exc.message = f"{path}: {exc.message}"
        raise


def load_run_file(args: argparse.Namespace, arm: Arm) -> tuple[str, Any]:
    """("waypoints", PlanRequest fields) or (kind, Trajectory), checked before any bus I/O."""
    from robodcn.dcn import TURNS
    from robodcn.interpolate import METHODS
    from robodcn.planner import PlanRequest, plan_request
    from robodcn.workflow import files

    kind, text = files.file_kind(args.file)
    if kind == "waypoints":
        wp = files.load_waypoints(args.file)
        beta = args.beta[0] if args.beta is not None and len(args.beta) == 1 else args.beta
        fields = wp.plan_fields(method=_split(args.method, "--method", METHODS),
                                turn=_split(args.turn, "--turn", TURNS), beta=beta,
                                duration=_duration(args.duration), profile=args.profile,
                                blend=args.blend, rate_hz=args.rate)
        fields.setdefault("rate_hz", arm.bus.rate_hz)
        segments = len(wp.waypoints) - 1
        for key in ("method", "turn", "beta"):
            if isinstance(fields.get(key), list):
                if len(fields[key]) != segments:
                    raise InputError(f"--{key} lists {len(fields[key])} values for the "
                                     f"{segments} segments of {args.file}", field=key,
                                     value=fields[key])
                fields[key] = tuple(fields[key])
        # Every field, and the path through the waypoints, checked before the bus opens (the
        # real plan starts from the present joints, with an approach).
        with _naming_file(args.file):
            plan_request(PlanRequest(arm=arm, **fields))
        return kind, fields
    plan_options = {"--method": args.method, "--beta": args.beta, "--turn": args.turn,
                    "--duration": args.duration, "--profile": args.profile,
                    "--blend": args.blend}
    given = [k for k, v in plan_options.items() if v is not None]
    if given:
        raise InputError(f"{given[0]} applies to waypoints files; {args.file} is already a "
                         "timed trajectory", field=given[0].lstrip("-"), value=args.file)
    if kind == "trajectory":
        traj = files.load_trajectory(args.file, arm, text=text)
        if args.rate is not None and args.rate != traj.rate_hz:
            raise InputError(f"--rate {args.rate:g}: {args.file} was planned at "
                             f"{traj.rate_hz:g} Hz; plan it again for another rate",
                             field="rate", value=args.rate)
        return kind, traj
    rate = args.rate if args.rate is not None else arm.bus.rate_hz
    return kind, files.load_joint_trajectory(args.file, arm, rate, text=text)


def plan_run(args: argparse.Namespace, arm: Arm, bus, kind: str, loaded: Any):
    """The trajectory ``run`` streams: a waypoints file planned from the present joints, or
    a saved trajectory as saved after a joint-space approach to its first sample."""
    from robodcn.present import plan_from_present, present_joints
    from robodcn.workflow.files import with_approach

    present = present_joints(arm, bus)     # a bus error is not the file's
    if kind == "waypoints":
        fields = dict(loaded)
        with _naming_file(args.file):
            return plan_from_present(arm, None, fields.pop("waypoints"), joints=present,
                                     **fields)
    return with_approach(loaded, arm, present)


def cmd_run(args: argparse.Namespace) -> int:
    """Plan (or load), stream, report and plot through the path ``move`` uses
    (:func:`robodcn.cli.motion_cmd.stream` and :func:`~robodcn.cli.motion_cmd.finish`)."""
    arm = options.load_arm(args)
    motion_cmd.check_plot(args.plot)
    kind, loaded = load_run_file(args, arm)
    if args.sim:
        from robodcn.simulated import simulated_arm

        with simulated_arm(arm, timing="fast") as sim:
            traj = plan_run(args, arm, sim.bus, kind, loaded)
            report, live = motion_cmd.stream(args, traj, arm, sim.bus)
    else:
        with open_bus(args, arm) as bus:
            traj = plan_run(args, arm, bus, kind, loaded)
            report, live = motion_cmd.stream(args, traj, arm, bus)
    return motion_cmd.finish(args, arm, traj, report, live,
                             waypoints=loaded["waypoints"] if kind == "waypoints" else None)


# -- pose, torque, reboot -------------------------------------------------------------------------

def _add_pose(sub) -> None:
    p = sub.add_parser("pose", help="print the present joints, ticks and pose",
                       description="Read every servo's Present Position and print the joint "
                                   "angles (degrees), ticks and the tool pose (FK).")
    options.add_arm_option(p)
    _add_bus(p)
    p.add_argument("--watch", action="store_true", help="refresh until Ctrl-C")
    p.add_argument("--interval", type=_positive, default=0.5, metavar="SECONDS",
                   help="refresh period with --watch (default 0.5 s)")
    p.add_argument("--count", type=_count, metavar="N", help="with --watch: stop after N")
    p.add_argument("--json", action="store_true", help="one JSON object (SI) per reading")
    p.set_defaults(func=cmd_pose)


def _pose_line(arm: Arm, state) -> str:
    joints = ", ".join(f"{n} {math.degrees(q):8.2f}°" for n, q in
                       zip(arm.joint_names, state.joints, strict=True))
    x, y, theta = state.pose
    return (f"x={x:.4f} m, y={y:.4f} m, θ={math.degrees(theta):.2f}°  |  {joints}  |  ticks "
            + ",".join(str(int(t)) for t in state.ticks))


def cmd_pose(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import present_state

    arm = options.load_arm(args)
    with open_bus(args, arm) as bus:
        n = 0
        try:
            while True:
                state = present_state(bus, arm)
                print(json.dumps(state.to_dict(arm)) if args.json else _pose_line(arm, state),
                      flush=True)
                n += 1
                if not args.watch or (args.count is not None and n >= args.count):
                    return 0
                time.sleep(args.interval)
        except KeyboardInterrupt:
            return 0     # the way out of --watch


def _add_torque(sub) -> None:
    p = sub.add_parser("torque", help="switch servo torque on or off",
                       description="Torque Enable on or off, on every joint or one (--joint). "
                                   "Off releases the arm: it may fall. On holds the present "
                                   "position.")
    p.add_argument("state", choices=("on", "off"), help="on or off")
    p.add_argument("--joint", metavar="NAME", help="only this joint (default: every joint)")
    options.add_arm_option(p)
    _add_bus(p)
    p.set_defaults(func=cmd_torque)


def cmd_torque(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import joint_ids, set_torque

    arm = options.load_arm(args)
    ids = joint_ids(arm, args.joint)
    with open_bus(args, arm) as bus:
        set_torque(bus, arm, args.state == "on", args.joint)
    print(f"torque {args.state}: servo(s) {', '.join(map(str, ids))}")
    return 0


def _add_reboot(sub) -> None:
    p = sub.add_parser("reboot", help="reboot servos (clears a hardware error)",
                       description="REBOOT every servo or one joint's (--joint) and wait until "
                                   "it answers. Clears Hardware Error Status (overload, "
                                   "overheating); the servo comes back with torque off.")
    p.add_argument("--joint", metavar="NAME", help="only this joint (default: every joint)")
    options.add_arm_option(p)
    _add_bus(p)
    p.set_defaults(func=cmd_reboot)


def cmd_reboot(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import joint_ids, reboot

    arm = options.load_arm(args)
    joint_ids(arm, args.joint)
    with open_bus(args, arm) as bus:
        ids = reboot(bus, arm, args.joint)
    print(f"rebooted servo(s) {', '.join(map(str, ids))} (torque is off)")
    return 0


# -- servo --------------------------------------------------------------------------------------

def _add_servo(sub) -> None:
    p = sub.add_parser("servo", help="servo info, set-id, set-baud",
                       description="Servo administration on --device.")
    ssub = p.add_subparsers(dest="servo_command", metavar="ACTION", required=True)
    info = ssub.add_parser("info", help="model, firmware, id, baud, mode, errors, voltage, "
                                        "temperature of the arm's servos",
                           description="Ping and read every servo of the arm.")
    options.add_arm_option(info)
    _add_bus(info)
    info.add_argument("--json", action="store_true", help="print JSON")
    info.set_defaults(func=cmd_servo_info)
    sid = ssub.add_parser("set-id", help="change a servo's id",
                          description="Give the servo at id OLD the id NEW. Refused when no "
                                      "servo answers at OLD or NEW is taken. Only that servo "
                                      "is touched (torque off, then the EEPROM ID item).")
    sid.add_argument("old", type=_servo_id, metavar="OLD", help="present id")
    sid.add_argument("new", type=_servo_id, metavar="NEW", help="new id, 0..252, free")
    options.add_arm_option(sid)
    _add_bus(sid)
    sid.add_argument("--yes", action="store_true", help="do not ask for confirmation")
    sid.set_defaults(func=cmd_servo_set_id)
    sb = ssub.add_parser("set-baud", help="change the baud rate of the arm's servos",
                         description="Switch every servo of the arm from --baud to BAUD. "
                                     "Refused when a servo with one of the arm's ids already "
                                     "answers at BAUD. Update [bus] baud in the arm TOML after.")
    sb.add_argument("new_baud", type=_baud, metavar="BAUD", help="new baud rate")
    options.add_arm_option(sb)
    _add_bus(sb)
    sb.add_argument("--yes", action="store_true", help="do not ask for confirmation")
    sb.set_defaults(func=cmd_servo_set_baud)


def cmd_servo_info(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import servo_info

    arm = options.load_arm(args)
    with open_bus(args, arm) as bus:
        rows = servo_info(bus)
    if args.json:
        print(json.dumps({"device": args.device or arm.bus.port, "servos": rows}, indent=2))
        return 0 if all(r["answered"] for r in rows) else 4
    names = dict(zip(arm.servo_ids, arm.joint_names, strict=True))
    print(f"{'ID':>3} {'joint':<10} {'model':<11} {'fw':>3} {'baud':>8} {'mode':<18} "
          f"{'torque':<6} {'volt':>5} {'temp':>5}  errors")
    for r in rows:
        if not r["answered"]:
            print(f"{r['id']:>3} {names[r['id']]:<10} no answer")
            continue
        print(f"{r['id']:>3} {names[r['id']]:<10} {r['model'] or r['model_number']!s:<11} "
              f"{r['firmware']:>3} {r['baud']:>8} {r['operating_mode_name']:<18} "
              f"{'on' if r['torque'] else 'off':<6} {r['voltage_v']:5.1f} "
              f"{r['temperature_c']:4d}°  {r['hardware_error_names'] or 'none'}")
    return 0 if all(r["answered"] for r in rows) else 4


def cmd_servo_set_id(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import set_id

    arm = options.load_arm(args)
    if args.old == args.new:
        raise InputError(f"NEW must differ from OLD, both are {args.old}", field="new",
                         value=args.new)
    device, baud = args.device or arm.bus.port, args.baud or arm.bus.baud
    if not _confirm(args, f"change servo id {args.old} to {args.new} on {device}?"):
        raise StoppedError("not changed", field="yes")
    set_id(device, baud, args.old, args.new)
    print(f"servo {args.old} is now id {args.new}")
    return 0


def cmd_servo_set_baud(args: argparse.Namespace) -> int:
    from robodcn.workflow.admin import set_baud

    arm = options.load_arm(args)
    device, baud = args.device or arm.bus.port, args.baud or arm.bus.baud
    if args.new_baud == baud:
        raise InputError(f"BAUD {baud} is the present baud rate already", field="baud",
                         value=baud)
    if not _confirm(args, f"switch servo(s) {list(arm.servo_ids)} on {device} from {baud} to "
                          f"{args.new_baud} baud?"):
        raise StoppedError("not changed", field="yes")
    set_baud(device, baud, args.new_baud, arm.servo_ids)
    print(f"servo(s) {', '.join(map(str, arm.servo_ids))} now at {args.new_baud} baud; set "
          f"[bus] baud = {args.new_baud} in the arm TOML")
    return 0


# -- check-config and config example --------------------------------------------------------------

def _add_check(sub) -> None:
    p = sub.add_parser("check-config", help="validate an arm TOML and summarise it",
                       description="Validate FILE (or an example name) and print links, reach, "
                                   "joint and tick ranges in degrees, the servo map and the "
                                   "bus. --plot draws the reachable workspace.")
    p.add_argument("file", metavar="FILE", help="arm TOML file or example name")
    p.add_argument("--plot", metavar="FILE.png", help="draw the workspace (needs matplotlib)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON (SI)")
    p.set_defaults(func=cmd_check)


def cmd_check(args: argparse.Namespace) -> int:
    from robodcn.workflow.check import summary, summary_text, workspace_samples

    motion_cmd.check_plot(args.plot)
    arm = load_arm(resolve_arm_path(args.file, option="FILE"))
    print(json.dumps(summary(arm), indent=2) if args.json else summary_text(arm))
    if args.plot:
        from robodcn.plots import plot_workspace

        plot_workspace(args.plot, arm, workspace_samples(arm))
        _say(f"plot: {args.plot}")
    return 0


def _add_config(sub) -> None:
    p = sub.add_parser("config", help="example arm configs",
                       description="robodcn config example [arm3r|arm2r] > my.toml writes an "
                                   "example arm to edit.")
    csub = p.add_subparsers(dest="config_command", metavar="ACTION", required=True)
    ex = csub.add_parser("example", help="print an example arm TOML",
                         description="Print a packaged example arm: " + "; ".join(
                             f"{k}: {v}" for k, v in EXAMPLES.items()))
    ex.add_argument("name", nargs="?", default="arm3r", choices=tuple(EXAMPLES),
                    help="which example (default arm3r)")
    ex.set_defaults(func=cmd_config_example)


def cmd_config_example(args: argparse.Namespace) -> int:
    sys.stdout.write(example_text(args.name))
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the workflow subcommands to the ``robodcn`` parser's subparsers."""
    for add in (_add_calibrate, _add_teach, _add_run, _add_pose, _add_torque, _add_reboot,
                _add_servo, _add_check, _add_config):
        add(subparsers)


__all__ = ["check_output_path", "load_run_file", "open_bus", "register", "stdin_prompt"]
