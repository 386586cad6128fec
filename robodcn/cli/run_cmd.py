"""``robodcn run FILE``: play a waypoints file, a saved Trajectory JSON or a JointTrajectory
JSON through the path ``move`` uses (:func:`robodcn.cli.motion_cmd.stream` and
:func:`~robodcn.cli.motion_cmd.finish`).

The file and every option are checked before the bus opens (:func:`load_run_file`); the
plan options take the same types and choices as ``plan``'s (:mod:`robodcn.contract`) and
override a waypoints file's ``[plan]``.

A waypoints file runs on the arm its ``arm`` line names (``teach`` writes it) when neither
``--arm`` nor ``$ROBODCN_ARM`` is given; a different ``--arm`` is warned about.

A waypoints file whose waypoints act (``gripper``, ``payload_kg``) plays leg by leg
(:func:`robodcn.workflow.run.legs`). Every leg is planned with its payload and checked
before anything moves (:func:`robodcn.workflow.run.plan_legs`: the first from where the arm
is, each next from where the one before ends); an error names the file's waypoints and the
file's field that set the payload or duration. Then each leg is streamed, the arm comes to
rest, the gripper acts (:mod:`robodcn.workflow.gripper`) and the next leg starts; a leg that
does not complete, or jaws that do not come to rest, end the run there. The report is each
leg's (``--json``: the last leg's fields and ``legs``; ``--plot FILE.png`` draws one
``FILE-legN.png`` a leg).
"""

from __future__ import annotations

import argparse
import json
import os
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from robodcn import contract
from robodcn.cli import motion_cmd, options, planning, releasing
from robodcn.cli.dialogue import say
from robodcn.cli.error_text import describe, one_line, shorten
from robodcn.cli.exit_codes import Exit, exit_for_report
from robodcn.cli.output import emit
from robodcn.cli.servo_session import add_bus_options, open_bus
from robodcn.config import Arm
from robodcn.errors import InputError, RobodcnError, RobodcnWarning

#: The plan options of ``run`` → the PlanOverrides field each sets.
PLAN_OPTIONS = {"--method": "method", "--beta": "beta", "--turn": "turn",
                "--duration": "duration", "--profile": "profile", "--blend": "blend",
                "--payload": "payload", "--tool-speed": "tool_speed",
                "--tool-angular-speed": "tool_angular_speed",
                "--tool-acceleration": "tool_acceleration"}


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
    planning.add_tool_options(g)
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


def overrides(args: argparse.Namespace, segments: int, arm: Arm):
    """The plan options as a :class:`robodcn.workflow.run.PlanOverrides` for a file of
    ``segments`` segments on ``arm`` (the tool limits checked against its ceilings)."""
    from robodcn.workflow.run import PlanOverrides

    return PlanOverrides(
        method=_per_segment(_choices(args.method, "--method", "method"), "--method", segments,
                            args.file),
        turn=_per_segment(_choices(args.turn, "--turn", "turn"), "--turn", segments,
                          args.file),
        beta=_per_segment(args.beta, "--beta", segments, args.file),
        duration=args.duration, profile=args.profile, blend=args.blend, rate_hz=args.rate,
        payload_kg=args.payload, **planning.tool_keywords(args, arm))


def load_run_file(args: argparse.Namespace, arm: Arm) -> tuple[str, Any]:
    """("waypoints", PlanRequest fields) or (kind, Trajectory), checked before any bus I/O."""
    from robodcn.workflow import files
    from robodcn.workflow.run import waypoints_fields

    kind, text = files.file_kind(args.file)
    if kind == "waypoints":
        wp = files.load_waypoints(args.file, arm)
        with _file_terms(args.file, wp):
            return kind, waypoints_fields(wp, arm, overrides(args, len(wp.waypoints) - 1,
                                                                  arm))
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


