"""The ``robodcn`` command line: one argparse subparser per subcommand.

Each subcommand is a ``_cmd_<name>(args) -> int`` function registered by a
``_add_<name>(subparsers)`` function; ``main`` turns :class:`robodcn.errors.RobodcnError`
into one ``robodcn: <message>`` line on stderr and the error's exit code.

Subcommands
    plan    print a planned trajectory (table, JSON or CSV); touches no hardware
    move    plan from the arm's present pose and execute it on the servos
    sim     the same as move, against an in-process simulated bus (a dry-run)
    serve   the HTTP trajectory service
    scan    list the servos on a port: id, model, firmware, baud

Poses are ``x,y,θ`` in metres and degrees (``--radians`` for radians). A pose starting
with a minus sign may be given as ``--to=-0.1,0.2,0`` or ``--to -0.1,0.2,0``.

Exit codes: 0 done, 2 bad usage or input, 3 plan infeasible, 4 servo or bus fault,
130 stopped by the user.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import signal
import sys
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from robodcn.errors import InputError, RobodcnError

#: Default arm when neither --arm nor $ROBODCN_ARM is given.
DEFAULT_ARM = Path("configs") / "arm3r.toml"
#: Seconds the final read may wait for the arm to come to rest (a real servo, or the
#: physics sim, is still moving when the last goal goes out).
SETTLE_S = 0.5
EXIT_BY_STOP_REASON = {"completed": 0, "stopped": 130, "comm_failure": 4,
                       "hardware_alert": 4, "tracking_error": 4, "collision": 4}


def _id_list(text: str) -> list[int]:
    """``"1,2,5-8"`` → [1, 2, 5, 6, 7, 8]."""
    ids: list[int] = []
    try:
        for part in filter(None, (p.strip() for p in text.split(","))):
            low, dash, high = part.partition("-")
            ids.extend(range(int(low), int(high) + 1) if dash else [int(low)])
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"ids must look like 1,2,5-8, got {text!r}") from None
    bad = [i for i in ids if not 0 <= i <= 252]
    if bad or not ids:
        raise argparse.ArgumentTypeError(f"ids must be in 0..252, got {text!r}")
    return ids


# -- scan --------------------------------------------------------------------------------------

def _add_scan(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "scan", help="list the servos on a port (id, model, firmware, baud)",
        description="Ping for Dynamixel Protocol 2.0 servos on PORT at each baud rate given. "
                    "Without --ids a broadcast ping is used (about 0.8 s per baud rate).")
    p.add_argument("--port", help="serial device; default: the [bus] port of --config")
    p.add_argument("--config", help="arm TOML whose [bus] gives port and baud")
    p.add_argument("--baud", type=int, action="append",
                   help="baud rate to try (repeatable); default: the config's, else 1000000")
    p.add_argument("--all-bauds", action="store_true",
                   help="try every baud rate the Python SDK can set (9600 .. 4000000)")
    p.add_argument("--ids", type=_id_list, help="ping only these ids, e.g. 1,2,5-8")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=_cmd_scan)


def _cmd_scan(args: argparse.Namespace) -> int:
    from robodcn.bus import BAUD_INDEX, scan

    port, bauds = args.port, args.baud
    if args.config:
        from robodcn.config import load_arm

        arm = load_arm(args.config)
        port = port or arm.bus.port
        bauds = bauds or [arm.bus.baud]
    if not port:
        raise InputError("scan needs --port (or --config with a [bus] port)", field="port")
    if args.all_bauds:
        bauds = sorted(b for b in BAUD_INDEX.values() if b != 4_500_000)
    found = scan(port, bauds or [1_000_000], ids=args.ids)
    if args.json:
        print(json.dumps({"port": port, "servos": [s.to_dict() for s in found]}, indent=2))
        return 0
    if not found:
        print(f"no servos answered on {port} at {', '.join(map(str, bauds or [1_000_000]))} "
              "baud", file=sys.stderr)
        return 1
    print(f"{'ID':>3}  {'model':<12} {'number':>6}  {'firmware':>8}  {'baud':>8}")
    for s in found:
        firmware = "?" if s.firmware is None else str(s.firmware)
        print(f"{s.id:>3}  {s.model or 'unknown':<12} {s.model_number:>6}  {firmware:>8}  "
              f"{s.baud:>8}")
    return 0


# -- shared motion options ----------------------------------------------------------------------

def _add_motion_options(p: argparse.ArgumentParser, *, start_help: str) -> None:
    g = p.add_argument_group("motion")
    g.add_argument("--arm", metavar="FILE",
                   help=f"arm TOML (default: $ROBODCN_ARM, else {DEFAULT_ARM})")
    g.add_argument("--from", dest="start", metavar="X,Y,THETA", help=start_help)
    g.add_argument("--to", dest="end", metavar="X,Y,THETA", required=True,
                   help="goal pose (metres, degrees)")
    g.add_argument("--via", action="append", default=[], metavar="X,Y,THETA",
                   help="via pose, repeatable, in order")
    g.add_argument("--method", default="sclerp", metavar="M[,M...]",
                   help="sclerp | kenlerp | seplerp | dlb, or one per segment (default sclerp)")
    g.add_argument("--beta", type=float, default=1.0,
                   help="KenLERP bias: 0 decoupled, 1 = ScLERP, > 1 amplifies (default 1)")
    g.add_argument("--turn", default="shortest", metavar="T[,T...]",
                   help="shortest | ccw | cw, or one per segment (default shortest)")
    g.add_argument("--duration", default="auto", metavar="SECONDS|auto",
                   help="total duration, or auto: the shortest within the joint limits")
    g.add_argument("--profile", default="quintic", choices=("quintic", "trapezoid", "linear"),
                   help="time law s(t) (default quintic)")
    g.add_argument("--rate", type=float, metavar="HZ",
                   help="sample rate, 1..1000 Hz (default: the arm's [bus] rate_hz)")
    g.add_argument("--blend", action="store_true",
                   help="pass through via poses with continuous velocity instead of stopping")
    g.add_argument("--radians", action="store_true", help="θ in radians, not degrees")


def _load_arm(args: argparse.Namespace):
    from robodcn.config import load_arm

    path = args.arm or os.environ.get("ROBODCN_ARM") or DEFAULT_ARM
    if not Path(path).is_file():
        raise InputError(f"--arm: no such file {str(path)!r} (give --arm FILE or set "
                         "ROBODCN_ARM)", field="arm", value=str(path))
    return load_arm(path)


def parse_pose(text: str, option: str, *, radians: bool = False) -> tuple[float, float, float]:
    """``"x,y,θ"`` → (x, y, θ in radians); InputError naming ``option`` otherwise."""
    parts = [p.strip() for p in str(text).split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise InputError(f"{option} must be a pose x,y,θ (metres, "
                         f"{'radians' if radians else 'degrees'}), got {text!r}",
                         field=option.lstrip("-"), value=text)
    x, y, theta = values
    return x, y, theta if radians else math.radians(theta)


def _split_list(text: str) -> str | list[str]:
    items = [t.strip() for t in text.split(",")]
    return items[0] if len(items) == 1 else items


def _duration(text: str) -> float | str:
    if text == "auto":
        return "auto"
    try:
        return float(text)
    except ValueError:
        raise InputError(f"--duration must be a number of seconds or 'auto', got {text!r}",
                         field="duration", value=text) from None


def _waypoint_options(args: argparse.Namespace) -> list[str]:
    """Which option gave waypoints[i], for error messages."""
    return (["--from"] + [f"--via #{i + 1}" for i in range(len(args.via))] + ["--to"])


def _plan(args: argparse.Namespace, arm, start_pose, start_joints=None):
    """Plan from ``start_pose`` through the --via poses to --to; maps waypoint errors to options."""
    from robodcn.planner import plan

    vias = [parse_pose(v, f"--via #{i + 1}", radians=args.radians)
            for i, v in enumerate(args.via)]
    end = parse_pose(args.end, "--to", radians=args.radians)
    try:
        return plan(arm, [start_pose, *vias, end], method=_split_list(args.method),
                    beta=args.beta, turn=_split_list(args.turn), duration=_duration(args.duration),
                    profile=args.profile,
                    rate_hz=args.rate if args.rate is not None else arm.bus.rate_hz,
                    blend=args.blend, start_joints=start_joints)
    except RobodcnError as exc:
        match = re.match(r"waypoints\[(\d+)\]", exc.field or "")
        if match:
            names = _waypoint_options(args)
            index = int(match.group(1))
            if index < len(names):
                exc.message = f"{exc.message}\n(waypoints[{index}] is {names[index]})"
        raise


def _pose_text(pose: Sequence[float]) -> str:
    return f"x={pose[0]:.4f} m, y={pose[1]:.4f} m, θ={math.degrees(pose[2]):.2f}°"


# -- plan ---------------------------------------------------------------------------------------

def _add_plan(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "plan", help="print a planned trajectory (no hardware)",
        description="Plan a trajectory and print it: a table (t, pose, joints, ticks), the "
                    "Trajectory JSON, or CSV. Nothing is sent to any servo.")
    _add_motion_options(p, start_help="start pose (default: the arm's home pose)")
    p.add_argument("--format", choices=("table", "json", "csv"), default="table")
    p.add_argument("--out", metavar="FILE", help="write to FILE instead of standard output")
    p.set_defaults(func=_cmd_plan)


def _table(traj) -> str:
    names = list(traj.joint_names)
    head = (f"{'t [s]':>8} {'x [m]':>9} {'y [m]':>9} {'θ [°]':>8}  "
            + "  ".join(f"{n[:9] + ' [°]':>13}" for n in names) + "  ticks")
    lines = [f"# {len(traj.t)} samples, {traj.duration:.3f} s at {traj.rate_hz:g} Hz, "
             f"method {traj.method}", head]
    for t, pose, q, ticks in zip(traj.t, traj.poses, traj.joints, traj.ticks, strict=True):
        lines.append(f"{t:8.3f} {pose[0]:9.4f} {pose[1]:9.4f} {math.degrees(pose[2]):8.2f}  "
                     + "  ".join(f"{math.degrees(a):13.3f}" for a in q) + "  "
                     + ",".join(str(int(k)) for k in ticks))
    return "\n".join(lines) + "\n"


def _cmd_plan(args: argparse.Namespace) -> int:
    arm = _load_arm(args)
    start = (parse_pose(args.start, "--from", radians=args.radians) if args.start
             else tuple(arm.home))
    traj = _plan(args, arm, start)
    text = {"table": _table, "json": lambda tr: tr.to_json() + "\n",
            "csv": lambda tr: tr.to_csv()}[args.format](traj)
    if args.out:
        Path(args.out).write_text(text)
        print(f"wrote {len(traj.t)} samples ({traj.duration:.3f} s) to {args.out}",
              file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0


# -- move and sim -------------------------------------------------------------------------------

def _non_negative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be an integer ≥ 0, got {text!r}")
    return value


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


def _add_execution_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("execution")
    g.add_argument("--feedback-every", type=_non_negative_int, default=1, metavar="K",
                   help="read present positions every K samples (0: only at the end; "
                        "default 1)")
    g.add_argument("--tracking-limit", type=_positive_float, default=15.0, metavar="DEG",
                   help="stop when a joint lags its goal by more than DEG degrees (default 15)")
    g.add_argument("--release", action="store_true",
                   help="torque off at the end (default: the servos hold the last pose)")
    g.add_argument("--realtime", action="store_true",
                   help="stream from a real-time (SCHED_FIFO) thread; Linux, needs "
                        "CAP_SYS_NICE or root (warns and carries on otherwise)")
    g.add_argument("--compensation", choices=("on", "off"),
                   help="lead the goals by the servos' position-loop lag so they follow the "
                        "plan (default on; off with sim --dynamics off, whose servos do not "
                        "lag)")
    g.add_argument("--recover", action="store_true",
                   help="on an overload alert reboot that servo and hold it (the move stays "
                        "stopped)")
    g.add_argument("--json", action="store_true", help="print the report as JSON")


def _add_move(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "move", help="plan and execute a move on the servos",
        description="Plan from the arm's present pose (read from the servos) and stream it. "
                    "With --from, a joint-space approach from the present pose to --from is "
                    "planned first. Ctrl-C stops and holds.")
    _add_motion_options(p, start_help="start pose (default: the present pose); the arm "
                                      "approaches it first")
    g = p.add_argument_group("bus")
    g.add_argument("--port", metavar="DEV", help="serial device (default: the arm's [bus] port)")
    g.add_argument("--baud", type=int, help="baud rate (default: the arm's [bus] baud)")
    _add_execution_options(p)
    p.set_defaults(func=_cmd_move)


def _add_sim(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "sim", help="dry-run a move against a simulated servo bus",
        description="The same as move, against an in-process firmware_sim bus (realistic "
                    "wire timing) whose servos start at the arm's home pose. Prints the "
                    "report; --plot draws planned vs measured motion.")
    _add_motion_options(p, start_help="start pose (default: the home pose); the simulated "
                                      "arm approaches it first")
    p.add_argument("--timing", choices=("realistic", "fast"), default="realistic",
                   help="simulated wire timing (default realistic)")
    p.add_argument("--dynamics", choices=("on", "off"), default="on",
                   help="servo physics with the arm's masses (on, default) or the kinematic "
                        "model whose servos reach each goal at once (off)")
    p.add_argument("--plot", metavar="FILE.png",
                   help="draw planned vs measured path and joint angles (needs matplotlib)")
    _add_execution_options(p)
    p.set_defaults(func=_cmd_sim)


@contextmanager
def _ctrl_c_stops(stop) -> Iterator[None]:
    """While executing, SIGINT requests a stop (the streamer then holds) instead of raising."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        stop.request("stopped by Ctrl-C")

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


