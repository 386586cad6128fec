"""Torque off from the command line: an arm under gravity falls, so it needs ``--yes``.

Every command that switches torque off goes through :func:`guarded`, the gravity guard
(:func:`robodcn.workflow.release.release`) with ``--yes`` as its confirmation: ``torque
off``, ``reboot``, ``calibrate``, ``teach`` (torque off while a hand moves the arm, or
``--release`` at the end of ``--float``), ``servo set-id``/``set-baud`` and ``--release``
on ``move``/``sim``/``run``. On an arm with gravity (a chain in a vertical plane, g ≠ 0)
whose loaded joints would go off, without ``--yes`` they raise
:class:`~robodcn.errors.GravityReleaseError` (exit 2) naming the joints gravity loads, the
torque each holds and the flag — before anything moves or torque changes
(:func:`confirm_release` makes the same check before a move or a dialogue starts).
Confirmed, the arm is lowered to its rest pose (``[arm.rest]``) first, or the user is told
to hold it where it cannot be; a warning line says which. A horizontal planar arm, the
base yaw alone or a gripper are released at once.
"""

from __future__ import annotations

import argparse
from typing import Any

from numpy.typing import ArrayLike

from robodcn.cli.dialogue import say
from robodcn.cli.error_text import error_text
from robodcn.config import Arm
from robodcn.errors import GravityReleaseError


def add_yes_option(p, *, what: str) -> None:
    """``--yes``: confirm that ``what`` lets an arm under gravity fall."""
    p.add_argument("--yes", action="store_true",
                   help=f"confirm {what} on an arm under gravity (torque goes off: it is "
                        "lowered to its [arm.rest] pose first, or you hold it)")


def falls(arm: Arm) -> bool:
    """Whether torque off can let ``arm`` fall (it has gravity on its chain)."""
    from robodcn.workflow.float_teach import has_gravity

    return has_gravity(arm)


def asks(error: GravityReleaseError) -> GravityReleaseError:
    """The refusal as the command line prints it: ending with the flag that confirms."""
    error.cli_text = f"{error_text(error)}; --yes confirms"
    return error


def warning(text: str) -> None:
    """A warning line on stderr: what a confirmed release does to the arm."""
    say(f"robodcn: warning: {text}")


def confirm_release(arm: Arm, joints: ArrayLike, yes: bool, *,
                    joint: str | None = None, what: str = "torque off") -> bool:
    """Refuse (GravityReleaseError, exit 2) torque off at ``joints`` (rad) unless ``yes``
    when the arm would fall — the check of :func:`robodcn.workflow.release.release`, made
    before a move or a dialogue starts; with ``joint``, only when that joint is one gravity
    loads. Returns whether it falls (confirmed)."""
    from robodcn.workflow import release

    ids = None if joint is None else [arm.joints[arm.joint_names.index(joint)].servo.id]
    check = release.check_release(arm, joints, ids)
    if not check.falls:
        return False
    if yes:
        return True
    raise asks(release.refusal(check, what=what))


def guarded(args: argparse.Namespace, arm: Arm, bus, *, ids=None, what: str = "torque off",
            switch_off=None, yes: bool | None = None, **options: Any) -> Any:
    """The gravity guard (:func:`robodcn.workflow.release.release`) from the command line:
    ``--yes`` (or ``yes``) confirms, the refusal names the flag, the warnings go to stderr.
    ``options`` go to release (``verify``, ``execute_options`` …). Returns the
    ReleaseResult."""
    from robodcn.workflow import release

    confirmed = bool(getattr(args, "yes", False)) if yes is None else yes
    try:
        return release.release(bus, arm, confirm=confirmed, ids=ids, what=what,
                               switch_off=switch_off, warn=warning, **options)
    except GravityReleaseError as error:
        raise asks(error) from None


def release_after_move(bus, arm: Arm, report, *, stream_options: dict[str, Any] | None = None
                       ) -> Any:
    """``--release --yes`` after a move on an arm under gravity: lower it to the rest pose
    and torque off (:func:`guarded`); a move that did not complete is not followed by
    another motion: the arm holds where it stopped. Returns the ReleaseResult, or None when
    nothing was released."""
    from robodcn.workflow import release

    if report.outcome not in release.ARRIVED:
        say(f"robodcn: not released: the move ended {report.outcome}; the arm holds where "
            "it stopped (torque on)")
        return None
    result = guarded(argparse.Namespace(), arm, bus, yes=True, verify=False,
                     execute_options=stream_options)
    say(release_line(result))
    return result


def release_line(result, what: str = "torque off") -> str:
    """What a release did, in one line."""
    if not result.released:
        outcome = result.lowering.outcome if result.lowering is not None else "?"
        return (f"robodcn: {what} not done: the lowering to the rest pose ended {outcome}; "
                "torque stays on")
    lowered = " after lowering it to its rest pose" if result.lowered else ""
    return f"{what}: servo(s) {', '.join(map(str, result.released_ids))}{lowered}"


def release_in_stream(args: argparse.Namespace, arm: Arm) -> bool:
    """Whether the stream itself switches torque off at the end (``--release`` on an arm
    that does not fall; an arm under gravity is released by :func:`release_after_move`)."""
    return bool(getattr(args, "release", False)) and not falls(arm)


__all__ = ["add_yes_option", "asks", "confirm_release", "falls", "guarded", "release_after_move",
           "release_in_stream", "release_line", "warning"]
