"""``robodcn jog``: interactive teleop on a terminal, every key press a retarget.

Arrow keys step the target pose in x (←/→) and y (↑/↓) by ``--step`` metres, ``a``/``d``
turn θ by ``--step-deg`` (counter-clockwise/clockwise); each press re-plans a screw path
from where the arm is commanded to be, moving or not (:meth:`Execution.retarget`), so
presses in quick succession blend into one motion. The status line shows the target, the
commanded pose and the tracking error. ``q`` or Ctrl-C stops smoothly along the path and
quits; a second Ctrl-C holds at once. On an arm with a base yaw (the OpenMANIPULATOR-X:
poses x, y, z, pitch) the arrows step x and y in the base frame, ``w``/``s`` raise and
lower z by ``--step``, and ``a``/``d`` tilt the pitch up/down by ``--step-deg``; the yaw
follows from x, y. The tool point moves at most 250 mm/s (ISO 10218-1's reduced speed for
hands-on work; ``--tool-speed`` sets another, refused above the arm's ``[tool]``
``max_speed``). ``--sim`` jogs a simulated arm, else the servos on
``--device``. It ends with one summary line (moves, retargets, where the arm was
commanded) and exits 0 after ``q``, 130 after Ctrl-C (as ``sim`` and ``move``), 4 after a
fault.
"""

from __future__ import annotations

import argparse
import math
import sys
import termios
from collections.abc import Callable
from typing import Any

import numpy as np

from robodcn.cli import keys, options, planning
from robodcn.cli.exit_codes import Exit
from robodcn.errors import BusError, InputError, KeepOutError, RobodcnError
from robodcn.workflow.poses import tool_pose

#: key → (dx, dy, dθ) in steps
JOG_KEYS: dict[str, tuple[int, int, int]] = {
    "right": (1, 0, 0), "left": (-1, 0, 0), "up": (0, 1, 0), "down": (0, -1, 0),
    "a": (0, 0, 1), "d": (0, 0, -1),
}
#: key → (dx, dy, dz, dpitch) in steps, on an arm with a base yaw
YAWED_JOG_KEYS: dict[str, tuple[int, int, int, int]] = {
    "right": (1, 0, 0, 0), "left": (-1, 0, 0, 0), "up": (0, 1, 0, 0), "down": (0, -1, 0, 0),
    "w": (0, 0, 1, 0), "s": (0, 0, -1, 0), "a": (0, 0, 0, 1), "d": (0, 0, 0, -1),
}
HELP = "keys: ←/→ x · ↑/↓ y · a/d θ · space pause · q or Ctrl-C stop"
YAWED_HELP = "keys: ←/→ x · ↑/↓ y · w/s z · a/d pitch · space pause · q or Ctrl-C stop"


def jog_keys(arm: Any) -> dict[str, tuple[int, ...]]:
    """The keys that step ``arm``'s pose: x, y, θ, or a yawed arm's x, y, z, pitch."""
    return dict(YAWED_JOG_KEYS) if arm.yawed else dict(JOG_KEYS)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "jog", help="teleoperate the arm from the keyboard (each key a retarget in flight)",
        description="Arrow keys step the target pose in x (left/right) and y (up/down) by "
                    "--step metres, a/d turn theta by --step-deg; on an arm with a base yaw "
                    "(poses x,y,z,pitch, e.g. --arm omx) w/s step z by --step and a/d tilt "
                    "the pitch by --step-deg (the yaw follows x, y); each key press re-plans "
                    "from where the arm is commanded to be, moving or not, so presses in "
                    "quick succession blend into one motion. Shows the target, the commanded "
                    "pose and the tracking error. q or Ctrl-C stops smoothly along the path "
                    "and quits; a second Ctrl-C holds at once. The tool point moves at most "
                    "250 mm/s (--tool-speed). --sim jogs a simulated arm.")
    options.add_arm_option(p)
    g = p.add_argument_group("jog")
    g.add_argument("--step", type=options.positive_float, default=0.01, metavar="M",
                   help="x/y (and z) step per key press, metres (default 0.01)")
    g.add_argument("--step-deg", type=options.positive_float, default=5.0, metavar="DEG",
                   help="θ (or pitch) step per key press, degrees (default 5)")
    g.add_argument("--method", default="sclerp",
                   choices=("sclerp", "kenlerp", "seplerp", "dlb"),
                   help="interpolation of each step (default sclerp)")
    g.add_argument("--rate", type=options.rate, metavar="HZ",
                   help="stream rate (default: the arm's [bus] rate)")
    g.add_argument("--sim", action="store_true",
                   help="jog an in-process simulated arm (firmware_sim) instead of the servos")
    planning.add_payload_option(g)
    planning.add_tool_options(g, hands_on=True)
    g.add_argument("--timing", choices=("realistic", "fast"), default="realistic",
                   help="simulated wire timing with --sim (default realistic)")
    options.add_device_options(p, default_help="default: the arm's [bus] port")
    p.set_defaults(func=run_jog)