class _LiveProgress:
    """One self-rewriting status line on a terminal; silent when stderr is not a TTY."""

    def __init__(self, traj, arm, stream=None) -> None:
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty()
        self.total = traj.duration
        self.rad_per_tick = np.array([2 * math.pi / j.servo.ticks_per_turn for j in arm.joints])
        self.samples: list[tuple[float, tuple[int, ...]]] = []  # (elapsed, present ticks)

    def __call__(self, progress) -> None:
        if progress.present is not None:
            self.samples.append((progress.elapsed_s, tuple(progress.present)))
        if not self.enabled:
            return
        fraction = progress.sample / max(1, progress.samples_total - 1)
        error = ""
        if progress.present is not None:
            lag = np.abs(np.subtract(progress.present, progress.goals)) * self.rad_per_tick
            error = f"  tracking {math.degrees(float(lag.max())):5.2f}°"
        bar = "#" * int(20 * fraction)
        self.stream.write(f"\r[{bar:<20}] {100 * fraction:5.1f}%  {progress.elapsed_s:6.2f}/"
                          f"{self.total:.2f} s{error}")
        self.stream.flush()

    def finish(self) -> None:
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()


def _amps(value: float | None) -> str:
    return "off" if value is None else f"{value:.2f} A"


def _report_text(report) -> str:
    r = report.to_dict()
    lines = [f"{r['stop_reason']}: {r['message']}" if r.get("message") else r["stop_reason"],
             f"  samples sent {r['samples_sent']}/{r['samples_total']} in "
             f"{r['duration_s']:.3f} s, rate {r['rate_hz']:g} Hz, achieved "
             f"{r['achieved_rate_hz']:.1f} Hz" + (" (with approach)" if r.get("approach") else "")]
    jitter = {k: v for k, v in r.items() if k.startswith("jitter_")}
    if jitter:
        lines.append("  period jitter " + ", ".join(
            f"{k.removeprefix('jitter_').removesuffix('_s')} {1e3 * v:.3f} ms"
            for k, v in jitter.items()))
    lines.append(f"  overruns {r['overruns']}, skipped {r['samples_skipped']}, retries "
                 f"{r['retries']}, comm failures {r['comm_failures']}, fast read "
                 f"{'yes' if r.get('fast_read') else 'no'}")
    for name, mx, rms, mxt in zip(r["joint_names"], r["tracking_error_max_rad"],
                                  r["tracking_error_rms_rad"], r["tracking_error_max_ticks"],
                                  strict=True):
        lines.append(f"  tracking {name:<10} max {math.degrees(mx):6.3f}° ({mxt} ticks), rms "
                     f"{math.degrees(rms):6.3f}°")
    peaks = r.get("current_peak_a")
    if peaks is not None:
        for j, name in enumerate(r["joint_names"]):
            lines.append(f"  {name:<10} peak {math.degrees(r['velocity_peak_rad_s'][j]):6.1f}°/s,"
                         f" current {peaks[j]:.2f} A (limit {r['current_limit_a'][j]:.2f} A, "
                         f"predicted {r['predicted_current_peak_a'][j]:.2f} A, collision "
                         f"stop {_amps(r['collision_threshold_a'][j])})")
    for near in r.get("near_limits", []):
        lines.append(f"  near limit: {near['joint']} {near['quantity']} peak "
                     f"{near['peak']:.3g} of {near['limit']:.3g} (from t {near['time_s']:.3f} s)")
    if r.get("collision"):
        c = r["collision"]
        lines.append(f"  collision at {c['joint']}: {c['current_a']:.2f} A at sample "
                     f"{c['sample']} (t {c['time_s']:.3f} s)")
    for rec in r.get("recovered", []):
        lines.append(f"  overload recovery of servo {rec['servo_id']}: "
                     f"{'rebooted and holding' if rec.get('recovered') else rec.get('error')}")
    if r.get("final_error_ticks") is not None:
        lines.append(f"  final error (ticks) {list(r['final_error_ticks'])}")
    if r.get("hardware_errors"):
        lines.append(f"  hardware errors {r['hardware_errors']}")
    return "\n".join(lines)