def run_arm(args: argparse.Namespace) -> Arm:
    """The arm ``run`` drives: ``--arm`` (else ``$ROBODCN_ARM``); without either, the arm a
    waypoints file names (its ``arm`` line: a config file beside it or here, or an example
    name), else the default. A file that names another arm than the one given is warned
    about (RobodcnWarning, field "arm")."""
    from robodcn.config import load_arm
    from robodcn.workflow import files
    from robodcn.workflow.examples import resolve_arm_path

    named = None
    if files.file_kind(args.file)[0] == "waypoints":
        named = files.waypoints_arm(args.file)
    given = "--arm" if args.arm else "$ROBODCN_ARM" if os.environ.get("ROBODCN_ARM") else None
    if named is None or given is not None:
        arm = options.load_arm(args)
        if named is not None and named not in (arm.name, arm.source):
            warnings.warn(RobodcnWarning(
                f"{args.file} was taught on arm {named!r}; running on arm {arm.name!r} "
                f"({given})", field="arm"), stacklevel=2)
        return arm
    beside = Path(args.file).parent / named
    return load_arm(beside if beside.is_file()
                    else resolve_arm_path(named, option=f"{args.file}: arm"))


def file_field_names(wp: Any) -> dict[str, str]:
    """The words for the waypoints file's fields an error may name
    (:func:`robodcn.workflow.run.in_file_terms`): ``waypoints[4].payload_kg`` is "waypoint 4
    (payload_kg = 0.9 in the file)"."""
    names = {f"waypoints[{i}].payload_kg": f"waypoint {i} (payload_kg = "
                                            f"{a['payload_kg']:g} in the file)"
             for i, a in enumerate(wp.actions) if "payload_kg" in a}
    if "payload_kg" in wp.options:
        names["plan.payload_kg"] = (f"[plan] payload_kg ({wp.options['payload_kg']:g} kg in "
                                    "the file)")
    if "duration" in wp.options:
        duration = wp.options["duration"]
        text = f"{duration:g} s" if isinstance(duration, int | float) else repr(duration)
        names["plan.duration"] = f"[plan] duration ({text} in the file)"
    return names


def plan_file(args: argparse.Namespace, arm: Arm, bus, wp: Any, leg_list: list[Any]):
    """Every leg of the waypoints file ``wp`` planned from the present joints read on
    ``bus``, before anything moves (:func:`robodcn.workflow.run.plan_legs`); a planner
    error leaves with ``cli_text`` naming the file's waypoints and fields."""
    from robodcn.present import present_joints
    from robodcn.workflow.run import plan_legs

    present = present_joints(arm, bus)     # a bus error is not the file's
    with _file_terms(args.file, wp):
        return plan_legs(arm, leg_list, present, source=args.file,
                         on_recovery=planning.announce_recovery)


@contextmanager
def _file_terms(path: str, wp: Any) -> Iterator[None]:
    """An error of a waypoints file's leg (:func:`robodcn.workflow.run.in_file_terms`)
    leaves with ``cli_text``: the file, the leg, and the file's fields in words."""
    from robodcn.workflow.run import leg_context

    try:
        yield
    except RobodcnError as exc:
        where = ": ".join(p for p in (path, leg_context(exc)) if p)
        text = describe(exc, field_names=file_field_names(wp))
        exc.cli_text = shorten(one_line(text if text.startswith(where) else f"{where}: {text}"))
        raise


def plan_run(args: argparse.Namespace, arm: Arm, bus, kind: str, loaded: Any):
    """The trajectory ``run`` streams, from the present joints read on ``bus``
    (:func:`robodcn.workflow.run.trajectory_to_run`; a recovery first is announced)."""
    from robodcn.present import present_joints
    from robodcn.workflow.run import trajectory_to_run

    present = present_joints(arm, bus)     # a bus error is not the file's
    traj, recovery = trajectory_to_run(arm, kind, loaded, present, source=args.file)
    planning.announce_recovery(recovery)
    return traj


