"""The motion options every planning command shares (--to, --via, --method, ...) and the
one place that turns them into a :func:`robodcn.planner.plan` call.

:func:`motion_request` checks every option before anything is planned or moved, so a bad
value is a usage error (exit 2) naming the option as typed, and the planner's own errors
come back naming ``--from``, ``--via N`` or ``--to`` (:mod:`robodcn.cli.error_text`).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from robodcn import contract
from robodcn.cli import options
from robodcn.cli.error_text import error_text
from robodcn.errors import InputError, RobodcnError

ELBOWS = ("up", "down")


def add_motion_options(p: argparse.ArgumentParser, *, start_help: str) -> None:
    g = p.add_argument_group("motion")
    options.add_arm_option(g)
    g.add_argument("--from", dest="start", metavar="POSE", help=start_help)
    g.add_argument("--to", dest="end", metavar="POSE", required=True,
                   help="goal pose: x,y,θ (metres, degrees); x,y on a position-only (2R) "
                        "arm; x,y,z,pitch on an arm with a base yaw (the omx)")
    g.add_argument("--via", action="append", default=[], metavar="POSE",
                   help="via pose, repeatable, in order (--via 1, --via 2, ... in messages)")
    g.add_argument("--method", default="sclerp", metavar="M[,M...]",
                   help="sclerp | kenlerp | seplerp | dlb, or one per segment (default sclerp)")
    g.add_argument("--beta", type=options.finite_floats, metavar="B[,B...]",
                   help="KenLERP bias: 0 decoupled, 1 = ScLERP, > 1 amplifies, or one per "
                        "segment (default 1; only kenlerp uses it)")
    g.add_argument("--turn", default="shortest", metavar="T[,T...]",
                   help="shortest | ccw | cw, or one per segment (default shortest)")
    g.add_argument("--duration", type=options.duration, default="auto",
                   metavar="SECONDS|auto",
                   help="total duration, or auto: the shortest within the joint limits")
    profile = contract.field("profile")
    g.add_argument("--profile", default=profile.default, choices=contract.cli_choices("profile"),
                   help=f"time law s(t): optimal times the whole path time-optimally within "
                        f"the joint limits, the others stretch one uniform law (default "
                        f"{profile.default})")
    g.add_argument("--rate", type=options.rate, metavar="HZ",
                   help="sample rate, 1..1000 Hz (default: the arm's [bus] rate_hz)")
    g.add_argument("--blend", action="store_true",
                   help="pass through via poses with continuous velocity instead of stopping")
    g.add_argument("--elbow", choices=ELBOWS,
                   help="IK branch: up or down (default: the arm's [arm] elbow)")
    g.add_argument("--radians", action="store_true",
                   help="θ (or pitch) in radians, not degrees")
    add_payload_option(g)
    add_tool_options(g)


def add_tool_options(g, *, hands_on: bool = False) -> None:
    """``--tool-speed``, ``--tool-angular-speed``, ``--tool-acceleration``: the tool limits
    of the contract's fields (``hands_on``: jog and teach, whose default is the reduced
    speed :data:`robodcn.contract.HANDS_ON_SPEED`)."""
    default = (f"default {contract.HANDS_ON_SPEED:g} m/s, the reduced speed for hands-on "
               "work" if hands_on else "default: the arm's [tool] speed, else none")
    if hands_on:
        g.add_argument("--tool-speed", type=options.positive_float, metavar="M/S",
                       help=f"the tool point's largest speed, m/s ({default}; at most the "
                            "arm's [tool] max_speed)")
        return
    g.add_argument("--tool-speed", type=options.positive_float, metavar="M/S",
                   help=f"the tool point's largest speed, m/s, kept along the whole path with "
                        f"every joint limit; a straight line (seplerp, or kenlerp --beta 0) "
                        f"runs at exactly this speed where the joints allow ({default})")
    g.add_argument("--tool-angular-speed", type=options.positive_float, metavar="DEG/S",
                   help="the largest rate of θ (of pitch and of yaw on the omx), deg/s "
                        "(default: the arm's [tool] angular_speed, else none)")
    g.add_argument("--tool-acceleration", type=options.positive_float, metavar="M/S²",
                   help="the tool point's largest acceleration along its path, m/s²: the "
                        "ramps at both ends of a straight line (default: the arm's [tool] "
                        "acceleration, else none)")


def tool_keywords(args: argparse.Namespace, arm, *, hands_on: bool = False
                  ) -> dict[str, float]:
    """The tool limits given as options, SI (``tool_speed`` …), each checked against the
    arm's ``[tool]`` ceiling in the units typed; {} for none (the arm's defaults). With
    ``hands_on`` (jog, teach) the tool speed defaults to
    :func:`robodcn.contract.hands_on_speed` instead."""
    out: dict[str, float] = {}
    if hands_on and getattr(args, "tool_speed", None) is None:
        out["tool_speed"] = contract.hands_on_speed(arm)
    for name, key, factor, unit in (("tool_speed", "max_speed", 1.0, "m/s"),
                                    ("tool_angular_speed", "max_angular_speed",
                                     math.pi / 180.0, "deg/s"),
                                    ("tool_acceleration", "max_acceleration", 1.0, "m/s²")):
        given = getattr(args, name, None)
        if given is None:
            continue
        top = getattr(arm.tool, key)
        if top is not None and given * factor > top * (1 + 1e-12):
            option = contract.cli_option(name)
            raise InputError(f"{option} {given:g} {unit} is above the arm's [tool] {key}, "
                             f"{top / factor:.6g} {unit}", field=option, value=given)
        out[name] = given * factor
    return out


def add_payload_option(g) -> None:
    """``--payload KG``: the mass at the tool point the timing plans for."""
    g.add_argument("--payload", type=options.non_negative_float, metavar="KG",
                   help="mass held at the tool point, kg: the torque-limited timing plans "
                        "for it (default: the arm's [dynamics] payload_kg); a gripper "
                        "closing on an object does not change it")


def payload_keywords(args: argparse.Namespace) -> dict[str, float]:
    """``{"payload_kg": KG}`` when --payload was given, else {} (the arm's default)."""
    payload = getattr(args, "payload", None)
    return {} if payload is None else {"payload_kg": payload}


@dataclass(frozen=True)
class MotionRequest:
    """The checked motion options: everything :func:`plan` needs except the start."""

    vias: tuple[tuple[float, ...], ...]
    end: tuple[float, ...]
    start: tuple[float, ...] | None
    keywords: dict[str, Any]

    @property
    def segments(self) -> int:
        return len(self.vias) + 1


def motion_request(args: argparse.Namespace, arm) -> MotionRequest:
    """Parse and check the motion options against ``arm`` (InputError naming the option).

    --beta with methods that ignore it is the planner's BetaIgnoredWarning (printed once, as
    a ``robodcn: warning:`` line, by :func:`robodcn.cli.main`).
    """
    from robodcn.dcn import TURNS
    from robodcn.interpolate import METHODS
    from robodcn.planner import MAX_SAMPLES

    def pose(text: str, option: str) -> tuple[float, ...]:
        return options.arm_pose(arm, text, option, radians=args.radians)

    start = pose(args.start, "--from") if args.start is not None else None
    vias = tuple(pose(v, f"--via {i + 1}") for i, v in enumerate(args.via))
    end = pose(args.end, "--to")
    segments = len(vias) + 1
    method = options.split_list(args.method, "--method", METHODS, segments)
    turn = options.split_list(args.turn, "--turn", TURNS, segments)
    beta = 1.0 if args.beta is None else options.one_or_per_segment(args.beta, "--beta",
                                                                     segments)
    rate = args.rate if args.rate is not None else arm.bus.rate_hz
    if args.duration != "auto" and args.duration * rate + 1 > MAX_SAMPLES:
        raise InputError(f"--duration {args.duration:g} s at {rate:g} Hz needs more than "
                         f"{MAX_SAMPLES} samples: shorten it or lower --rate",
                         field="--duration", value=args.duration)
    if args.duration != "auto" and max(1, math.ceil(args.duration * rate - 1e-9)) < segments:
        raise InputError(f"--duration {args.duration:g} s at {rate:g} Hz is shorter than one "
                         f"sample period for each of the {segments} segments",
                         field="--duration", value=args.duration)
    keywords: dict[str, Any] = dict(
        method=method, beta=beta, turn=turn,
        duration=args.duration, profile=args.profile, rate_hz=rate, blend=args.blend,
        **payload_keywords(args), **tool_keywords(args, arm))
    if args.elbow is not None:
        keywords["elbow"] = args.elbow
    return MotionRequest(vias=vias, end=end, start=start, keywords=keywords)


def plan_motion(request: MotionRequest, arm, start_pose, start_joints=None):
    """Plan from ``start_pose`` through the --via poses to --to; a planner error comes back
    with the option it is about (``--to``, ``--via 2``, ``--rate``...)."""
    from robodcn.planner import plan

    with _cli_terms(request):
        return plan(arm, [tuple(start_pose), *request.vias, request.end],
                    start_joints=start_joints, **request.keywords)


def plan_from_present(request: MotionRequest, arm, bus):
    """Plan from the arm's present joints (read from ``bus``, :func:`robodcn.present.
    plan_recovering`) to --to: from the present pose, or with a joint-space approach to
    --from first; from a present state outside the joint limits a recovery comes first,
    announced on stderr (:func:`announce_recovery`)."""
    from robodcn.present import plan_recovering

    with _cli_terms(request, present=True):
        traj, recovery = plan_recovering(arm, bus, [request.start, *request.vias,
                                                    request.end], **request.keywords)
    announce_recovery(recovery)
    return traj


def announce_recovery(recovery) -> None:
    """The recovery's one line on stderr (:meth:`robodcn.planner.recovery.Recovery.line`),
    when the move opens with one."""
    if recovery is not None:
        from robodcn.cli.dialogue import say

        say(f"robodcn: {recovery.line()}")


@contextmanager
def _cli_terms(request: MotionRequest, *, present: bool = False) -> Iterator[None]:
    """A planner error leaves with ``cli_text``: what main() prints, naming the option;
    ``present``: the plan starts at the arm's present pose unless --from was typed (the
    first waypoint is then named "the present pose", not a --from the user never typed)."""
    try:
        yield
    except RobodcnError as exc:
        exc.cli_text = error_text(exc, vias=len(request.vias),
                                  start=not present or request.start is not None)
        raise


__all__ = ["ELBOWS", "MotionRequest", "add_motion_options", "add_payload_option",
           "add_tool_options", "announce_recovery", "motion_request", "payload_keywords",
           "plan_from_present", "plan_motion", "tool_keywords"]
