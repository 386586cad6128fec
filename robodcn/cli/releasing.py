"""Torque off from the command line: an arm under gravity falls, so it needs ``--yes``.

``torque off``, ``--release`` on ``move``/``sim``/``run`` and ``teach`` (torque off while a
hand moves the arm, or ``--release`` at its end) go through here. On an arm with gravity
(:func:`robodcn.workflow.float_teach.has_gravity`: a chain in a vertical plane, g ≠ 0)
without ``--yes`` they raise :class:`~robodcn.errors.GravityReleaseError` (exit 2) naming
the joints gravity loads and the torque each holds — before anything moves or torque
changes. Confirmed, ``--release`` lowers the arm to its rest pose (``[arm.rest]``) first
(:func:`robodcn.workflow.release.release`) and says so. A horizontal planar arm is released
as before, at once.
"""

from __future__ import annotations

import argparse
from typing import Any

from numpy.typing import ArrayLike

from robodcn.cli.dialogue import say
from robodcn.cli.error_text import error_text
from robodcn.config import Arm


def add_yes_option(p, *, what: str) -> None:
    """``--yes``: confirm that ``what`` lets an arm under gravity fall."""
    p.add_argument("--yes", action="store_true",
                   help=f"confirm {what} on an arm under gravity (it falls when torque goes "
                        "off; --release lowers it to its [arm.rest] pose first)")


def falls(arm: Arm) -> bool:
    """Whether torque off lets ``arm`` fall (it has gravity on its chain)."""
    from robodcn.workflow.float_teach import has_gravity

    return has_gravity(arm)


def confirm_release(arm: Arm, joints: ArrayLike, yes: bool, *,
                    joint: str | None = None) -> bool:
    """Refuse (GravityReleaseError, exit 2) torque off at ``joints`` (rad) unless ``yes``
    when the arm would fall; with ``joint``, only when that joint is one gravity loads.
    Returns whether it falls (confirmed)."""
    from robodcn.workflow import release

    check = release.check_release(arm, joints)
    if not check.falls or (joint is not None and joint not in check.joints):
        return False
    if yes:
        return True
    error = release.refusal(check)    # the library's own warning
    error.cli_text = f"{error_text(error)}; --yes confirms"
    raise error


def warn_falling(arm: Arm, *, lowering: bool = True) -> None:
    """The confirmed warning: the arm is let go under gravity (``lowering``: after being
    lowered to its rest pose, when it has one; else where it is: hold it)."""
    if not lowering:
        rest = "where it is now: hold it"
    elif arm.rest is not None:
        rest = "it is lowered to its rest pose first"
    else:
        rest = "it has no [arm.rest] pose to be lowered to"
    say(f"robodcn: warning: torque off lets arm {arm.name!r} fall under gravity ({rest}); "
        "confirmed by --yes")


def release_after_move(bus, arm: Arm, report, *, stream_options: dict[str, Any] | None = None
                       ) -> Any:
    """``--release --yes`` after a move on an arm under gravity: lower it to the rest pose
    and torque off (:func:`robodcn.workflow.release.release`); a move that did not complete
    is not followed by another motion: the arm holds where it stopped. Returns the
    ReleaseResult, or None when nothing was released."""
    from robodcn.workflow import release

    if report.outcome not in release.ARRIVED:
        say(f"robodcn: not released: the move ended {report.outcome}; the arm holds where "
            "it stopped (torque on)")
        return None
    warn_falling(arm)
    result = release.release(bus, arm, confirm=True, verify=False,
                             execute_options=stream_options)
    say(release_line(result))
    return result


def release_line(result) -> str:
    """What a release did, in one line."""
    if not result.released:
        outcome = result.lowering.outcome if result.lowering is not None else "?"
        return (f"robodcn: not released: the lowering to the rest pose ended {outcome}; "
                "torque stays on")
    lowered = " after lowering it to its rest pose" if result.lowered else ""
    return f"torque off: servo(s) {', '.join(map(str, result.released_ids))}{lowered}"


def release_in_stream(args: argparse.Namespace, arm: Arm) -> bool:
    """Whether the stream itself switches torque off at the end (``--release`` on an arm
    that does not fall; an arm under gravity is released by :func:`release_after_move`)."""
    return bool(getattr(args, "release", False)) and not falls(arm)


__all__ = ["add_yes_option", "confirm_release", "falls", "release_after_move",
           "release_in_stream", "release_line", "warn_falling"]
