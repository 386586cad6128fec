"""``robodcn serve``: the HTTP trajectory service (robodcn.http).

The execution options ``move`` has for streaming (``--compensation``, ``--tracking-limit``,
``--recover``) are declared once, by :func:`robodcn.cli.motion_cmd.add_execution_options`;
``serve`` takes the same declarations and applies them to every move it starts
(``GET /v1/arm`` says what is in force).

Exit code 6 (:data:`robodcn.cli.exit_codes.Exit.CANNOT_SERVE`) when the TCP address cannot be
bound (in use, not available), or when a worker process of ``--processes N`` ends by itself.
``--processes`` above 1 without ``--plan-only`` is a usage error (exit 2) before anything
opens: only one process can own an arm's bus.
"""

from __future__ import annotations

import argparse
import math
import os
from typing import Any

from robodcn.cli import motion_cmd, options
from robodcn.errors import InputError

#: The execution options of ``move`` that ``serve`` takes too (argparse dests).
EXECUTION_OPTIONS = ("compensation", "tracking_limit", "recover")


def add_streaming_options(p: argparse.ArgumentParser) -> None:
    """``move``'s declarations of :data:`EXECUTION_OPTIONS` (same help, type, default),
    taken from :func:`motion_cmd.add_execution_options` rather than written again."""
    scratch = argparse.ArgumentParser(add_help=False)
    motion_cmd.add_execution_options(scratch)
    group = p.add_argument_group("execution (as for move; every move the service starts)")
    for action in scratch._actions:
        if action.dest in EXECUTION_OPTIONS:
            group._add_action(action)


def execution_options(args: argparse.Namespace) -> dict[str, Any]:
    """The :class:`~robodcn.stream.ExecutionOptions` fields the options give (SI)."""
    return {"compensation": motion_cmd.compensation(args),
            "tracking_limit": math.radians(args.tracking_limit), "recover": args.recover}


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "serve", help="run the HTTP trajectory service",
        description="Serve the HTTP API (GET /openapi.json lists it). Binds 127.0.0.1 by "
                    "default; any other address needs --token (or ROBODCN_TOKEN), and every "
                    "POST, PUT and DELETE must then carry 'Authorization: Bearer TOKEN'. "
                    "Answers only requests naming it (Host 127.0.0.1:PORT, localhost:PORT, "
                    "[::1]:PORT, the bound address, or an --allow-host name) and refuses "
                    "requests from other web pages' origins (403). Logs one line per "
                    "request. Exits 6 when the address cannot be bound (e.g. in use).")
    options.add_arm_option(p)
    p.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    p.add_argument("--port", type=options.tcp_port, default=8080,
                   help="TCP port (default 8080; 0 = any)")
    p.add_argument("--token", default=os.environ.get("ROBODCN_TOKEN"),
                   help="bearer token for POST, PUT and DELETE requests, 1-256 visible "
                        "ASCII characters (default: $ROBODCN_TOKEN)")
    p.add_argument("--allow-host", action="append", default=[], metavar="NAME",
                   help="also answer requests naming NAME (a host name or address, no port) "
                        "in their Host and Origin, e.g. the machine's LAN name behind "
                        "--host 0.0.0.0; repeatable (default: 127.0.0.1, localhost, [::1] "
                        "and the bound address only: a page re-pointing its own name at "
                        "this machine, DNS rebinding, is refused)")
    target = p.add_mutually_exclusive_group()
    target.add_argument("--sim", action="store_true", help="serve a simulated arm")
    target.add_argument("--device", metavar="DEV",
                        help="servo serial device (default: the arm's [bus] port)")
    target.add_argument("--plan-only", action="store_true",
                        help="attach no arm: serve planning only (POST /v1/trajectories; "
                             "moves, stop and state answer 503)")
    p.add_argument("--processes", type=options.positive_int, default=1, metavar="N",
                   help="worker processes answering on the port (default 1; --plan-only "
                        "only): planning is CPU-bound Python, so plans/s grow with processes "
                        "up to the cores; limits hold per process")
    p.add_argument("--baud", type=options.baud, help="baud rate (default: the arm's [bus] baud)")
    add_streaming_options(p)
    p.set_defaults(func=_cmd_serve, log_default="INFO")  # the request log


def _cmd_serve(args: argparse.Namespace) -> int:
    from robodcn.http import serve

    if args.processes > 1 and not args.plan_only:
        device = args.device or "the arm's [bus] port"
        attached = "--sim" if args.sim else f"device {device}"
        raise InputError(f"--processes {args.processes} needs --plan-only: with an arm "
                         f"attached ({attached}) only one process can own its bus",
                         field="--processes", value=args.processes)
    if args.plan_only and args.baud is not None:
        raise InputError("--baud is for a device; --plan-only opens none", field="--baud",
                         value=args.baud)
    arm = options.load_arm(args)
    serve(arm, host=args.host, port=args.port, token=args.token,
          allow_hosts=tuple(args.allow_host), sim=args.sim,
          device=args.device, baud=args.baud, execution=execution_options(args),
          plan_only=args.plan_only, processes=args.processes,
          ready=lambda url: print(f"robodcn: serving {arm.name!r} on {url}", flush=True))
    return 0
