"""``robodcn move`` (the servos) and ``robodcn sim`` (an in-process simulated bus).

Both check every option and output path, read the present pose, plan from it (a
joint-space approach first when --from is elsewhere), stream, print the report and exit
with the outcome's code: 0 done (in position), 5 completed with samples skipped or out of
position, 4 fault or collision, 130 stopped.
:func:`stream` and :func:`finish` are the execute / report / plot path every command that
moves the arm shares (``robodcn run`` too).
"""

from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import termios
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from robodcn.cli import keys, options, planning, releasing
from robodcn.cli.exit_codes import exit_for_report
from robodcn.cli.output import emit
from robodcn.cli.report_text import approach_seconds, report_dict, report_text, tool_line
from robodcn.errors import BusError

#: Seconds the final read may wait for the arm to come to rest (a real servo, or the
#: physics sim, is still moving when the last goal goes out).
SETTLE_S = 0.5


def add_execution_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("execution")
    g.add_argument("--feedback-every", type=options.non_negative_int, default=1, metavar="K",
                   help="read present positions every K samples (0: only at the end; "
                        "default 1)")
    g.add_argument("--tracking-limit", type=options.positive_float, default=15.0,
                   metavar="DEG",
                   help="stop when a joint lags its goal by more than DEG degrees (default 15)")
    g.add_argument("--release", action="store_true",
                   help="torque off at the end (default: the servos hold the last pose); "
                        "an arm under gravity falls, so it needs --yes and is lowered to "
                        "its [arm.rest] pose first")
    releasing.add_yes_option(g, what="--release")
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
    add_plot_option(g)


def add_plot_option(g) -> None:
    g.add_argument("--plot", metavar="FILE.png",
                   help="draw the planned motion (arm poses, waypoints, approach), the "
                        "measured path and joint velocity/acceleration against the limits; "
                        "after a run also each joint's tracking error and current against "
                        "theirs, marking where a limit came within 10 %% (needs matplotlib)")


def check_plot(path: str | None) -> None:
    """--plot's file checked (and matplotlib present) before anything is planned or moved."""
    if path is not None:
        from robodcn.plots import require_matplotlib

        require_matplotlib()
        options.check_plot_path(path)


