"""``robodcn follow``: stream targets from stdin, one JSON object a line, at the pace they come.

Each line is a target as ``PUT /v1/follow/target`` takes it: ``{"joints": [rad…]}`` or
``{"pose": [the arm's pose axes, m and rad]}``, optionally with ``"velocity"`` (rad/s per
joint). The arm heads for the newest from where it is commanded to be, tracking a steady
stream one target period behind (:func:`robodcn.stream.follow`). A bad line — not JSON, a
field the session does not take, a joint beyond its limits, a pose out of reach — is one
stderr line naming its line number and field, and the arm goes on to the previous target.
End of input: the arm comes to rest at the last target, exit 0. Ctrl-C: a smooth stop,
exit 130 (a second one holds at once). The closing summary counts the targets taken and
refused. ``--sim`` follows on a simulated arm, else on the servos at ``--device``.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any, TextIO

from robodcn.cli import options
from robodcn.cli.exit_codes import Exit, exit_for_report
from robodcn.errors import BusError, InputError, KeepOutError, RobodcnError
from robodcn.stream.following import SPACES

#: the keys a target line may carry
FIELDS = ("joints", "pose", "velocity")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "follow", help="stream targets to the arm, one JSON line each from stdin",
        description="Reads one JSON target a line from stdin ({\"joints\": [...]} or "
                    "{\"pose\": [...]}, optional \"velocity\"), at the pace the lines come, "
                    "and moves the arm toward the newest within its limits. EOF: rest at "
                    "the last target, exit 0; Ctrl-C: smooth stop, exit 130; a bad line: "
                    "one stderr line naming its number and field, the arm goes on.")
    options.add_arm_option(p)
    g = p.add_argument_group("follow")
    g.add_argument("--space", choices=SPACES, default="joints",
                   help="targets are joint angles in radians or poses (default joints)")
    g.add_argument("--timeout", type=options.positive_float, metavar="S",
                   help="deadman: no target for S seconds while moving stops smoothly")
    g.add_argument("--rate", type=options.rate, metavar="HZ",
                   help="stream rate (default: the arm's [bus] rate)")
    g.add_argument("--payload", type=options.positive_float, metavar="KG",
                   help="payload the torque limits carry (default: the arm's)")
    g.add_argument("--compensation", choices=("on", "off"),
                   help="tracking compensation: lead each goal like a planned move's "
                        "(default on; off with --sim --dynamics off)")
    g.add_argument("--sim", action="store_true",
                   help="follow on an in-process simulated arm (firmware_sim)")
    g.add_argument("--timing", choices=("realistic", "fast"), default="realistic",
                   help="simulated wire timing with --sim (default realistic)")
    g.add_argument("--dynamics", choices=("on", "off"), default="on",
                   help="with --sim: the servo physics (on) or kinematic servos that reach "
                        "each goal at once (off)")
    options.add_device_options(p, default_help="default: the arm's [bus] port")
    p.set_defaults(func=run_follow)


def parse_line(text: str) -> dict[str, Any]:
    """One target line as keywords of :meth:`Follower.target`; InputError naming the
    field (``line`` when it is not a JSON object)."""
    try:
        body = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"not JSON: {exc.msg} at column {exc.colno}", field="line",
                         value=text[:80]) from None
    if not isinstance(body, dict):
        raise InputError("a target is a JSON object: {\"joints\": [...]} or "
                         "{\"pose\": [...]}", field="line", value=text[:80])
    for name in body:
        if name not in FIELDS:
            raise InputError(f"unknown field (known: {', '.join(FIELDS)})", field=name,
                             value=None)
    return body


class Feeder:
    """Targets from ``lines`` to ``follower``, each refusal one line on ``err``."""

    def __init__(self, follower: Any, err: TextIO) -> None:
        self.follower = follower
        self.err = err
        self.interrupted = False
        #: lines refused before they were a target (not JSON, an unknown field)
        self.unparsed = 0

    def feed(self, lines: Any) -> None:
        for number, text in enumerate(lines, start=1):
            if not text.strip():
                continue
            try:
                target = parse_line(text)
            except InputError as exc:
                self.unparsed += 1
                self._refused(number, exc)
                continue
            try:
                self.follower.target(**target)
            except (InputError, KeepOutError) as exc:   # the arm goes on to the last target
                self._refused(number, exc)
            if self.follower.done:
                return

    def _refused(self, number: int, exc: InputError | KeepOutError) -> None:
        self.err.write(f"robodcn: line {number}: {exc.field}: {exc.message}\n")
        self.err.flush()

    def summary(self, report: Any) -> str:
        f = self.follower
        ended = "stopped by Ctrl-C" if self.interrupted else (
            report.headline if report is not None else f.status)
        return (f"follow: {f.taken} target(s) taken, {f.refused + self.unparsed} refused; "
                f"{ended}")


def _compensation(args: argparse.Namespace) -> bool:
    """--compensation as given; by default on, but against kinematic simulated servos
    (``--sim --dynamics off``), which reach each goal at once."""
    if args.compensation is not None:
        return args.compensation == "on"
    return not (args.sim and args.dynamics == "off")


def run_follow(args: argparse.Namespace, stdin: TextIO | None = None,
               err: TextIO | None = None) -> int:
    """The command; ``stdin``/``err`` replace the process's (tests)."""
    arm = options.load_arm(args)
    settings = {"space": args.space, "timeout_s": args.timeout, "rate_hz": args.rate,
                "payload_kg": args.payload, "compensation": _compensation(args)}
    source = stdin if stdin is not None else sys.stdin
    out = err if err is not None else sys.stderr
    if args.sim:
        from robodcn.simulated import simulated_arm
        with simulated_arm(arm, timing=args.timing, dynamics=args.dynamics == "on") as sim:
            return _follow(arm, sim.bus, settings, source, out)
    from robodcn.bus import ServoBus
    device = args.device if args.device is not None else arm.bus.port
    try:
        with ServoBus(device, args.baud or arm.bus.baud,
                      servos=[j.servo for j in arm.joints]) as bus:
            bus.verify()
            return _follow(arm, bus, settings, source, out)
    except OSError as exc:
        raise BusError(f"{device}: the serial device failed ({exc}); check the cable and "
                       "the adapter", field="device", value=device) from exc


def _follow(arm: Any, bus: Any, settings: dict[str, Any], source: TextIO, out: TextIO) -> int:
    from robodcn.stream import follow

    follower = follow(bus, arm, **settings)
    out.write(f"follow: {arm.name} follows {settings['space']} targets at "
              f"{follower.rate_hz:g} Hz, one JSON object a line (EOF ends, Ctrl-C stops)\n")
    out.flush()
    feeder = Feeder(follower, out)
    report = None
    try:
        try:
            feeder.feed(source)
            if not follower.done:
                follower.end()
        except KeyboardInterrupt:
            feeder.interrupted = True
            if not follower.done:
                follower.stop("smooth", "Ctrl-C")
        report = follower.wait()
    except KeyboardInterrupt:           # a second Ctrl-C: hold at once
        follower.stop("hold", "Ctrl-C twice")
        report = follower.wait()
    except RobodcnError:
        if not follower.done:
            follower.stop("hold", "the session failed")
        raise
    out.write(feeder.summary(report) + "\n")
    out.flush()
    if feeder.interrupted:
        return int(Exit.STOPPED)
    return int(exit_for_report(report)) if report is not None else int(Exit.FAULT)
