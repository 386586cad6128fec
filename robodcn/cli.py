"""The ``robodcn`` command line: one argparse subparser per subcommand.

Each subcommand is a ``_cmd_<name>(args) -> int`` function registered by a
``_add_<name>(subparsers)`` function; ``main`` turns :class:`robodcn.errors.RobodcnError`
into one ``robodcn: <message>`` line on stderr and the error's exit code.

Subcommands
    scan    list the servos on a port: id, model, firmware, baud
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

from robodcn.errors import InputError, RobodcnError


def _id_list(text: str) -> list[int]:
    """``"1,2,5-8"`` → [1, 2, 5, 6, 7, 8]."""
    ids: list[int] = []
    try:
        for part in filter(None, (p.strip() for p in text.split(","))):
            low, dash, high = part.partition("-")
            ids.extend(range(int(low), int(high) + 1) if dash else [int(low)])
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"ids must look like 1,2,5-8, got {text!r}") from None
    bad = [i for i in ids if not 0 <= i <= 252]
    if bad or not ids:
        raise argparse.ArgumentTypeError(f"ids must be in 0..252, got {text!r}")
    return ids


# -- scan --------------------------------------------------------------------------------------

def _add_scan(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "scan", help="list the servos on a port (id, model, firmware, baud)",
        description="Ping for Dynamixel Protocol 2.0 servos on PORT at each baud rate given. "
                    "Without --ids a broadcast ping is used (about 0.8 s per baud rate).")
    p.add_argument("--port", help="serial device; default: the [bus] port of --config")
    p.add_argument("--config", help="arm TOML whose [bus] gives port and baud")
    p.add_argument("--baud", type=int, action="append",
                   help="baud rate to try (repeatable); default: the config's, else 1000000")
    p.add_argument("--all-bauds", action="store_true",
                   help="try every baud rate the Python SDK can set (9600 .. 4000000)")
    p.add_argument("--ids", type=_id_list, help="ping only these ids, e.g. 1,2,5-8")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=_cmd_scan)


def _cmd_scan(args: argparse.Namespace) -> int:
    from robodcn.bus import BAUD_INDEX, scan

    port, bauds = args.port, args.baud
    if args.config:
        from robodcn.config import load_arm

        arm = load_arm(args.config)
        port = port or arm.bus.port
        bauds = bauds or [arm.bus.baud]
    if not port:
        raise InputError("scan needs --port (or --config with a [bus] port)", field="port")
    if args.all_bauds:
        bauds = sorted(b for b in BAUD_INDEX.values() if b != 4_500_000)
    found = scan(port, bauds or [1_000_000], ids=args.ids)
    if args.json:
        print(json.dumps({"port": port, "servos": [s.to_dict() for s in found]}, indent=2))
        return 0
    if not found:
        print(f"no servos answered on {port} at {', '.join(map(str, bauds or [1_000_000]))} "
              "baud", file=sys.stderr)
        return 1
    print(f"{'ID':>3}  {'model':<12} {'number':>6}  {'firmware':>8}  {'baud':>8}")
    for s in found:
        firmware = "?" if s.firmware is None else str(s.firmware)
        print(f"{s.id:>3}  {s.model or 'unknown':<12} {s.model_number:>6}  {firmware:>8}  "
              f"{s.baud:>8}")
    return 0


# -- entry point -------------------------------------------------------------------------------

def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="robodcn", description="Plan planar rigid motions with dual complex numbers and "
                                    "stream them to Dynamixel servos.")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    _add_scan(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 ok, RobodcnError.exit_code on error)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except RobodcnError as exc:
        print(f"robodcn: {exc.message}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("robodcn: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
