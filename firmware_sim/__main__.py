"""``python -m firmware_sim``: serve a simulated Dynamixel bus on a pseudo-terminal.

Prints the device path as the first stdout line, then serves until SIGINT/SIGTERM.

Fault flags take ``TARGET[:key=value,...]`` where TARGET is a servo ID or ``bus``::

    --drop 2:n=3            drop servo 2's next 3 replies (n=0: every reply)
    --drop bus:p=0.05       drop 5 % of all replies
    --delay 1:ms=40         delay servo 1's next reply by 40 ms
    --corrupt-crc 3         corrupt servo 3's next reply CRC
    --wrong-id 2:to=9       servo 2's next reply carries ID 9
    --truncate-fast bus:keep=1,n=0   cut every fast-read chain after one block
    --split bus:pieces=3,gap_ms=0.5  write every reply in three pieces
    --trip 2:bits=32,at=1.5          overload servo 2 1.5 s after start
    --stale bus:of=98,read=70,n=2    answer the next two reads of 70 with the last Bus
                                     Watchdog reply first (a straggler)

Physics (default): the firmware's controller drives a DC motor, gearbox and load;
``--dynamics off`` gives the kinematic model (Present Position = the profile).
``--arm configs/arm3r.toml`` (or a name) makes the servos drive that arm's rigid bodies,
with its gripper servo if it has one: ``--arm omx`` is the OpenMANIPULATOR-X, ids 11-14
(yaw, shoulder, elbow, wrist) under gravity and the gripper 15, at 1 Mbps;
``--control PATH`` serves "move ID TICKS" (a hand turning the shaft, torque off), "push ID
NM", "obstacle ID DEG" (a joint's angle; for a servo that is no joint, like the gripper,
its own angle, tick 2048 = 0°: an object in the jaws), "voltage ID V", "indirect ID MODE"
and "get ID" on a UNIX socket, for any servo of the bus.

``--indirect off`` (or per ID, ``--indirect 2:off``) makes a servo acknowledge a WRITE to
Indirect Address (168-222, 578-632) without storing it, like an older firmware or a clone;
``unresolved`` stores the map but Indirect Data does not follow it.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from collections.abc import Callable

from firmware_sim.bus import SimBus
from firmware_sim.bus_config import SimBusConfig
from firmware_sim.control_socket import ControlServer
from firmware_sim.faults import FaultInjector


def _int_list(text: str) -> list[int]:
    try:
        return [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--ids must be comma-separated integers, got {text!r}")\
            from None


def _per_id(text: str, what: str) -> str | dict[int, str]:
    """``value`` or ``id:value,id:value``."""
    if ":" not in text:
        return text
    out = {}
    for item in text.split(","):
        key, _, value = item.partition(":")
        try:
            out[int(key)] = value
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} entry {item!r}: expected ID:VALUE")\
                from None
    return out


def _spec(text: str) -> tuple[int | None, dict[str, float]]:
    target, _, rest = text.partition(":")
    if target in ("bus", "all"):
        servo_id = None
    else:
        try:
            servo_id = int(target)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"fault target {target!r} must be a servo ID or 'bus'") from None
    opts: dict[str, float] = {}
    for item in filter(None, rest.split(",")):
        key, eq, value = item.partition("=")
        if not eq:
            raise argparse.ArgumentTypeError(f"fault option {item!r}: expected key=value")
        try:
            opts[key.strip()] = float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"fault option {item!r}: value is not a number")\
                from None
    return servo_id, opts


_FAULT_KEYS = {"drop": set(), "delay": {"ms"}, "corrupt_crc": set(), "wrong_id": {"to"},
               "truncate_fast": {"keep"}, "split": {"pieces", "gap_ms"}, "trip": {"bits", "at"},
               "stale": {"of", "read"}}


def _arm(faults: FaultInjector, kind: str, servo_id: int | None,
         opts: dict[str, float]) -> Callable[[], None] | None:
    """Arm one CLI fault; a trip is returned as a callable to run at its time."""
    allowed = _FAULT_KEYS[kind] | ({"n", "p"} if kind != "trip" else set())
    unknown = set(opts) - allowed
    if unknown:
        raise SystemExit(f"firmware_sim: --{kind.replace('_', '-')}: unknown option(s) "
                         f"{sorted(unknown)}; allowed {sorted(allowed)}")
    n = int(opts.get("n", 0 if "p" in opts else 1))
    common = {"times": n if n > 0 else None, "probability": opts.get("p", 1.0)}
    if kind == "drop":
        faults.drop(servo_id, **common)
    elif kind == "delay":
        faults.delay(opts.get("ms", 40.0) / 1e3, servo_id, **common)
    elif kind == "corrupt_crc":
        faults.corrupt_crc(servo_id, **common)
    elif kind == "wrong_id":
        if "to" not in opts:
            raise SystemExit("firmware_sim: --wrong-id needs to=ID")
        faults.wrong_id(int(opts["to"]), servo_id, **common)
    elif kind == "truncate_fast":
        if servo_id is not None:
            raise SystemExit("firmware_sim: --truncate-fast cuts the whole fast-read chain; "
                             f"use target 'bus', not servo {servo_id}")
        faults.truncate_fast(int(opts.get("keep", 1)), **common)
    elif kind == "split":
        faults.split(int(opts.get("pieces", 2)), opts.get("gap_ms", 0.5) / 1e3, servo_id,
                     **common)
    elif kind == "stale":
        if "of" not in opts:
            raise SystemExit("firmware_sim: --stale needs of=ADDRESS (the earlier read whose "
                             "reply is sent again)")
        faults.stale(int(opts["of"]), servo_id,
                     address=int(opts["read"]) if "read" in opts else None, **common)
    else:
        bits = int(opts.get("bits", 0x20))
        return lambda: faults.trip(servo_id, bits)
    return None


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m firmware_sim", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--ids", type=_int_list, default=[1], help="servo IDs, e.g. 1,2,3")
    p.add_argument("--model", default="xm430-w350",
                   help="xm430-w350 | xl430-w250, or per ID: 1:xm430-w350,2:xl430-w250")
    p.add_argument("--firmware", default="46", help="firmware version, or per ID: 1:44,2:46")
    p.add_argument("--baud", type=int, default=1_000_000)
    p.add_argument("--link", help="make a symlink to the device at this path")
    p.add_argument("--timing", choices=("realistic", "fast"), default="realistic")
    p.add_argument("--log", metavar="FILE", help="append a packet log to FILE")
    p.add_argument("--seed", type=int, help="seed for probabilistic faults")
    p.add_argument("--dynamics", choices=("on", "off"), default="on",
                   help="physics model (on, default) or the kinematic model (off)")
    p.add_argument("--arm", metavar="TOML|NAME",
                   help="arm file whose rigid bodies the servos drive, or an arm's name "
                        "(omx: configs/omx.toml, or the copy packaged with robodcn)")
    p.add_argument("--supply", type=float, default=12.0, metavar="V",
                   help="supply voltage, V (default 12)")
    p.add_argument("--control", metavar="PATH",
                   help="UNIX socket for move/push/obstacle/voltage/indirect commands")
    p.add_argument("--indirect", default="on", metavar="MODE",
                   help="Indirect Address map: on (default), off (writes acknowledged, "
                        "not stored) or unresolved, or per ID: 2:off,3:unresolved")
    for kind in _FAULT_KEYS:
        p.add_argument(f"--{kind.replace('_', '-')}", action="append", type=_spec, default=[],
                       metavar="TARGET[:k=v,...]")
    return p


def _check_targets(p: argparse.ArgumentParser, args: argparse.Namespace,
                   bus_ids: list[int]) -> None:
    """Every fault flag names a servo on the bus (or ``bus``): checked before serving, so a
    typo is an error at startup rather than a crash when the fault fires."""
    ids = set(bus_ids)
    for kind in _FAULT_KEYS:
        for servo_id, _ in getattr(args, kind):
            if servo_id is not None and servo_id not in ids:
                p.error(f"--{kind.replace('_', '-')} {servo_id}: no servo {servo_id} on the bus "
                        f"(ids {','.join(map(str, bus_ids))})")


def main(argv: list[str] | None = None) -> int:
    p = parser()
    args = p.parse_args(argv)
    model = _per_id(args.model, "--model")
    fw_text = _per_id(args.firmware, "--firmware")
    try:
        firmware = ({k: int(v) for k, v in fw_text.items()} if isinstance(fw_text, dict)
                    else int(fw_text))
    except ValueError:
        raise SystemExit(f"firmware_sim: --firmware must be integers, got {args.firmware!r}")\
            from None
    indirect = _per_id(args.indirect, "--indirect")
    if args.arm and args.dynamics == "off":
        p.error("--arm needs the physics model; drop --dynamics off")
    ids = args.ids
    if args.arm and "--ids" not in (argv if argv is not None else sys.argv[1:]):
        ids = None                          # the arm file's servo ids
    try:
        bus = SimBus(config=SimBusConfig(
            ids=ids, model=model, baud=args.baud, timing=args.timing, firmware=firmware,
            link=args.link, log=False, log_file=args.log, fault_seed=args.seed,
            dynamics=args.dynamics == "on", arm=args.arm, supply_voltage=args.supply,
            indirect=indirect))
    except ValueError as exc:
        p.error(str(exc))
    _check_targets(p, args, [s.id for s in bus.servos])
    trips: list[tuple[float, Callable[[], None]]] = []
    for kind in _FAULT_KEYS:
        for servo_id, opts in getattr(args, kind):
            action = _arm(bus.faults, kind, servo_id, opts)
            if action is not None:
                trips.append((opts.get("at", 0.0), action))
    trips.sort(key=lambda t: t[0])

    stop = threading.Event()

    def on_signal(signum: int, frame: object) -> None:
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    control = None
    try:
        bus.start()
    except FileExistsError as exc:
        p.error(f"--link: {exc.strerror}")
    with bus:
        if args.control:
            try:
                control = ControlServer(bus, args.control)
            except OSError as exc:
                p.error(f"--control {args.control}: {exc.strerror}")
        print(bus.port_path, flush=True)
        t0 = time.monotonic()
        while not stop.is_set():
            if trips and time.monotonic() - t0 >= trips[0][0]:
                trips.pop(0)[1]()
                continue
            wait = trips[0][0] - (time.monotonic() - t0) if trips else 1.0
            stop.wait(max(0.0, min(wait, 1.0)))
        if control is not None:
            control.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
