"""Argument types and option groups shared by the subcommands.

Every value is checked here, in the user's terms (the option as typed, degrees, deg/s, Hz),
before anything is planned or moved: a bad one is one ``robodcn <command>: ...`` line and
exit code 2.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from robodcn.errors import InputError

#: Default arm when neither --arm nor $ROBODCN_ARM is given.
DEFAULT_ARM = Path("configs") / "arm3r.toml"
LOG_LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL")
#: Poses such as -0.1,0.2,0 are values, not options.
NEGATIVE_POSE = re.compile(r"^-\.?[0-9][0-9.,eE+\-]*$")
_NUMBER = re.compile(r"^[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?$")


class Parser(argparse.ArgumentParser):
    """argparse, with usage errors as one line naming the option (exit code 2).

    Options are never abbreviated: on a command that moves an arm a prefix is a guess
    (``--to`` is a prefix of ``--tool-speed``), so ``--too`` is an unknown option with its
    "did you mean --to?" rather than one of several it could abbreviate.
    """

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str):  # type: ignore[override]
        from robodcn.cli.error_text import one_line

        if message.startswith("the following arguments are required"):
            # argparse checks required options before it returns the unknown ones: a typo of
            # a required option (--too) is named here, where the user will look.
            known = {o for a in self._actions for o in a.option_strings}
            typed = [a for a in getattr(self, "_args_seen", ())
                     if a.startswith("--") and a.split("=", 1)[0] not in known]
            if self.suggestion(typed):
                message = f"unrecognized arguments: {' '.join(typed)}{self.suggestion(typed)}"
        self.exit(2, one_line(f"{self.prog}: {message} (see '{self.prog} --help')") + "\n")

    def parse_known_args(self, args=None, namespace=None):  # type: ignore[override]
        self._args_seen = list(sys.argv[1:] if args is None else args)
        namespace, extras = super().parse_known_args(args, namespace)
        if extras and self._subparsers is None:
            return namespace, extras
        if extras:
            # argparse leaves a subcommand's unknown options to the top-level parser, which
            # would point at the top-level help: the (sub)command that got them says it.
            command = self._command_parser(namespace)
            command.error(f"unrecognized arguments: {' '.join(extras)}"
                          + command.suggestion(extras))
        return namespace, extras

    def _command_parser(self, namespace: argparse.Namespace) -> Parser:
        """The deepest (sub)command parser ``namespace`` was parsed by."""
        parser: Parser = self
        while parser._subparsers is not None:
            action = next(a for a in parser._subparsers._group_actions
                          if isinstance(a, argparse._SubParsersAction))
            chosen = getattr(namespace, action.dest, None)
            if chosen not in action.choices:
                break
            parser = action.choices[chosen]
        return parser

    def suggestion(self, extras: Sequence[str]) -> str:
        """``"; did you mean --to?"`` for the first unknown option close to one of ours."""
        import difflib

        known = [o for a in self._actions for o in a.option_strings if o.startswith("--")]
        for extra in extras:
            if extra.startswith("--"):
                typed = extra.split("=", 1)[0]
                typo = difflib.get_close_matches(typed, known, n=1, cutoff=0.85)
                if typo:                      # one letter off (--too): that option
                    return f"; did you mean {typo[0]}?"
                longer = [o for o in known if o.startswith(typed)]
                if len(longer) > 1:           # an abbreviation of several: name them all
                    return f"; did you mean {', '.join(longer[:-1])} or {longer[-1]}?"
                close = longer or difflib.get_close_matches(typed, known, n=1, cutoff=0.6)
                if close:
                    return f"; did you mean {close[0]}?"
        return ""

    def _get_values(self, action, arg_strings):
        # argparse drops a "--" value (``--beta=--``) and hands the option an empty list.
        if action.option_strings and action.nargs is None and arg_strings == ["--"]:
            raise argparse.ArgumentError(action, "expected one argument, got '--'")
        return super()._get_values(action, arg_strings)


# -- values ------------------------------------------------------------------------------------

def number(text: str, option: str) -> float:
    """A finite decimal number written in ASCII (``1e3``, ``-0.5``); InputError otherwise.

    Python's float() also takes ``nan``, ``inf``, ``1_000`` and non-ASCII digits; a
    command line takes none of them.
    """
    value = float(text) if _NUMBER.match(str(text).strip()) else math.nan
    if not math.isfinite(value):
        raise InputError(f"{option} must be a finite number, got {_shown(text)}",
                         field=option, value=text)
    return value


def _shown(text: Any, limit: int = 40) -> str:
    """The user's text, quoted, shortened past ``limit`` characters."""
    text = str(text)
    return repr(text if len(text) <= limit else text[:limit] + "…")