class Jogger:
    """The jog loop on an open bus: keys → targets → retargets (or new moves from rest)."""

    def __init__(self, arm: Any, bus: Any, *, step: float, step_rad: float, method: str,
                 rate_hz: float, out: Any = None, payload_kg: float | None = None,
                 tool_speed: float | None = None) -> None:
        from robodcn.present import present_joints
        self.arm, self.bus = arm, bus
        self.keys = jog_keys(arm)
        self.step, self.step_rad, self.method, self.rate_hz = step, step_rad, method, rate_hz
        #: the plan's payload (None: the arm's [dynamics] payload_kg) and tool speed (None:
        #: the arm's [tool] speed; the command gives the reduced speed of hands-on work)
        self.plan_options: dict[str, float] = {} if payload_kg is None \
            else {"payload_kg": payload_kg}
        if tool_speed is not None:
            self.plan_options["tool_speed"] = tool_speed
        self.out = out if out is not None else sys.stderr
        q = present_joints(arm, bus)
        self.target = np.array(tool_pose(arm, q))
        self.execution: Any = None
        self.commanded = self.target.copy()
        self.tracking = 0.0
        self.message = ""
        self.quit = False
        self.reports: list[Any] = []
        #: key presses applied in flight (a retarget of a running move)
        self.retargets = 0
        #: ended by Ctrl-C (exit code 130, as sim and move), not by q
        self.interrupted = False

    # -- motion ---------------------------------------------------------------------------

    def _progress(self, p: Any) -> None:
        from robodcn import servo_units
        q = servo_units.ticks_to_radians(np.array(p.goals), self.arm.servos)
        self.commanded = tool_pose(self.arm, q)
        if p.present is not None:
            lag = np.abs(np.subtract(p.present, p.goals))
            rad = np.array([2 * math.pi / s.ticks_per_turn for s in self.arm.servos])
            self.tracking = float((lag * rad).max())

    def _collect(self) -> None:
        if self.execution is not None and self.execution.done:
            try:
                self.reports.append(self.execution.wait(0))
            finally:
                self.execution = None

    def go(self) -> None:
        """Move to the present target: a retarget while moving, else a new move."""
        from robodcn.present import plan_from_present
        from robodcn.stream import start
        self._collect()
        goal = tuple(float(v) for v in self.target)
        if self.execution is not None:
            try:
                self.execution.retarget([None, goal], method=self.method,
                                        **self.plan_options)
                self.retargets += 1
                return
            except RobodcnError as exc:
                if not self.execution.done:
                    raise
                self.message = exc.message  # it finished meanwhile: start afresh
                self._collect()
        traj = plan_from_present(self.arm, self.bus, [None, goal], method=self.method,
                                 rate_hz=self.rate_hz, **self.plan_options)
        self.execution = start(traj, self.bus, progress=self._progress, arm=self.arm,
                               approach=True)

    def key(self, key: str) -> None:
        """One key press."""
        if key in ("q", "\x03"):
            self.interrupted = self.interrupted or key == "\x03"
            self.stop("smooth")
            return
        if key == " " and self.execution is not None and not self.execution.done:
            self.message = keys.move_key(self.execution, " ") or ""
            return
        delta = self.keys.get(key)
        if delta is None:
            return
        before = self.target.copy()
        scale = np.array([self.step] * (len(delta) - 1) + [self.step_rad])
        self.target = self.target + np.array(delta) * scale
        try:
            self.go()
            self.message = ""
        except RobodcnError as exc:
            self.target = before  # refused: the target stays where the arm can go
            self.message = exc.message
            if isinstance(exc, KeepOutError) and exc.zone is not None:
                # the status line shows 60 characters: the zone first
                self.message = (f"refused: keep-out zone {exc.zone!r}, the {exc.point} "
                                f"{(exc.depth or 0.0) * 1e3:.1f} mm inside")

    def stop(self, mode: str) -> None:
        self.quit = True
        if self.execution is not None and not self.execution.done:
            self.execution.stop(mode, "stopped by the jog keys")

    def _interrupt(self, mode: str) -> None:
        self.interrupted = True
        self.stop(mode)

    def summary(self) -> str:
        """The closing line: moves, retargets, outcomes and where the arm was commanded."""
        outcomes: dict[str, int] = {}
        for report in self.reports:
            if report is not None:
                outcomes[report.outcome] = outcomes.get(report.outcome, 0) + 1
        c = self.commanded
        ended = ", ".join(f"{n} {k}" for k, n in sorted(outcomes.items())) or "no move"
        where = ", ".join(_terms(self.arm, c, metres=" m", width=1))
        return (f"jog: {len(self.reports)} move(s), {self.retargets} retarget(s) in flight "
                f"({ended}); ended at {where}"
                + ("; stopped by Ctrl-C" if self.interrupted else ""))

    def finish(self, timeout: float = 10.0) -> None:
        if self.execution is not None:
            self.execution.wait(timeout)
            self._collect()

    # -- display --------------------------------------------------------------------------

    def status(self) -> str:
        t, c = self.target, self.commanded
        return (f"target {' '.join(_terms(self.arm, t))}  "
                f"commanded {' '.join(_terms(self.arm, c))}  "
                f"tracking {math.degrees(self.tracking):4.2f}°  {self.message[:60]}")

    def show(self) -> None:
        self.out.write("\r\x1b[K" + self.status())
        self.out.flush()

    def run(self, read_key: Callable[[float], str | None], poll: float = 0.05) -> None:
        """Until q/Ctrl-C: read keys (``read_key(timeout)``) and show the status line."""
        ctrl_c = keys.CtrlC(lambda: self._interrupt("smooth"), lambda: self._interrupt("hold"))
        self.out.write((YAWED_HELP if self.arm.yawed else HELP) + "\n")
        with ctrl_c.installed():
            while not self.quit:
                key = read_key(poll)
                if key is not None:
                    self.key(key)
                self.show()
        self.finish()
        self.show()
        self.out.write("\n")


