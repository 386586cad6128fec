"""A robodcn error as the one line (or two) the command line prints, in the user's terms.

The text comes from :func:`robodcn.messages.describe` (``units="cli"``: degrees, deg/s) when
that module exists, else from the error's own message; the option the user typed is found
from the error's data (``field``), never by reading its text.
"""

from __future__ import annotations

import re

from robodcn.errors import RobodcnError

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


def describe(exc: RobodcnError) -> str:
    """The error in CLI units: robodcn.messages.describe when present, else its message."""
    try:
        from robodcn import messages
    except ImportError:
        messages = None
    text = None
    if messages is not None and hasattr(messages, "describe"):
        try:
            text = messages.describe(exc, units="cli")
        except Exception:  # a formatter bug must not hide the error itself
            text = None
    return text or exc.message or type(exc).__name__


def error_text(exc: RobodcnError, *, vias: int | None = None) -> str:
    """``describe(exc)`` naming the option it is about (when ``vias``, the number of --via
    options, is given), cut to :data:`MAX_CHARS`."""
    text = describe(exc)
    option = option_for(exc.field, vias) if vias is not None else None
    if option and option not in text:
        text = (f"{text} ({exc.field} is {option})" if exc.field.startswith("waypoints")
                else f"{option}: {text}")
    if len(text) > MAX_CHARS:
        text = text[:MAX_CHARS - 1] + "…"
    return text


__all__ = ["MAX_CHARS", "OPTION_BY_FIELD", "describe", "error_text", "option_for",
           "waypoint_options"]
