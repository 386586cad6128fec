"""``robodcn serve``: the HTTP trajectory service (robodcn.http_server).

Exit code 6 (:data:`robodcn.cli.exit_codes.Exit.CANNOT_SERVE`) when the TCP address cannot be
bound (in use, not available).
"""

from __future__ import annotations

import argparse
import os

from robodcn.cli import options


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
    p.set_defaults(func=_cmd_serve, log_default="INFO")  # the request log


def _cmd_serve(args: argparse.Namespace) -> int:
    from robodcn.http import serve

    arm = options.load_arm(args)
    serve(arm, host=args.host, port=args.port, token=args.token, sim=args.sim,
          device=args.device, baud=args.baud,
          ready=lambda url: print(f"robodcn: serving {arm.name!r} on {url}", flush=True))
    return 0
