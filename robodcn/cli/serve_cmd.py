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
    add_zenoh_options(p)
    p.set_defaults(func=_cmd_serve, log_default="INFO")  # the request log


def add_zenoh_options(p: argparse.ArgumentParser) -> None:
    """``--zenoh`` and its options (the Zenoh face, :mod:`robodcn.zenoh`)."""
    g = p.add_argument_group("Zenoh face (pip install 'robodcn[zenoh]'; README \"Many arms "
                             "over Zenoh\", \"ROS 2 without ROS\")")
    g.add_argument("--zenoh", action="store_true",
                   help="also serve the arm on Zenoh: robodcn/<name>/{state,op/*,follow/"
                        "target} and a liveliness token (peer mode, loopback only unless "
                        "--zenoh-config authenticates)")
    g.add_argument("--zenoh-connect", action="append", default=[], metavar="ENDPOINT",
                   help="connect to a router or peer, e.g. tcp/192.168.1.7:7447 "
                        "(repeatable; default: this host's router, tcp/127.0.0.1:7447, "
                        "unless --zenoh-config is given)")
    g.add_argument("--zenoh-listen", action="append", default=[], metavar="ENDPOINT",
                   help="listen on ENDPOINT (repeatable; default tcp/127.0.0.1:0); off "
                        "loopback only with --zenoh-config giving TLS or user/password")
    g.add_argument("--zenoh-config", metavar="FILE",
                   help="a Zenoh JSON5 configuration (TLS, user/password, routers)")
    g.add_argument("--zenoh-scout", action="store_true",
                   help="multicast scouting on (off by default, as rmw_zenoh)")
    g.add_argument("--name", help="the arm's name in the key space (default: its [arm] name)")
    g.add_argument("--ros2", action="store_true",
                   help="also a ROS 2 node on rmw_zenoh's wire (implies --zenoh): "
                        "/joint_states, /<controller>/joint_trajectory and the "
                        "FollowJointTrajectory action (Jazzy interfaces)")
    g.add_argument("--ros-domain-id", type=int, default=None,
                   help="ROS domain (default $ROS_DOMAIN_ID, else 0)")
    g.add_argument("--ros-controller", default="arm_controller",
                   help="controller name of the ROS topics and action (default "
                        "arm_controller)")


def connect_endpoints(args: argparse.Namespace) -> tuple[str, ...]:
    """``--zenoh-connect``'s endpoints; none given and no ``--zenoh-config``: this host's
    router (:data:`robodcn.zenoh.options.DEFAULT_ROUTER`), as rmw_zenoh connects."""
    from robodcn.zenoh.options import DEFAULT_ROUTER

    if args.zenoh_connect or args.zenoh_config:
        return tuple(args.zenoh_connect)
    return (DEFAULT_ROUTER,)


def zenoh_options(args: argparse.Namespace) -> Any:
    """The :class:`~robodcn.zenoh.ZenohOptions` of ``serve``'s arguments, or None without
    ``--zenoh``/``--ros2`` (a Zenoh option alone is a usage error naming it)."""
    from robodcn.zenoh.options import ZenohOptions

    if not (args.zenoh or args.ros2):
        given = [name for name, value in (
            ("--zenoh-connect", args.zenoh_connect), ("--zenoh-listen", args.zenoh_listen),
            ("--zenoh-config", args.zenoh_config), ("--zenoh-scout", args.zenoh_scout),
            ("--name", args.name), ("--ros-domain-id", args.ros_domain_id)) if value]
        if given:
            raise InputError(f"{given[0]} is an option of the Zenoh face: add --zenoh",
                             field=given[0], value=None)
        return None
    if args.processes > 1:
        raise InputError("--zenoh serves from one process: drop --processes",
                         field="--processes", value=args.processes)
    if args.ros2 and args.plan_only:
        raise InputError("--ros2 makes the arm a ROS 2 node: give --sim or --device, not "
                         "--plan-only", field="--ros2", value=True)
    return ZenohOptions(connect=connect_endpoints(args), listen=tuple(args.zenoh_listen),
                        config_file=args.zenoh_config, scout=args.zenoh_scout,
                        name=args.name, ros2=args.ros2, ros_domain=args.ros_domain_id,
                        ros_controller=args.ros_controller)


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
    zenoh = zenoh_options(args)
    arm = options.load_arm(args)
    faces = []
    if zenoh is not None:
        from robodcn.zenoh import face

        faces.append(lambda server: face(server, zenoh, url=server.url))
        name = zenoh.name or arm.name
        print(f"robodcn: on Zenoh as robodcn/{name}"
              + (f" and ROS 2 node robodcn_{name} (domain {zenoh.domain})" if zenoh.ros2
                 else ""), flush=True)
    serve(arm, host=args.host, port=args.port, token=args.token,
          allow_hosts=tuple(args.allow_host), sim=args.sim,
          device=args.device, baud=args.baud, execution=execution_options(args),
          plan_only=args.plan_only, processes=args.processes, faces=faces,
          ready=lambda url: print(f"robodcn: serving {arm.name!r} on {url}", flush=True))
    return 0
