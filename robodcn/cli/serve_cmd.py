"""``robodcn serve``: the HTTP trajectory service (robodcn.http).

The execution options ``move`` has for streaming (``--compensation``, ``--tracking-limit``,
``--recover``) are declared once, by :func:`robodcn.cli.motion_cmd.add_execution_options`;
``serve`` takes the same declarations and applies them to every move it starts
(``GET /v1/arm`` says what is in force).

Exit code 6 (:data:`robodcn.cli.exit_codes.Exit.CANNOT_SERVE`) when the TCP address cannot be
bound (in use, not available).
"""

from __future__ import annotations

import argparse
import math
import os
from typing import Any

from robodcn.cli import motion_cmd, options

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
                    "POST must then carry 'Authorization: Bearer TOKEN'. Logs one line per "
                    "request. Exits 6 when the address cannot be bound (e.g. in use).")
    options.add_arm_option(p)
    p.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    p.add_argument("--port", type=options.tcp_port, default=8080,
                   help="TCP port (default 8080; 0 = any)")
    p.add_argument("--token", default=os.environ.get("ROBODCN_TOKEN"),
                   help="bearer token for POST requests, 1-256 visible ASCII characters "
                        "(default: $ROBODCN_TOKEN)")
    target = p.add_mutually_exclusive_group()
    target.add_argument("--sim", action="store_true", help="serve a simulated arm")
    target.add_argument("--device", metavar="DEV",
                        help="servo serial device (default: the arm's [bus] port)")
    p.add_argument("--baud", type=options.baud, help="baud rate (default: the arm's [bus] baud)")
    add_streaming_options(p)
    p.set_defaults(func=_cmd_serve, log_default="INFO")  # the request log


def _cmd_serve(args: argparse.Namespace) -> int:
    from robodcn.http import serve

    arm = options.load_arm(args)
    serve(arm, host=args.host, port=args.port, token=args.token, sim=args.sim,
          device=args.device, baud=args.baud, execution=execution_options(args),
          ready=lambda url: print(f"robodcn: serving {arm.name!r} on {url}", flush=True))
    return 0
