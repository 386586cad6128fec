"""``robodcn fleet ls`` and ``robodcn fleet state ARM…``: the arms served on Zenoh.

``ls`` prints one line per live arm (name, host, moving or at rest, pose); ``state`` prints
the named arms' state as it arrives (one JSON line per sample, ``--count`` samples in all,
or until interrupted). Both take the Zenoh options of ``serve`` that reach a network:
``--zenoh-connect`` (repeatable), ``--zenoh-config`` and ``--zenoh-scout``.
"""

from __future__ import annotations

import argparse
import json
import threading
import time
from typing import Any

from robodcn.errors import InputError


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("fleet", help="list and watch the arms served on Zenoh",
                              description="The arms served with `robodcn serve --zenoh` on "
                                          "the Zenoh network reached (pip install "
                                          "'robodcn[zenoh]').")
    sub = p.add_subparsers(dest="fleet_command", metavar="ACTION", required=True)
    ls = sub.add_parser("ls", help="the live arms: name, host, moving or at rest, pose")
    state = sub.add_parser("state", help="print the named arms' state live (JSON lines)")
    state.add_argument("arms", nargs="+", metavar="ARM")
    state.add_argument("--count", type=int, default=0,
                       help="stop after this many samples (default: until interrupted)")
    for q in (ls, state):
        q.add_argument("--zenoh-connect", action="append", default=[], metavar="ENDPOINT",
                       help="a router or peer to reach the arms through (repeatable; "
                            "default tcp/127.0.0.1:7447, this host's router)")
        q.add_argument("--zenoh-config", metavar="FILE", help="a Zenoh JSON5 configuration")
        q.add_argument("--zenoh-scout", action="store_true", help="multicast scouting on")
        q.add_argument("--timeout", type=float, default=2.0,
                       help="seconds to wait for answers (default 2)")
    ls.set_defaults(func=_cmd_ls)
    state.set_defaults(func=_cmd_state)


def _session(args: argparse.Namespace) -> Any:
    from robodcn.cli.serve_cmd import connect_endpoints
    from robodcn.zenoh.options import ZenohOptions
    from robodcn.zenoh.session import open_session

    return open_session(ZenohOptions(connect=connect_endpoints(args),
                                     config_file=args.zenoh_config, scout=args.zenoh_scout))


def _cmd_ls(args: argparse.Namespace) -> int:
    from robodcn.zenoh.fleet import list_arms

    session = _session(args)
    try:
        time.sleep(min(args.timeout, 0.5))  # routes to the peers are set up
        entries = list_arms(session, args.timeout)
    finally:
        session.close()
    if not entries:
        print("no arm is live on this Zenoh network")
        return 0
    for e in entries:
        where = e.host or "?"
        if e.error is not None:
            print(f"{e.name}\t{where}\terror: {e.error}")
            continue
        motion = "moving" if e.moving else "at rest"
        pose = ", ".join(f"{v:.4f}" for v in e.pose or [])
        print(f"{e.name}\t{where}\t{motion}\tpose [{pose}]")
    return 0


def _cmd_state(args: argparse.Namespace) -> int:
    from robodcn.zenoh.fleet import follow_state, live_names

    if args.count < 0:
        raise InputError(f"--count must be ≥ 0, got {args.count}", field="--count",
                         value=args.count)
    session = _session(args)
    done = threading.Event()
    seen = [0]
    lock = threading.Lock()

    def show(name: str, state: dict[str, Any]) -> None:
        with lock:
            if done.is_set():
                return
            print(json.dumps({"arm": name, **state}), flush=True)
            seen[0] += 1
            if args.count and seen[0] >= args.count:
                done.set()

    try:
        time.sleep(min(args.timeout, 0.5))
        live = live_names(session, args.timeout)
        missing = [a for a in args.arms if a not in live]
        if missing:
            raise InputError(f"arm {missing[0]!r} is not live on this Zenoh network (live: "
                             f"{', '.join(live) or 'none'})", field="ARM", value=missing[0])
        follow_state(session, args.arms, show)
        while not done.wait(0.2):
            pass
    except KeyboardInterrupt:
        pass
    finally:
        done.set()
        session.close()
    return 0