def plot(path: str | None, arm, traj, *, samples=(), report=None, waypoints=None) -> None:
    """--plot: :func:`robodcn.plots.plot_motion` of ``traj`` with the measured ``samples``,
    the report's trace (tracking error and current panels) and, when the run did not
    complete, where it stopped."""
    if path is None:
        return
    from robodcn.plots import plot_motion

    stop = None if report is None or report.stop_reason == "completed" else {
        "t": report.duration_s, "reason": report.stop_reason}
    near = () if report is None else report.near_limits
    plot_motion(path, arm, traj, samples=list(samples), stop=stop, waypoints=waypoints,
                near_limits=near, trace=None if report is None else report.trace)
    print(f"plot: {path}", file=sys.stderr, flush=True)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "move", help="plan and execute a move on the servos",
        description="Plan from the arm's present pose (read from the servos) and stream it. "
                    "With --from, a joint-space approach from the present pose to --from is "
                    "planned first. Ctrl-C stops and holds. Exit code 5: completed with "
                    "samples skipped, or the arm came to rest out of position.")
    planning.add_motion_options(p, start_help="start pose (default: the present pose); the "
                                              "arm approaches it first")
    options.add_device_options(p, default_help="default: the arm's [bus] port")
    add_execution_options(p)
    p.set_defaults(func=run_move)

    p = subparsers.add_parser(
        "sim", help="dry-run a move against a simulated servo bus",
        description="The same as move, against an in-process firmware_sim bus (realistic "
                    "wire timing) whose servos start at the arm's home pose and, by default, "
                    "follow the servo physics driving the arm's masses. Prints the report "
                    "(tracking error, peak velocity and current per joint, where a limit "
                    "came within 10 %); --plot draws planned vs measured motion, tracking error "
                    "and current.")
    planning.add_motion_options(p, start_help="start pose (default: the home pose); the "
                                              "simulated arm approaches it first")
    p.add_argument("--timing", choices=("realistic", "fast"), default="realistic",
                   help="simulated wire timing (default realistic)")
    p.add_argument("--dynamics", choices=("on", "off"), default="on",
                   help="servo physics with the arm's masses (on, default: the report shows "
                        "the lag and currents to expect) or the kinematic model whose servos "
                        "reach each goal at once (off)")
    p.add_argument("--sim-payload", type=options.non_negative_float, metavar="KG",
                   help="the mass (kg) the simulated arm carries at its tool point, whatever "
                        "--payload declares: a load the plan misdeclares (default: the "
                        "payload the move declares, so the dry run predicts the arm "
                        "carrying it)")
    add_execution_options(p)
    p.set_defaults(func=run_sim)


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
        self.samples: list[tuple[float, tuple[int, ...]]] = []  # (elapsed, present ticks)

    def __call__(self, progress) -> None:
        if progress.present is not None:
            self.samples.append((progress.elapsed_s, tuple(progress.present)))
        if not self.enabled:
            return
        fraction = progress.sample / max(1, progress.samples_total - 1)
        error = ""
        if progress.tracking_error_rad is not None:   # the report's definition
            error = f"  tracking {math.degrees(max(progress.tracking_error_rad)):5.2f}°"
        bar = "#" * int(20 * fraction)
        self.stream.write(f"\r[{bar:<20}] {100 * fraction:5.1f}%  {progress.elapsed_s:6.2f}/"
                          f"{self.total:.2f} s{error}")
        self.stream.flush()

    def finish(self) -> None:
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()


def compensation(args: argparse.Namespace) -> bool:
    """--compensation as given; by default on, except against kinematic simulated servos
    (``sim --dynamics off``), which reach each goal at once and need no lead."""
    if getattr(args, "compensation", None) is not None:
        return args.compensation == "on"
    return getattr(args, "dynamics", "on") == "on"


def stream(args: argparse.Namespace, traj, arm, bus) -> tuple[Any, _LiveProgress]:
    """Stream ``traj`` with the execution options (Ctrl-C stops and holds; the final read
    waits up to :data:`SETTLE_S` for the arm to come to rest); returns (report, the live
    progress with the measured samples)."""
    from robodcn.stream import StopSignal, execute

    stop = StopSignal()
    live = _LiveProgress(traj, arm)
    if keys.interactive():
        return _execute_with_keys(args, traj, arm, bus, stop, live), live
    with _ctrl_c_stops(stop):
        try:
            report = execute(traj, bus, feedback_every=args.feedback_every,
                             tracking_limit=math.radians(args.tracking_limit), stop=stop,
                             progress=live, release=releasing.release_in_stream(args, arm),
                             realtime=args.realtime, compensation=compensation(args),
                             recover=args.recover, settle=SETTLE_S)
        finally:
            live.finish()
    return report, live


def stream_and_release(args: argparse.Namespace, traj, arm, bus
                       ) -> tuple[Any, _LiveProgress, Any]:
    """:func:`stream`, with ``--release`` on an arm under gravity confirmed (``--yes``,
    else GravityReleaseError before anything moves) and done after the move by lowering it
    to its rest pose (:mod:`robodcn.cli.releasing`); returns (report, live, the
    ReleaseResult or None)."""
    gravity_release = bool(getattr(args, "release", False)) and releasing.falls(arm)
    if gravity_release:
        releasing.confirm_release(arm, traj.joints[-1], args.yes)
    report, live = stream(args, traj, arm, bus)
    released = None
    if gravity_release:
        released = releasing.release_after_move(bus, arm, report)
    return report, live, released