def _terms(arm: Any, pose: Any, *, metres: str = "", width: int = 6) -> list[str]:
    """``x=+0.123`` … for each of the arm's pose keys (the angle in degrees)."""
    names = {"theta": "θ"}
    *lengths, angle = arm.pose_keys
    out = [f"{k}={v:+.3f}{metres}" for k, v in zip(lengths, pose, strict=False)]
    out.append(f"{names.get(angle, angle)}={math.degrees(pose[-1]):+{width}.1f}°")
    return out


def run_jog(args: argparse.Namespace, read_key: Callable[[float], str | None] | None = None
            ) -> int:
    """The command; ``read_key`` replaces the terminal (tests)."""
    arm = options.load_arm(args)
    rate = args.rate or arm.bus.rate_hz
    settings = {"step": args.step, "step_rad": math.radians(args.step_deg),
                "method": args.method, "rate_hz": rate, "payload_kg": args.payload,
                **planning.tool_keywords(args, arm, hands_on=True)}
    if read_key is None and not sys.stdin.isatty():
        raise InputError("jog needs a terminal on stdin (it reads single key presses)",
                         field="stdin", value=None)
    if args.sim:
        from robodcn.simulated import simulated_arm
        with simulated_arm(arm, timing=args.timing) as sim:
            return _jog(Jogger(arm, sim.bus, **settings), read_key)
    from robodcn.bus import ServoBus
    device = args.device if args.device is not None else arm.bus.port
    try:
        with ServoBus(device, args.baud or arm.bus.baud,
                      servos=[j.servo for j in arm.joints]) as bus:
            bus.verify()
            return _jog(Jogger(arm, bus, **settings), read_key)
    except (OSError, termios.error) as exc:
        raise BusError(f"{device}: the serial device failed ({exc}); check the cable and "
                       "the adapter", field="device", value=device) from exc


def _jog(jogger: Jogger, read_key: Callable[[float], str | None] | None) -> int:
    if read_key is not None:
        jogger.run(read_key)
    else:
        with keys.TerminalKeys() as terminal:
            jogger.run(terminal)
    jogger.out.write(jogger.summary() + "\n")
    jogger.out.flush()
    faults = [r for r in jogger.reports if r is not None and r.outcome == "fault"]
    if faults:
        return int(Exit.FAULT)
    return int(Exit.STOPPED if jogger.interrupted else Exit.DONE)