class _Bad(argparse.ArgumentTypeError):
    """A value argparse rejects; argparse prefixes the option: ``argument --rate: ...``."""


def non_negative_int(text: str) -> int:
    if not re.fullmatch(r"\+?[0-9]{1,9}", text.strip()):
        raise _Bad(f"must be an integer in 0..999999999, got {_shown(text)}")
    return int(text)


def positive_int(text: str) -> int:
    if not re.fullmatch(r"\+?[0-9]{1,9}", text.strip()) or int(text) < 1:
        raise _Bad(f"must be an integer ≥ 1, got {_shown(text)}")
    return int(text)


def servo_id(text: str) -> int:
    from robodcn.config import MAX_SERVO_ID

    if not re.fullmatch(r"[0-9]{1,3}", text.strip()) or int(text) > MAX_SERVO_ID:
        raise _Bad(f"must be a servo id 0..{MAX_SERVO_ID}, got {_shown(text)}")
    return int(text)


def positive_float(text: str) -> float:
    value = _number_or_nan(text)
    if not value > 0:
        raise _Bad(f"must be a positive number, got {_shown(text)}")
    return value


def non_negative_float(text: str) -> float:
    value = _number_or_nan(text)
    if not value >= 0:
        raise _Bad(f"must be a number ≥ 0, got {_shown(text)}")
    return value


def finite_float(text: str) -> float:
    value = _number_or_nan(text)
    if math.isnan(value):
        raise _Bad(f"must be a finite number, got {_shown(text)}")
    return value


def finite_floats(text: str) -> list[float]:
    """``"0.5"`` or ``"0.2,1.5"``: finite numbers (one, or one per segment: see
    :func:`one_or_per_segment`)."""
    values = [_number_or_nan(part) for part in str(text).split(",")]
    if any(math.isnan(v) for v in values):
        raise _Bad(f"must be a finite number or a comma list of them (one per segment), got "
                   f"{_shown(text)}")
    return values


def rate(text: str) -> float:
    from robodcn.config import RATE_RANGE

    value = _number_or_nan(text)
    if not RATE_RANGE[0] <= value <= RATE_RANGE[1]:
        raise _Bad(f"must be within {RATE_RANGE[0]:g}..{RATE_RANGE[1]:g} Hz, got "
                   f"{_shown(text)}")
    return value


def duration(text: str) -> float | str:
    if text.strip() == "auto":
        return "auto"
    value = _number_or_nan(text)
    if not value > 0:
        raise _Bad(f"must be a positive number of seconds or 'auto', got {_shown(text)}")
    return value


def host_bauds() -> list[int]:
    """The Dynamixel baud rates dynamixel-sdk's Python port can open (not 4.5 Mbps)."""
    from robodcn.bus import BAUD_INDEX

    return sorted(set(BAUD_INDEX.values()) - {4_500_000})


def baud(text: str) -> int:
    rates = host_bauds()
    if not re.fullmatch(r"[0-9]{1,8}", text.strip()) or int(text) not in rates:
        raise _Bad(f"must be one of {', '.join(map(str, rates))}, got {_shown(text)}")
    return int(text)


def id_list(text: str) -> list[int]:
    """``"1,2,5-8"`` → [1, 2, 5, 6, 7, 8]."""
    ids: list[int] = []
    for part in filter(None, (p.strip() for p in text.split(","))):
        low, dash, high = part.partition("-")
        if not re.fullmatch(r"[0-9]{1,3}", low) or (dash and not re.fullmatch(r"[0-9]{1,3}",
                                                                               high)):
            raise _Bad(f"ids must look like 1,2,5-8, got {_shown(text)}")
        ids.extend(range(int(low), int(high) + 1) if dash else [int(low)])
    if not ids or any(not 0 <= i <= 252 for i in ids):
        raise _Bad(f"ids must be in 0..252, like 1,2,5-8, got {_shown(text)}")
    return ids