def _execute_with_keys(args: argparse.Namespace, traj, arm, bus, stop, live):
    """On a terminal: the move keys (robodcn.cli.keys.MOVE_KEYS) while it streams."""
    from robodcn.stream import start

    sys.stderr.write(f"keys: {keys.MOVE_KEYS}\n")
    execution = start(traj, bus, feedback_every=args.feedback_every,
                      tracking_limit=math.radians(args.tracking_limit), stop=stop,
                      progress=live, release=releasing.release_in_stream(args, arm),
                      realtime=args.realtime, compensation=compensation(args),
                      recover=args.recover, settle=SETTLE_S, arm=arm)
    try:
        with keys.TerminalKeys() as terminal:
            keys.drive(execution, terminal,
                       on_action=lambda what: sys.stderr.write(f"\n{what}\n"))
        return execution.wait()
    finally:
        if not execution.done:
            execution.stop("hold")
            execution.wait(5)
        live.finish()


def finish(args: argparse.Namespace, arm, traj, report, live: _LiveProgress, *,
           waypoints=None, released=None) -> int:
    """Print the report (text or --json; ``released``: what ``--release`` did on an arm
    under gravity, as the JSON's ``release``), draw --plot, return the outcome's exit
    code."""
    from robodcn.planner.tool_peak import tool_peak

    approach = approach_seconds(report, traj)
    request = getattr(traj, "request", None)
    # a plan under a tool limit: its peak tool speed and where the limit binds
    tool = tool_peak(traj).to_dict() if request is not None and request.tool_limited \
        else None
    if args.json:
        data = report_dict(report, approach)
        if released is not None:
            data["release"] = released.to_dict()
            data["released"] = released.released
        if tool is not None:
            data["tool"] = tool
        emit(json.dumps(data, indent=2) + "\n")
    else:
        text = report_text(report, approach)
        if tool is not None:
            text += "\n" + tool_line(tool, getattr(traj, "pose_keys", None))
        emit(text + "\n")
    plot(args.plot, arm, traj, samples=live.samples, report=report, waypoints=waypoints)
    return exit_for_report(report)


def run_move(args: argparse.Namespace) -> int:
    from robodcn.bus import ServoBus, lower_latency_timer

    check_plot(args.plot)
    arm = options.load_arm(args)
    request = planning.motion_request(args, arm)
    device = args.device if args.device is not None else arm.bus.port
    note = lower_latency_timer(device).message(device)
    if note:
        print(f"robodcn: {note}", file=sys.stderr, flush=True)
    try:
        with ServoBus(device, args.baud or arm.bus.baud,
                      servos=[j.servo for j in arm.joints]) as bus:
            traj = planning.plan_from_present(request, arm, bus)   # verifies the servos
            report, live, released = stream_and_release(args, traj, arm, bus)
    except (OSError, termios.error) as exc:
        # The device went away under the SDK (unplugged, simulator killed): a bus fault.
        raise BusError(f"{device}: the serial device failed ({_os_reason(exc)}); check the "
                       "cable and the adapter, then run the move again", field="device",
                       value=device) from exc
    return finish(args, arm, traj, report, live, released=released)


def _os_reason(exc: BaseException) -> str:
    return getattr(exc, "strerror", None) or str(exc) or type(exc).__name__


def run_sim(args: argparse.Namespace) -> int:
    from robodcn.simulated import simulated_arm

    check_plot(args.plot)
    arm = options.load_arm(args)
    request = planning.motion_request(args, arm)
    with simulated_arm(arm, timing=args.timing, dynamics=args.dynamics == "on",
                       carried_kg=args.sim_payload) as sim:
        traj = planning.plan_from_present(request, arm, sim.bus)
        sim.carry(traj.request.payload_kg if traj.request is not None else None)
        report, live, released = stream_and_release(args, traj, arm, sim.bus)
        report = sim.reported(report, traj)
    return finish(args, arm, traj, report, live, released=released)
