"""A robodcn error as the one line (or two) the command line prints, in the user's terms.

The text comes from :func:`robodcn.messages.describe` (``units="cli"``: degrees, deg/s,
waypoints named by the option that gave them); the option the user typed is found from the
error's data (``field``), never by reading its text.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from robodcn import messages
from robodcn.errors import RobodcnError

#: Request field → the option that sets it.
OPTION_BY_FIELD = {"rate_hz": "--rate", "duration": "--duration", "beta": "--beta",
                   "method": "--method", "turn": "--turn", "profile": "--profile",
                   "blend": "--blend", "elbow": "--elbow", "arm": "--arm"}
#: Longest message printed; a longer one (a config table, say) is cut.
MAX_CHARS = 400


#: What waypoints[0] is when the user typed no --from: where the arm is.
PRESENT_POSE = "the present pose"


def waypoint_options(vias: int, start: bool = True) -> list[str]:
    """The option that gave waypoints[i]: ``--from`` (``start``: the user typed it, else
    :data:`PRESENT_POSE`: the plan starts where the arm is), ``--via 1`` … ``--via N``,
    ``--to``."""
    return [("--from" if start else PRESENT_POSE)] + [f"--via {i + 1}" for i in range(vias)] \
        + ["--to"]


def option_for(field: str | None, vias: int, start: bool = True) -> str | None:
    """The option behind a request field (``waypoints[2]`` → ``--via 2``), None if unknown;
    ``start``: whether --from was typed (else waypoints[0] is the present pose)."""
    if not field:
        return None
    match = re.fullmatch(r"waypoints\[(\d+)\].*", field)
    if match:
        names = waypoint_options(vias, start)
        index = int(match.group(1))
        return names[index] if index < len(names) else None
    return OPTION_BY_FIELD.get(field.split("[", 1)[0])


def describe(exc: RobodcnError | Warning, waypoint_names: list[str] | None = None,
             field_names: Mapping[str, str] | None = None) -> str:
    """The error (or warning) in CLI units: :func:`robodcn.messages.describe` with
    ``units="cli"`` (degrees, deg/s, the options as typed, ``--via 2`` for waypoints[2];
    ``field_names`` for fields a file gave)."""
    return messages.describe(exc, units="cli", waypoint_names=waypoint_names,
                             field_names=field_names) or type(exc).__name__


def one_line(text: str) -> str:
    """``text`` on one line: line breaks and other non-printable characters escaped."""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii")
                   for c in text)


def error_text(exc: RobodcnError, *, vias: int | None = None, start: bool = True) -> str:
    """``describe(exc)`` naming the option it is about (when ``vias``, the number of --via
    options, is given; ``start``: whether --from was typed, else the first waypoint is
    the present pose and no --from is named), cut to :data:`MAX_CHARS`."""
    names = waypoint_options(vias, start) if vias is not None else None
    text = describe(exc, names)
    option = option_for(exc.field, vias, start) if vias is not None else None
    if option and option not in text:
        text = (f"{text} ({exc.field} is {option})" if exc.field.startswith("waypoints")
                else f"{option}: {text}")
    elif vias is not None and (exc.field or "").startswith("start_joints"):
        text = f"{text} ({PRESENT_JOINTS})"
    return shorten(one_line(text))


#: What ``start_joints`` is on the command line: where the servos are.
PRESENT_JOINTS = ("start_joints are the arm's present joints, read from the servos; "
                  "`robodcn pose` shows them")


def shorten(text: str, limit: int = MAX_CHARS) -> str:
    """``text`` cut to ``limit`` characters in the middle: the start says where, the end
    what is wrong (``key 'arm.bogus' = {…}: unknown key (allowed: ...)``)."""
    if len(text) <= limit:
        return text
    head = (limit - 3) * 3 // 5
    return f"{text[:head]} … {text[len(text) - (limit - 3 - head):]}"


__all__ = ["MAX_CHARS", "OPTION_BY_FIELD", "PRESENT_POSE", "describe", "error_text", "one_line",
           "option_for", "shorten", "waypoint_options"]
