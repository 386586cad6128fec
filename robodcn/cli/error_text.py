"""A robodcn error as the one line (or two) the command line prints, in the user's terms.

The text comes from :func:`robodcn.messages.describe` (``units="cli"``: degrees, deg/s) when
that module exists, else from the error's own message; the option the user typed is found
from the error's data (``field``), never by reading its text.
"""

from __future__ import annotations

import math
import re
from typing import Any

from robodcn.errors import (
    AccelerationLimitError,
    JointLimitError,
    RobodcnError,
    VelocityLimitError,
)

#: Request field → the option that sets it.
OPTION_BY_FIELD = {"rate_hz": "--rate", "duration": "--duration", "beta": "--beta",
                   "method": "--method", "turn": "--turn", "profile": "--profile",
                   "blend": "--blend", "elbow": "--elbow", "arm": "--arm"}
#: Longest message printed; a longer one (a config table, say) is cut.
MAX_CHARS = 400


def waypoint_options(vias: int) -> list[str]:
    """The option that gave waypoints[i]: ``--from``, ``--via 1`` … ``--via N``, ``--to``."""
    return ["--from"] + [f"--via {i + 1}" for i in range(vias)] + ["--to"]


def option_for(field: str | None, vias: int) -> str | None:
    """The option behind a request field (``waypoints[2]`` → ``--via 2``), None if unknown."""
    if not field:
        return None
    match = re.fullmatch(r"waypoints\[(\d+)\].*", field)
    if match:
        names = waypoint_options(vias)
        index = int(match.group(1))
        return names[index] if index < len(names) else None
    return OPTION_BY_FIELD.get(field.split("[", 1)[0])


def describe(exc: RobodcnError | Warning, arm: Any = None,
             waypoint_names: list[str] | None = None) -> str:
    """The error in CLI units: robodcn.messages.describe when present, else (for a limit
    error whose data and ``arm`` are known) the same facts in degrees, else its message."""
    try:
        from robodcn import messages
    except ImportError:
        messages = None
    text = None
    if messages is not None and hasattr(messages, "describe"):
        attempts = [{"waypoint_names": waypoint_names}] if waypoint_names is not None else []
        for extra in [*attempts, {}]:
            try:
                text = messages.describe(exc, units="cli", **extra)
                break
            except TypeError:  # an older describe without waypoint_names
                continue
            except Exception:  # a formatter bug must not hide the error itself
                break
    return text or (_limit_text(exc, arm) if arm is not None else None) \
        or getattr(exc, "message", None) or str(exc) or type(exc).__name__


def _limit_text(exc: RobodcnError, arm: Any) -> str | None:
    """A joint, velocity or acceleration limit error from its data, in degrees."""
    joint = getattr(exc, "joint", None)
    if not isinstance(exc, JointLimitError | VelocityLimitError | AccelerationLimitError) \
            or joint not in arm.joint_names or not isinstance(exc.value, int | float) \
            or exc.t is None or exc.pose is None:
        return None
    spec = arm.joints[arm.joint_names.index(joint)]
    x, y, theta = exc.pose
    where = (f"sample {exc.sample} (t={exc.t:.3f} s, x={x:.4f} m, y={y:.4f} m, "
             f"θ={math.degrees(theta):.1f}°): joint {joint} ")
    if isinstance(exc, JointLimitError):
        return (where + f"would be at {math.degrees(exc.value):.1f}°, outside its limits "
                f"{math.degrees(spec.min_angle):.1f}..{math.degrees(spec.max_angle):.1f}°")
    if isinstance(exc, VelocityLimitError):
        need, limit, unit = exc.value, spec.max_velocity, "deg/s"
    else:
        need, limit, unit = exc.value, spec.max_acceleration, "deg/s²"
    return (where + f"needs {math.degrees(need):.1f} {unit}, limit "
            f"{math.degrees(limit):.1f} {unit}: lengthen --duration (or leave it auto)")


def one_line(text: str) -> str:
    """``text`` on one line: line breaks and other non-printable characters escaped."""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii")
                   for c in text)


def error_text(exc: RobodcnError, *, vias: int | None = None, arm: Any = None) -> str:
    """``describe(exc)`` naming the option it is about (when ``vias``, the number of --via
    options, is given), cut to :data:`MAX_CHARS`."""
    names = waypoint_options(vias) if vias is not None else None
    text = describe(exc, arm, names)
    option = option_for(exc.field, vias) if vias is not None else None
    if option and option not in text:
        text = (f"{text} ({exc.field} is {option})" if exc.field.startswith("waypoints")
                else f"{option}: {text}")
    return shorten(one_line(text))


def shorten(text: str, limit: int = MAX_CHARS) -> str:
    """``text`` cut to ``limit`` characters in the middle: the start says where, the end
    what is wrong (``key 'arm.bogus' = {…}: unknown key (allowed: ...)``)."""
    if len(text) <= limit:
        return text
    head = (limit - 3) * 3 // 5
    return f"{text[:head]} … {text[len(text) - (limit - 3 - head):]}"


__all__ = ["MAX_CHARS", "OPTION_BY_FIELD", "describe", "error_text", "one_line", "option_for",
           "shorten", "waypoint_options"]