def tcp_port(text: str) -> int:
    if not re.fullmatch(r"[0-9]{1,5}", text.strip()) or int(text) > 65535:
        raise _Bad(f"must be a TCP port 0..65535 (0: any free port), got {_shown(text)}")
    return int(text)


def device(text: str) -> str:
    if not text.strip():
        raise _Bad("needs a serial device path, e.g. /dev/ttyUSB0")
    return text


def log_level(text: str) -> str:
    level = text.strip().upper()
    if level not in LOG_LEVELS:
        raise _Bad(f"must be one of {', '.join(LOG_LEVELS)}, got {_shown(text)}")
    return level


def _number_or_nan(text: str) -> float:
    try:
        return number(text, "")
    except InputError:
        return math.nan


def parse_pose(text: str, option: str, *, radians: bool = False,
               position_only: bool = False, yawed: bool = False) -> tuple[float, ...]:
    """``"x,y,θ"`` → (x, y, θ in radians); InputError naming ``option`` otherwise.

    With ``position_only`` (a 2R arm, θ free) ``"x,y"`` is accepted too, with θ = 0. With
    ``yawed`` (an arm with a base yaw) the pose is ``"x,y,z,pitch"`` → (x, y, z, pitch in
    radians): metres in the base frame, pitch the tool axis's elevation. A wrong count of
    numbers says the arm's pose keys.
    """
    parts = [p.strip() for p in str(text).split(",")]
    try:
        values = [number(p, option) for p in parts]
    except InputError:
        values = []
    unit = "radians" if radians else "degrees"
    if yawed:
        counts: tuple[int, ...] = (4,)
        form = (f"a pose x,y,z,pitch (metres, pitch in {unit}; this arm's pose keys are x, "
                "y, z, pitch)")
    elif position_only:
        counts = (2, 3)
        form = f"a position x,y (metres) or a pose x,y,θ (θ in {unit}, ignored by this arm)"
    else:
        counts = (3,)
        form = f"a pose x,y,θ (metres, {unit})"
    if len(values) not in counts:
        count = f" ({len(values)} numbers)" if yawed and values else ""
        raise InputError(f"{option} must be {form}, got {_shown(text)}{count}",
                         field=option.lstrip("-"), value=text)
    if len(values) == 2:
        values.append(0.0)
    angle = values[-1] if radians else math.radians(values[-1])
    from robodcn.contract.fields import MAX_ANGLE

    if 2 * math.pi * (1 + 1e-12) < abs(angle) <= MAX_ANGLE \
            and not (position_only and len(parts) == 2):       # beyond MAX_ANGLE: an error
        _warn_beyond_a_turn(option, values[-1], angle, radians)
    return (*values[:-1], angle)


def _warn_beyond_a_turn(option: str, typed: float, angle: float, radians: bool) -> None:
    """A pose angle beyond a full turn names the orientation of its wrap: say which is taken
    (the path still turns the shorter way unless --turn says otherwise)."""
    import warnings

    from robodcn.errors import RobodcnWarning

    wrapped = math.remainder(angle, 2 * math.pi)
    shown = (f"{typed:g} rad is {math.degrees(angle):.6g}°" if radians
             else f"{typed:g}°")
    warnings.warn(RobodcnWarning(
        f"{option}: the angle {shown}, beyond a full turn; the pose's orientation is that of "
        f"{math.degrees(wrapped) + 0.0:.6g}°" + (" (did you mean degrees? drop --radians)"
                                                   if radians and abs(typed) > 2 * math.pi
                                                   else "")), stacklevel=3)


#: The arm's own poses a pose option also takes by name.
POSE_NAMES = ("home", "rest")


