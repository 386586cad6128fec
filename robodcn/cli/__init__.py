"""The ``robodcn`` command line: one module per subcommand, each with ``register(subparsers)``.

Subcommands
    plan    print a planned trajectory (table, JSON or CSV); touches no hardware
    move    plan from the arm's present pose and execute it on the servos
    sim     the same as move, against an in-process simulated bus (a dry-run)
    follow  stream targets to the arm, one JSON line each from stdin
    serve   the HTTP trajectory service
    scan    list the servos on a serial device: id, model, firmware, baud
    gripper open|close|WIDTH_MM: the arm's [gripper] (current-based position mode)
    calibrate, teach, run, pose, torque, reboot, servo, check-config, config
            the everyday workflow around a real arm (over :mod:`robodcn.workflow`)

A command module's ``register(subparsers)`` adds its parser and sets ``func`` (``args → exit
code``); :data:`COMMANDS` lists the modules in help order: a new command is one more module
there. ``main`` adds ``-v/--verbose`` and ``--log-level`` to every command, turns
:class:`robodcn.errors.RobodcnError` into one ``robodcn: <message>`` line on stderr with its
exit code (:mod:`robodcn.cli.exit_codes`), prints warnings as ``robodcn: warning: ...`` and
exits quietly when the reader of stdout goes away (``| head``).

Poses are ``x,y,θ`` in metres and degrees (``--radians`` for radians; ``x,y`` on a
position-only arm). A pose starting with a minus sign may be given as ``--to=-0.1,0.2,0`` or
``--to -0.1,0.2,0``.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings
from collections.abc import Sequence

from robodcn.cli.error_text import error_text
from robodcn.cli.exit_codes import EXIT_CODES, Exit, exit_for_error
from robodcn.cli.options import DEFAULT_ARM, NEGATIVE_POSE, Parser, parse_pose
from robodcn.cli.output import silence_stdout
from robodcn.errors import RobodcnError

#: The command modules, in help order; each has ``register(subparsers)``.
COMMANDS: tuple[str, ...] = ("robodcn.cli.plan_cmd", "robodcn.cli.motion_cmd",
                             "robodcn.cli.jog_cmd", "robodcn.cli.follow_cmd",
                             "robodcn.cli.serve_cmd", "robodcn.cli.scan_cmd",
                             "robodcn.cli.calibrate_cmd", "robodcn.cli.teach_cmd",
                             "robodcn.cli.run_cmd", "robodcn.cli.gripper_cmd",
                             "robodcn.cli.admin_cmd",
                             "robodcn.cli.config_cmd", "robodcn.cli.fleet_cmd")


def build_parser() -> argparse.ArgumentParser:
    from robodcn.cli.options import add_logging_options

    parser = Parser(prog="robodcn",
                    description="Plan planar rigid motions with dual complex numbers and "
                                "stream them to Dynamixel servos.",
                    epilog="exit codes: " + ", ".join(f"{c} {m}" for c, m in EXIT_CODES.items()))
    parser.add_argument("--version", action="version", version=f"robodcn {_version()}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        importlib.import_module(name).register(subparsers)
    for command in subparsers.choices.values():
        add_logging_options(command)
        # Poses such as -0.1,0.2,0 are values, not options.
        command._negative_number_matcher = NEGATIVE_POSE
    parser._negative_number_matcher = NEGATIVE_POSE
    return parser


def _version() -> str:
    from robodcn import __version__

    return __version__


def _warning_printer():
    """A ``warnings.showwarning`` that prints each warning once per command, as one
    ``robodcn: warning: ...`` line in CLI terms (messages.describe: ``--beta``, degrees)."""
    from robodcn.cli.error_text import describe, one_line, shorten

    shown: set[str] = set()

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        text = shorten(one_line(describe(message) if isinstance(message, Warning)
                                else str(message)))
        if text not in shown:
            shown.add(text)
            print(f"robodcn: warning: {text}", file=sys.stderr)

    return show


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (:data:`EXIT_CODES`)."""
    from robodcn.cli.options import configure_logging

    parser = build_parser()
    args = parser.parse_args(argv)
    configure_logging(args)
    with warnings.catch_warnings():
        # Every user-facing warning reaches the printer (which says each one once per
        # command): the default filter would hide one an earlier main() here already showed.
        warnings.simplefilter("always", UserWarning)
        warnings.showwarning = _warning_printer()
        try:
            return int(args.func(args))
        except RobodcnError as exc:
            text = getattr(exc, "cli_text", None) or error_text(exc)
            print(f"robodcn: {text}", file=sys.stderr)
            return exit_for_error(exc)
        except KeyboardInterrupt:
            print("robodcn: interrupted", file=sys.stderr)
            return Exit.STOPPED
        except BrokenPipeError:
            silence_stdout()
            return Exit.DONE


__all__ = ["COMMANDS", "DEFAULT_ARM", "EXIT_CODES", "Exit", "build_parser", "main",
           "parse_pose"]
