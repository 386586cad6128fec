"""The command line's exit codes: one table, used by ``main``, the docs and the tests.

README.md's exit-code table is checked against :data:`EXIT_CODES` (tests/test_readme.py).
"""

from __future__ import annotations

from enum import IntEnum
from typing import Any

from robodcn.errors import (
    BusError,
    BusyError,
    InputError,
    PlanError,
    RobodcnError,
    StoppedError,
)


class Exit(IntEnum):
    """What a ``robodcn`` command's exit status means."""

    DONE = 0
    DECLINED = 1
    USAGE = 2
    INFEASIBLE = 3
    FAULT = 4
    DEGRADED = 5
    CANNOT_SERVE = 6
    STOPPED = 130


#: code → meaning, in the words of README.md's table.
EXIT_CODES: dict[int, str] = {
    Exit.DONE: "done",
    Exit.DECLINED: "declined: the user answered no (nothing written)",
    Exit.USAGE: "bad usage or input (nothing moved)",
    Exit.INFEASIBLE: "plan infeasible (nothing moved)",
    Exit.FAULT: "servo or bus fault, or a collision stop (including: scan found no servo)",
    Exit.DEGRADED: "completed with samples skipped, or the arm came to rest out of position",
    Exit.CANNOT_SERVE: "cannot serve (TCP address in use or not available, or a "
                       "--processes worker died)",
    Exit.STOPPED: "stopped by the user (Ctrl-C)",
}

#: Error class → exit code, most specific first (README.md's error table).
EXIT_BY_ERROR: tuple[tuple[type[RobodcnError], Exit], ...] = (
    (InputError, Exit.USAGE),
    (PlanError, Exit.INFEASIBLE),
    (BusError, Exit.FAULT),
    (BusyError, Exit.FAULT),
    (StoppedError, Exit.STOPPED),
)

#: ExecutionReport outcome (:data:`robodcn.stream.OUTCOMES`) → exit code; a collision stop
#: is a fault of the move (the arm met something), 4 like the others.
EXIT_BY_OUTCOME: dict[str, Exit] = {"done": Exit.DONE, "degraded": Exit.DEGRADED,
                                    "stopped": Exit.STOPPED, "fault": Exit.FAULT,
                                    "collision": Exit.FAULT}


def exit_for_error(exc: RobodcnError) -> Exit:
    """The exit code of an error: by class (:data:`EXIT_BY_ERROR`), else the error's own
    ``exit_code`` when it is one of the table's (e.g. 6 for the HTTP server's cannot-listen
    error), else 4: never 1."""
    for cls, code in EXIT_BY_ERROR:
        if isinstance(exc, cls):
            return code
    own = getattr(exc, "exit_code", None)
    # an error is never "done" nor "declined" (the user's own no, which raises nothing)
    return Exit(own) if own in EXIT_CODES and own not in (Exit.DONE, Exit.DECLINED) \
        else Exit.FAULT


def exit_for_report(report: Any) -> Exit:
    """The exit code of an ExecutionReport, by its ``outcome``."""
    return EXIT_BY_OUTCOME[report.outcome]


__all__ = ["EXIT_BY_ERROR", "EXIT_BY_OUTCOME", "EXIT_CODES", "Exit", "exit_for_error",
           "exit_for_report"]