def arm_pose(arm, text: str, option: str, *, radians: bool = False) -> tuple[float, ...]:
    """:func:`parse_pose` with the form ``arm`` takes: ``x,y,z,pitch`` on a yawed arm,
    ``x,y`` or ``x,y,θ`` on a 2-joint arm, ``x,y,θ`` otherwise; or one of the arm's own
    poses by name (``home``, ``rest``: the ``[arm.home]`` / ``[arm.rest]`` tables)."""
    name = str(text).strip().lower()
    if name in POSE_NAMES:
        pose = arm.home if name == "home" else arm.rest
        if pose is None:
            raise InputError(f"{option} rest: this arm file has no [arm.rest] pose; give "
                             "the pose as numbers or add the table", field=option.lstrip("-"),
                             value=text)
        return tuple(float(v) for v in pose)
    try:
        return parse_pose(text, option, radians=radians, position_only=not arm.yawed and
                          arm.dof == 2, yawed=arm.yawed)
    except InputError as exc:
        if any(c.isalpha() for c in name.replace("e", "")):
            raise InputError(f"{exc}, or one of the arm's poses by name: "
                             f"{', '.join(POSE_NAMES)}", field=exc.field,
                             value=text) from None
        raise


def check_output_path(path: str, option: str, *, overwrite: bool = True) -> Path:
    """A file ``option`` may write: its directory exists and is writable, it is not a
    directory, and an existing file is writable (and, unless ``overwrite``, refused: the
    user passes ``--force``). Checked before any planning, motion or bus I/O."""
    if not str(path).strip():
        raise InputError(f"{option} needs a file name", field=option, value=path)
    out = Path(path)
    parent = out.parent
    if out.is_dir():
        raise InputError(f"{option} {path}: is a directory, give a file name", field=option,
                         value=path)
    if not parent.is_dir():
        raise InputError(f"{option} {path}: no such directory {str(parent)!r}", field=option,
                         value=path)
    if out.exists() and not overwrite:
        raise InputError(f"{option} {path}: exists; pass --force to overwrite it",
                         field=option, value=path)
    writable = os.access(parent, os.W_OK | os.X_OK) and (not out.exists()
                                                         or os.access(out, os.W_OK))
    if not writable:
        raise InputError(f"{option} {path}: not writable", field=option, value=path)
    return out


def check_plot_path(path: str, option: str = "--plot") -> Path:
    """:func:`check_output_path`, with an image format matplotlib can write (by suffix)."""
    out = check_output_path(path, option)
    suffix = out.suffix.lower().lstrip(".")
    if suffix:
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        formats = FigureCanvasAgg.get_supported_filetypes()
        if suffix not in formats:
            raise InputError(f"{option} {path}: cannot draw .{suffix} files; use "
                             f"{', '.join('.' + f for f in sorted(formats))}", field=option,
                             value=path)
    return out


def choice_list(text: str, option: str, allowed: Sequence[str]) -> list[str]:
    """``"a"`` or ``"a,b"``: the comma list, each one of ``allowed``."""
    items = [t.strip() for t in str(text).split(",")]
    for item in items:
        if item not in allowed:
            raise InputError(f"{option}: {_shown(item)} is not one of {', '.join(allowed)}",
                             field=option, value=text)
    return items


def split_list(text: str, option: str, allowed: Sequence[str], segments: int
               ) -> str | list[str]:
    """``"a"`` or ``"a,b"`` (one per segment), each one of ``allowed``."""
    return one_or_per_segment(choice_list(text, option, allowed), option, segments)


def one_or_per_segment(items: list[Any], option: str, segments: int) -> Any:
    """The one item (for every segment), or the list when it has one per segment;
    InputError naming ``option`` otherwise."""
    if len(items) == 1:
        return items[0]
    if len(items) != segments:
        raise InputError(f"{option} takes one value or one per segment ({segments} here: "
                         f"--from → {'--via … → ' if segments > 1 else ''}--to), got "
                         f"{len(items)}", field=option, value=",".join(map(str, items)))
    return items


# -- option groups -----------------------------------------------------------------------------

def add_logging_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("logging")
    g.add_argument("-v", "--verbose", action="count", default=0,
                   help="log more: -v info, -vv debug (to stderr)")
    g.add_argument("--log-level", type=log_level, metavar="LEVEL",
                   help=f"log level: {', '.join(LOG_LEVELS)} (default WARNING; overrides -v)")


