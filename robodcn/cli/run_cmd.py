"""``robodcn run FILE``: play a waypoints file, a saved Trajectory JSON or a JointTrajectory
JSON through the path ``move`` uses (:func:`robodcn.cli.motion_cmd.stream` and
:func:`~robodcn.cli.motion_cmd.finish`).

The file and every option are checked before the bus opens (:func:`load_run_file`); the
plan options take the same types and choices as ``plan``'s (:mod:`robodcn.contract`) and
override a waypoints file's ``[plan]``.

A waypoints file whose waypoints act (``gripper``, ``payload_kg``) plays leg by leg
(:func:`robodcn.workflow.run.legs`): each leg is planned from where the arm is with its
payload, streamed, the arm comes to rest, the gripper acts (:mod:`robodcn.workflow.gripper`)
and the next leg starts; a leg that does not complete, or jaws that do not come to rest,
end the run there. The report is each leg's (``--json``: the last leg's fields and
``legs``; ``--plot FILE.png`` draws one ``FILE-legN.png`` a leg).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from robodcn import contract
from robodcn.cli import motion_cmd, options, planning
from robodcn.cli.dialogue import say
from robodcn.cli.exit_codes import Exit, exit_for_report
from robodcn.cli.output import emit
from robodcn.cli.servo_session import add_bus_options, open_bus
from robodcn.config import Arm
from robodcn.errors import InputError

#: The plan options of ``run`` → the PlanOverrides field each sets.
PLAN_OPTIONS = {"--method": "method", "--beta": "beta", "--turn": "turn",
                "--duration": "duration", "--profile": "profile", "--blend": "blend",
                "--payload": "payload"}


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
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
    add_bus_options(p)
    p.add_argument("--sim", action="store_true",
                   help="run against an in-process simulated bus (servos start at home)")
    g = p.add_argument_group("plan (waypoints files; override the file's [plan])")
    g.add_argument("--method", metavar="M[,M...]",
                   help="sclerp | kenlerp | seplerp | dlb, or one per segment")
    g.add_argument("--beta", type=options.finite_floats, metavar="B[,B...]",
                   help="KenLERP bias, or one per segment")
    g.add_argument("--turn", metavar="T[,T...]", help="shortest | ccw | cw, or one per segment")
    g.add_argument("--duration", type=options.duration, metavar="SECONDS|auto",
                   help="total duration or auto")
    profile = contract.field("profile")
    g.add_argument("--profile", choices=contract.cli_choices("profile"),
                   help=f"time law (default: the file's, else {profile.default})")
    g.add_argument("--blend", action="store_true", default=None,
                   help="pass through via poses without stopping")
    g.add_argument("--rate", type=options.rate, metavar="HZ",
                   help="stream rate, 1..1000 Hz (default: the file's, else the arm's)")
    planning.add_payload_option(g)
    motion_cmd.add_execution_options(p)
    p.set_defaults(func=run)


def _per_segment(values: list[Any] | None, option: str, segments: int, path: str) -> Any:
    """One value (for every segment) or a tuple of one per segment of the file."""
    if values is None:
        return None
    if len(values) == 1:
        return values[0]
    if len(values) != segments:
        raise InputError(f"{option} lists {len(values)} values for the {segments} segments of "
                         f"{path}", field=option.lstrip("-"), value=values)
    return tuple(values)


def _choices(text: str | None, option: str, name: str) -> list[str] | None:
    if text is None:
        return None
    return options.choice_list(text, option, contract.cli_choices(name))


def overrides(args: argparse.Namespace, segments: int):
    """The plan options as a :class:`robodcn.workflow.run.PlanOverrides` for a file of
    ``segments`` segments."""
    from robodcn.workflow.run import PlanOverrides

    return PlanOverrides(
        method=_per_segment(_choices(args.method, "--method", "method"), "--method", segments,
                            args.file),
        turn=_per_segment(_choices(args.turn, "--turn", "turn"), "--turn", segments,
                          args.file),
        beta=_per_segment(args.beta, "--beta", segments, args.file),
        duration=args.duration, profile=args.profile, blend=args.blend, rate_hz=args.rate,
        payload_kg=args.payload)


def load_run_file(args: argparse.Namespace, arm: Arm) -> tuple[str, Any]:
    """("waypoints", PlanRequest fields) or (kind, Trajectory), checked before any bus I/O."""
    from robodcn.workflow import files
    from robodcn.workflow.run import waypoints_fields

    kind, text = files.file_kind(args.file)
    if kind == "waypoints":
        wp = files.load_waypoints(args.file, arm)
        return kind, waypoints_fields(wp, arm, overrides(args, len(wp.waypoints) - 1))
    given = [option for option, dest in PLAN_OPTIONS.items()
             if getattr(args, dest) is not None]
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
    """The trajectory ``run`` streams, from the present joints read on ``bus``
    (:func:`robodcn.workflow.run.trajectory_to_run`)."""
    from robodcn.present import present_joints
    from robodcn.workflow.run import trajectory_to_run

    present = present_joints(arm, bus)     # a bus error is not the file's
    return trajectory_to_run(arm, kind, loaded, present, source=args.file)


def run(args: argparse.Namespace) -> int:
    arm = options.load_arm(args)
    motion_cmd.check_plot(args.plot)
    kind, loaded = load_run_file(args, arm)
    if kind == "waypoints":
        from robodcn.workflow import files
        from robodcn.workflow.run import legs

        wp = files.load_waypoints(args.file, arm)
        if wp.has_actions:
            return run_legs(args, arm, legs(wp, loaded, arm))
    if args.sim:
        from robodcn.simulated import simulated_arm

        with simulated_arm(arm, timing="fast") as sim:
            traj = plan_run(args, arm, sim.bus, kind, loaded)
            report, live, released = motion_cmd.stream_and_release(args, traj, arm, sim.bus)
    else:
        with open_bus(args, arm) as bus:
            traj = plan_run(args, arm, bus, kind, loaded)
            report, live, released = motion_cmd.stream_and_release(args, traj, arm, bus)
    return motion_cmd.finish(args, arm, traj, report, live,
                             waypoints=loaded["waypoints"] if kind == "waypoints" else None,
                             released=released)


@contextmanager
def _bus(args: argparse.Namespace, arm: Arm) -> Iterator[Any]:
    if args.sim:
        from robodcn.simulated import simulated_arm

        with simulated_arm(arm, timing="fast") as sim:
            yield sim.bus
    else:
        with open_bus(args, arm) as bus:
            yield bus


def _leg_plot(path: str | None, k: int) -> str | None:
    if path is None:
        return None
    p = Path(path)
    return str(p.with_name(f"{p.stem}-leg{k}{p.suffix}"))


def run_legs(args: argparse.Namespace, arm: Arm, plan_legs: list[Any]) -> int:
    """Play ``plan_legs`` (module docstring): plan each from the present joints, stream it,
    act at its end; returns the exit code of the first leg that did not complete, else
    degraded (5) if any leg was, else 0."""
    from robodcn.cli.gripper_cmd import result_line
    from robodcn.cli.report_text import approach_seconds, report_dict, report_text
    from robodcn.present import present_joints
    from robodcn.workflow.gripper import actuate
    from robodcn.workflow.run import plan_leg

    held = argparse.Namespace(**{**vars(args), "release": False})
    done: list[dict[str, Any]] = []
    code, last, released = Exit.DONE, None, None
    with _bus(args, arm) as bus:
        for k, leg in enumerate(plan_legs, start=1):
            final = k == len(plan_legs)
            traj = plan_leg(arm, leg, present_joints(arm, bus), source=args.file)
            say(f"leg {k}/{len(plan_legs)}: waypoints {leg.first}..{leg.last}, payload "
                f"{leg.payload_kg:g} kg{f', then gripper {leg.gripper}' if leg.gripper else ''}")
            if final:
                report, live, released = motion_cmd.stream_and_release(args, traj, arm, bus)
            else:
                report, live = motion_cmd.stream(held, traj, arm, bus)
            approach = approach_seconds(report, traj)
            entry = {**leg.to_dict(), "report": report_dict(report, approach)}
            done.append(entry)
            last = entry["report"]
            if not args.json:
                emit(report_text(report, approach) + "\n")
            motion_cmd.plot(_leg_plot(args.plot, k), arm, traj, samples=live.samples,
                            report=report)
            leg_code = exit_for_report(report)
            if leg_code not in (Exit.DONE, Exit.DEGRADED):
                code = leg_code
                break
            code = max(code, leg_code)
            if leg.gripper is not None:
                result = actuate(bus, arm.gripper, leg.gripper)
                entry["gripper_result"] = result.to_dict()
                say(result_line(result))
                if not result.settled:
                    code = Exit.FAULT
                    break
    if args.json:
        data = {**(last or {}), "legs": done}
        if released is not None:
            data["release"] = released.to_dict()
            data["released"] = released.released
        emit(json.dumps(data, indent=2) + "\n")
    return code


__all__ = ["load_run_file", "overrides", "plan_run", "register", "run", "run_legs"]