def _compensation(args: argparse.Namespace) -> bool:
    if args.compensation is not None:
        return args.compensation == "on"
    return getattr(args, "dynamics", "on") == "on"


def _execute(args: argparse.Namespace, arm, bus) -> tuple[Any, Any, _LiveProgress]:
    """Read the present pose, plan from it, stream; returns (trajectory, report, progress)."""
    from robodcn import kinematics, servo_units
    from robodcn.stream import StopSignal, execute

    present = servo_units.ticks_to_radians(bus.read_positions()[None, :],
                                           [j.servo for j in arm.joints])[0]
    if args.start:
        start = parse_pose(args.start, "--from", radians=args.radians)
    else:
        start = tuple(kinematics.fk(arm.links, present[None, :])[0])
    traj = _plan(args, arm, start, start_joints=present)
    stop = StopSignal()
    live = _LiveProgress(traj, arm)
    with _ctrl_c_stops(stop):
        try:
            report = execute(traj, bus, feedback_every=args.feedback_every,
                             tracking_limit=math.radians(args.tracking_limit), stop=stop,
                             progress=live, release=args.release, realtime=args.realtime,
                             compensation=_compensation(args), recover=args.recover,
                             settle=SETTLE_S)
        finally:
            live.finish()
    return traj, report, live