class Deprecated(argparse.Action):
    """An old spelling of an option (``scan --config`` for ``--arm``): stores into the new
    option's ``dest`` and says on stderr which option to use instead."""

    def __call__(self, parser, namespace, values, option_string=None):
        new = "--" + self.dest.replace("_", "-")
        print(f"robodcn: warning: {parser.prog} {option_string} is deprecated, use {new}",
              file=sys.stderr)
        setattr(namespace, self.dest, values)


class _DeprecatedPort(argparse.Action):
    """``--port DEV`` on move/scan: the old spelling of ``--device`` (a note on stderr)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"robodcn: note: {parser.prog} {option_string} is deprecated, use --device "
              "(--port is the TCP port of 'robodcn serve')", file=sys.stderr)
        setattr(namespace, self.dest, values)


def add_device_options(p: argparse.ArgumentParser, *, default_help: str,
                       repeat_baud: bool = False) -> None:
    """--device DEV (and its deprecated spelling --port) and --baud (repeatable for scan)."""
    g = p.add_argument_group("bus")
    g.add_argument("--device", type=device, metavar="DEV",
                   help=f"serial device ({default_help})")
    g.add_argument("--port", type=device, dest="device", metavar="DEV", action=_DeprecatedPort,
                   help="deprecated spelling of --device")
    if repeat_baud:
        g.add_argument("--baud", type=baud, action="append",
                       help="baud rate to try (repeatable); default: the config's, else "
                            "1000000")
    else:
        g.add_argument("--baud", type=baud, help="baud rate (default: the arm's [bus] baud)")


def configure_logging(args: argparse.Namespace) -> None:
    """-v/-vv/--log-level → the level of the ``robodcn`` loggers; one handler on stderr.

    The default is WARNING, or the command's ``log_default`` (``serve``: INFO, its request
    log). The handler sits on the root logger (so records still propagate to any other
    handler, pytest's included, and a command that checks for configured logging finds it).
    """
    verbose = getattr(args, "verbose", 0) or 0
    default = getattr(args, "log_default", "WARNING")
    level = getattr(args, "log_level", None) or (
        default if not verbose else ("INFO", "DEBUG")[min(1, verbose - 1)])
    root = logging.getLogger()
    for handler in [h for h in root.handlers if isinstance(h, _StderrHandler)]:
        root.removeHandler(handler)
    handler = _StderrHandler()
    handler.setFormatter(logging.Formatter("robodcn: %(levelname)s: %(name)s: %(message)s"))
    root.addHandler(handler)
    logging.getLogger("robodcn").setLevel(level)


class _StderrHandler(logging.StreamHandler):
    """Writes to whatever ``sys.stderr`` is at the time (so captured stderr works)."""

    @property
    def stream(self):  # type: ignore[override]
        return sys.stderr

    @stream.setter
    def stream(self, value) -> None:
        pass


def load_arm(args: argparse.Namespace, option: str = "--arm"):
    """The arm ``--arm`` names: a TOML file, or an example name (``arm3r``, ``arm2r``);
    absent: ``$ROBODCN_ARM``, else ``configs/arm3r.toml`` here, else the arm3r example
    (:func:`robodcn.workflow.examples.resolve_arm_path`). Every command loads its arm here."""
    from robodcn.config import load_arm as load
    from robodcn.workflow.examples import resolve_arm_path

    return load(resolve_arm_path(getattr(args, "arm", None), option=option))


def add_arm_option(p: argparse.ArgumentParser) -> None:
    from robodcn.workflow.examples import EXAMPLES

    p.add_argument("--arm", metavar="FILE|NAME",
                   help=f"arm TOML file or example name ({', '.join(EXAMPLES)}); default: "
                        f"$ROBODCN_ARM, else {DEFAULT_ARM} here, else the arm3r example")


__all__ = ["DEFAULT_ARM", "NEGATIVE_POSE", "Deprecated", "Parser", "add_arm_option",
           "add_device_options", "add_logging_options", "arm_pose", "baud",
           "check_output_path", "check_plot_path", "choice_list", "configure_logging",
           "device", "duration", "finite_float", "finite_floats", "host_bauds", "id_list",
           "load_arm", "non_negative_float", "non_negative_int", "number",
           "one_or_per_segment", "parse_pose", "positive_float", "positive_int", "rate",
           "servo_id", "split_list", "tcp_port"]