def run(args: argparse.Namespace) -> int:
    arm = run_arm(args)
    motion_cmd.check_plot(args.plot)
    kind, loaded = load_run_file(args, arm)
    wp = leg_list = None
    if kind == "waypoints":
        from robodcn.workflow import files
        from robodcn.workflow.run import legs

        wp = files.load_waypoints(args.file, arm)
        leg_list = legs(wp, loaded, arm)
        if wp.has_actions:
            return run_legs(args, arm, leg_list, wp)
    with _bus(args, arm) as (bus, simulated):
        if wp is not None:
            (traj,) = plan_file(args, arm, bus, wp, leg_list)
        else:
            traj = plan_run(args, arm, bus, kind, loaded)
        _carry(simulated, traj)
        report, live, released = motion_cmd.stream_and_release(args, traj, arm, bus)
        report = _reported(simulated, report, traj)
    return motion_cmd.finish(args, arm, traj, report, live,
                             waypoints=loaded["waypoints"] if kind == "waypoints" else None,
                             released=released)


@contextmanager
def _bus(args: argparse.Namespace, arm: Arm) -> Iterator[tuple[Any, Any]]:
    """(bus, the SimulatedArm with ``--sim`` else None)."""
    if args.sim:
        from robodcn.simulated import simulated_arm

        with simulated_arm(arm, timing="fast") as sim:
            yield sim.bus, sim
    else:
        with open_bus(args, arm) as bus:
            yield bus, None


def _carry(simulated: Any, traj: Any) -> None:
    """With ``--sim`` the simulated arm carries the payload the leg declares (issue 27 §2)."""
    if simulated is not None:
        simulated.carry(traj.request.payload_kg if traj.request is not None else None)


def _reported(simulated: Any, report: Any, traj: Any) -> Any:
    """``report`` naming the payload the simulated arm carried (``--sim``), else as is."""
    return report if simulated is None else simulated.reported(report, traj)


def _leg_plot(path: str | None, k: int) -> str | None:
    if path is None:
        return None
    p = Path(path)
    return str(p.with_name(f"{p.stem}-leg{k}{p.suffix}"))


def run_legs(args: argparse.Namespace, arm: Arm, plan_legs: list[Any], wp: Any) -> int:
    """Play ``plan_legs`` of the waypoints file ``wp`` (module docstring): every leg planned
    first (:func:`plan_file`), then each streamed and acted on at its end; returns the exit
    code of the first leg that did not complete, else degraded (5) if any leg was, else 0."""
    from robodcn.cli.gripper_cmd import result_line
    from robodcn.cli.report_text import approach_seconds, report_dict, report_text
    from robodcn.workflow.gripper import actuate

    held = argparse.Namespace(**{**vars(args), "release": False})
    done: list[dict[str, Any]] = []
    code, last, released = Exit.DONE, None, None
    with _bus(args, arm) as (bus, simulated):
        trajectories = plan_file(args, arm, bus, wp, plan_legs)
        if getattr(args, "release", False) and releasing.falls(arm):
            releasing.confirm_release(arm, trajectories[-1].joints[-1], args.yes)
        for k, (leg, traj) in enumerate(zip(plan_legs, trajectories, strict=True), start=1):
            final = k == len(plan_legs)
            say(f"leg {k}/{len(plan_legs)}: waypoints {leg.first}..{leg.last}, payload "
                f"{leg.payload_kg:g} kg{f', then gripper {leg.gripper}' if leg.gripper else ''}")
            _carry(simulated, traj)
            if final:
                report, live, released = motion_cmd.stream_and_release(args, traj, arm, bus)
            else:
                report, live = motion_cmd.stream(held, traj, arm, bus)
            report = _reported(simulated, report, traj)
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


__all__ = ["file_field_names", "load_run_file", "overrides", "plan_file", "plan_run",
           "register", "run", "run_arm", "run_legs"]