def _finish(args: argparse.Namespace, report) -> int:
    if args.json:
        print(json.dumps(report.to_dict(), indent=2))
    else:
        print(_report_text(report))
    return EXIT_BY_STOP_REASON.get(report.stop_reason, 4)


def _cmd_move(args: argparse.Namespace) -> int:
    from robodcn.bus import ServoBus

    arm = _load_arm(args)
    port = args.port or arm.bus.port
    with ServoBus(port, args.baud or arm.bus.baud, servos=[j.servo for j in arm.joints]) as bus:
        bus.verify()
        _, report, _ = _execute(args, arm, bus)
    return _finish(args, report)


def _cmd_sim(args: argparse.Namespace) -> int:
    from robodcn.simulated import simulated_arm

    arm = _load_arm(args)
    if args.plot:
        _require_matplotlib()
    with simulated_arm(arm, timing=args.timing, dynamics=args.dynamics == "on") as sim:
        traj, report, live = _execute(args, arm, sim.bus)
    code = _finish(args, report)
    if args.plot:
        _plot(args.plot, arm, traj, live.samples, report.near_limits)
        print(f"plot: {args.plot}")
    return code


def _require_matplotlib() -> None:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise InputError("--plot needs matplotlib: pip install 'robodcn[plot]'",
                         field="plot") from None


