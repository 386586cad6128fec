"""``robodcn scan``: list the servos on a serial device (id, model, firmware, baud).

Finding no servo is a bus fault (exit 4) with a one-line message: nothing answered. The USB
latency timer is lowered to 1 ms first when its sysfs file is writable (and said so).
"""

from __future__ import annotations

import argparse
import json
import sys

from robodcn.cli import options
from robodcn.cli.exit_codes import Exit
from robodcn.cli.output import emit
from robodcn.errors import InputError


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "scan", help="list the servos on a serial device (id, model, firmware, baud)",
        description="Ping for Dynamixel Protocol 2.0 servos on DEV at each baud rate given. "
                    "Without --ids a broadcast ping is used (about 0.8 s per baud rate). "
                    "Exit code 4 when no servo answers.")
    options.add_device_options(p, default_help="default: the [bus] port of --arm",
                               repeat_baud=True)
    p.add_argument("--arm", metavar="FILE|NAME",
                   help="arm TOML (or example name) whose [bus] gives device and baud")
    p.add_argument("--config", dest="arm", metavar="FILE|NAME", action=options.Deprecated,
                   help="deprecated spelling of --arm")
    p.add_argument("--all-bauds", action="store_true",
                   help="try every baud rate the Python SDK can set (9600 .. 4000000)")
    p.add_argument("--ids", type=options.id_list, help="ping only these ids, e.g. 1,2,5-8")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from robodcn.bus import lower_latency_timer, scan

    device, bauds = args.device, args.baud
    if args.arm is not None:
        arm = options.load_arm(args)
        device = device if device is not None else arm.bus.port
        bauds = bauds or [arm.bus.baud]
    if not device:
        raise InputError("scan needs --device DEV (or --arm with a [bus] port)",
                         field="--device")
    if args.all_bauds:
        bauds = options.host_bauds()
    bauds = bauds or [1_000_000]
    note = lower_latency_timer(device).message(device)
    if note:
        print(f"robodcn: {note}", file=sys.stderr, flush=True)
    found = scan(device, bauds, ids=args.ids)
    if args.json:
        emit(json.dumps({"port": device, "device": device,
                         "servos": [s.to_dict() for s in found]}, indent=2) + "\n")
    if not found:
        print(f"robodcn: no servo answered on {device} at {', '.join(map(str, bauds))} baud"
              + (f" (ids {_ids_text(args.ids)})" if args.ids else ""), file=sys.stderr)
        return Exit.FAULT
    if args.json:
        return Exit.DONE
    lines = [f"{'ID':>3}  {'model':<12} {'number':>6}  {'firmware':>8}  {'baud':>8}"]
    for s in found:
        firmware = "?" if s.firmware is None else str(s.firmware)
        lines.append(f"{s.id:>3}  {s.model or 'unknown':<12} {s.model_number:>6}  "
                     f"{firmware:>8}  {s.baud:>8}")
    emit("\n".join(lines) + "\n")
    return Exit.DONE


def _ids_text(ids: list[int]) -> str:
    return ",".join(map(str, ids)) if len(ids) <= 8 else f"{ids[0]}-{ids[-1]}"