def _plot(path: str, arm, traj, samples: list[tuple[float, tuple[int, ...]]],
          near: list[dict] | tuple = ()) -> None:
    """Planned vs measured end-effector path (left) and joint angles over time (right);
    ``near`` (report ``near_limits``) marks where a limit came within 10 %."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from robodcn import kinematics, servo_units

    fig, (ax_path, ax_joints) = plt.subplots(1, 2, figsize=(12, 5))
    ax_path.plot(traj.poses[:, 0], traj.poses[:, 1], "-", color="tab:blue", label="planned")
    if samples:
        t_meas = np.array([s[0] for s in samples])
        q_meas = servo_units.ticks_to_radians(np.array([s[1] for s in samples]),
                                              [j.servo for j in arm.joints])
        p_meas = kinematics.fk(arm.links, q_meas)
        ax_path.plot(p_meas[:, 0], p_meas[:, 1], ".", color="tab:orange", ms=3,
                     label="measured")
    ax_path.set(xlabel="x [m]", ylabel="y [m]", title="end-effector path", aspect="equal")
    ax_path.legend()
    for k, name in enumerate(traj.joint_names):
        line, = ax_joints.plot(traj.t, np.degrees(traj.joints[:, k]), label=f"{name} planned")
        if samples:
            ax_joints.plot(t_meas, np.degrees(q_meas[:, k]), ".", ms=3, color=line.get_color(),
                           label=f"{name} measured")
    for k, mark in enumerate(near):
        i = min(int(mark["sample"]), len(traj.t) - 1)
        j = list(traj.joint_names).index(mark["joint"])
        label = "limit within 10 %" if k == 0 else None
        ax_joints.plot(traj.t[i], np.degrees(traj.joints[i, j]), "x", color="tab:red", ms=9,
                       label=label)
        ax_joints.annotate(mark["quantity"], (traj.t[i], np.degrees(traj.joints[i, j])),
                           fontsize="x-small", color="tab:red")
        ax_path.plot(traj.poses[i, 0], traj.poses[i, 1], "x", color="tab:red", ms=9,
                     label=label)
    if near:
        ax_path.legend()
    ax_joints.set(xlabel="t [s]", ylabel="angle [°]", title="joint angles")
    ax_joints.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# -- serve --------------------------------------------------------------------------------------

def _add_serve(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "serve", help="run the HTTP trajectory service",
        description="Serve the HTTP API (GET /openapi.json lists it). Binds 127.0.0.1 by "
                    "default; any other address needs --token (or ROBODCN_TOKEN), and every "
                    "POST must then carry 'Authorization: Bearer TOKEN'.")
    p.add_argument("--arm", metavar="FILE",
                   help=f"arm TOML (default: $ROBODCN_ARM, else {DEFAULT_ARM})")
    p.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=8080, help="TCP port (default 8080; 0 = any)")
    p.add_argument("--token", default=os.environ.get("ROBODCN_TOKEN"),
                   help="bearer token for POST requests (default: $ROBODCN_TOKEN)")
    target = p.add_mutually_exclusive_group()
    target.add_argument("--sim", action="store_true", help="serve a simulated arm")
    target.add_argument("--device", metavar="DEV",
                        help="servo serial device (default: the arm's [bus] port)")
    p.add_argument("--baud", type=int, help="baud rate (default: the arm's [bus] baud)")
    p.set_defaults(func=_cmd_serve)


def _cmd_serve(args: argparse.Namespace) -> int:
    from robodcn.http_server import serve

    arm = _load_arm(args)
    serve(arm, host=args.host, port=args.port, token=args.token, sim=args.sim,
          device=args.device, baud=args.baud,
          ready=lambda url: print(f"robodcn: serving {arm.name!r} on {url}", flush=True))
    return 0


# -- entry point -------------------------------------------------------------------------------

def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="robodcn", description="Plan planar rigid motions with dual complex numbers and "
                                    "stream them to Dynamixel servos.")
    parser.add_argument("--version", action="version", version=f"robodcn {_version()}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in (_add_plan, _add_move, _add_sim, _add_serve, _add_scan):
        add(subparsers)
    # Poses such as -0.1,0.2,0 are values, not options.
    for action in subparsers.choices.values():
        action._negative_number_matcher = _NEGATIVE_POSE
    parser._negative_number_matcher = _NEGATIVE_POSE
    return parser


_NEGATIVE_POSE = re.compile(r"^-\.?\d[\d.,eE+\-]*$")


def _version() -> str:
    from robodcn import __version__

    return __version__


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 ok, RobodcnError.exit_code on error)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except RobodcnError as exc:
        print(f"robodcn: {exc.message}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("robodcn: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
