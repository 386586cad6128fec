"""firmware_sim: the servo models' CPU cost per simulated servo-millisecond (physics and
kinematic), and round trips through the real dynamixel-sdk: fast timing, and realistic
timing at 1 Mbps against the wire-time formula (dynamixel-notes.md §5).

Wire bytes (10 bits a byte): PING 10 + 14; Sync Read 14 + N out, 15·N back; Fast Sync
Read 14 + N out, 8 + 8·N back. Return Delay Time adds RDT per replying servo (sync read)
or once (fast sync read: the sim's model). Target: realistic median within 25 % of
wire time plus return delays.
"""

from __future__ import annotations

import math
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from dynamixel_sdk import COMM_SUCCESS, GroupSyncRead, PacketHandler, PortHandler

from firmware_sim.bus import SimBus
from firmware_sim.bus_config import SimBusConfig
from firmware_sim.dynamics import PHYSICS_STEP_S

BAUD = 1_000_000
BYTE_S = 10 / BAUD
TURNAROUND_S = SimBusConfig().turnaround_s
PH = PacketHandler(2.0)
ROOT = Path(__file__).resolve().parent.parent


def _samples(fn: Callable[[], int], n: int) -> tuple[list[float], int]:
    """Round-trip times of ``n`` successful calls, and how many calls failed on the way."""
    for _ in range(10):            # warm-up
        fn()
    out: list[float] = []
    failed = 0
    while len(out) < n:
        t0 = time.perf_counter()
        result = fn()
        dt = time.perf_counter() - t0
        if result == COMM_SUCCESS:
            out.append(dt)
        else:
            failed += 1
            # timeouts under machine load are counted in the table; this many means a
            # broken bus, not a busy machine
            if failed > n:
                raise RuntimeError(f"bench call failed {failed} times: "
                                   f"{PH.getTxRxResult(result)}")
    return out, failed


def _p99(xs: list[float]) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(0.99 * len(xs)))]


def _cases(port: PortHandler, n_servos: int) -> dict[str, tuple[Callable[[], int], int]]:
    """name -> (call, wire bytes)."""
    sync = GroupSyncRead(port, PH, 132, 4)
    fast = GroupSyncRead(port, PH, 132, 4)
    for sid in range(1, n_servos + 1):
        sync.addParam(sid)
        fast.addParam(sid)
    n = n_servos
    return {
        "PING": (lambda: PH.ping(port, 1)[1], 10 + 14),
        f"sync read ×{n}": (sync.txRxPacket, 14 + n + 15 * n),
        f"fast sync read ×{n}": (fast.fastSyncRead, 14 + n + 8 + 8 * n),
    }


@contextmanager
def _bus(where: str, n_servos: int, timing: str) -> Iterator[str]:
    """Port path of a bus served in this interpreter or by ``python -m firmware_sim``."""
    ids = list(range(1, n_servos + 1))
    if where == "in-process":
        with SimBus(config=SimBusConfig(ids=tuple(ids), timing=timing, baud=BAUD,
                                        log=False)) as bus:
            yield bus.port_path
        return
    proc = subprocess.Popen(
        [sys.executable, "-m", "firmware_sim", "--ids", ",".join(map(str, ids)),
         "--timing", timing, "--baud", str(BAUD)],
        cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        yield proc.stdout.readline().strip()
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def _measure(where: str, timing: str, n_servos: int, rdt_units: int, n: int) -> list[tuple]:
    rows = []
    with _bus(where, n_servos, timing) as path:
        port = PortHandler(path)
        port.openPort()
        port.setBaudRate(BAUD)
        try:
            for sid in range(1, n_servos + 1):
                if PH.write1ByteTxRx(port, sid, 9, rdt_units)[0] != COMM_SUCCESS:
                    raise RuntimeError(f"could not set Return Delay Time on servo {sid}")
            rdt = rdt_units * 2e-6
            for name, (fn, wire_bytes) in _cases(port, n_servos).items():
                if name == "PING" and n_servos != 3:
                    continue
                xs, failed = _samples(fn, n)
                replies = 1 if name == "PING" or name.startswith("fast") else n_servos
                model = wire_bytes * BYTE_S + replies * (rdt + TURNAROUND_S)
                rows.append((where, timing, name, rdt_units * 2, statistics.median(xs),
                             _p99(xs), model, failed))
        finally:
            port.closePort()
    return rows


def _load() -> str:
    return ", ".join(f"{x:.1f}" for x in os.getloadavg())


def model_cost(dynamics: bool, n_servos: int = 6, seconds: float = 2.0) -> tuple[float, float]:
    """CPU and wall seconds per simulated second of ``n_servos`` moving servos, each sent a
    goal and read once per simulated millisecond (a 1 kHz stream). Goal writes and reads
    go straight to the Servo objects on a virtual clock, so only the model is timed, not
    the pty or the protocol."""
    from firmware_sim import control_table as ct
    from firmware_sim.clock import VirtualClock
    from firmware_sim.servo import Servo
    clock = VirtualClock()
    servos = [Servo(i, clock=clock, dynamics=dynamics) for i in range(1, n_servos + 1)]
    for s in servos:
        s.write(ct.TORQUE_ENABLE, b"\x01")
    steps = int(seconds * 1000)
    cpu0, wall0 = time.thread_time(), time.perf_counter()
    for k in range(steps):
        clock.advance(0.001)
        goal = 2048 + round(1200 * math.sin(2 * math.pi * k / 1000))
        for s in servos:
            s.write(ct.GOAL_POSITION, goal.to_bytes(4, "little", signed=True))
            s.read(ct.PRESENT_POSITION, 4)
    return (time.thread_time() - cpu0) / seconds, (time.perf_counter() - wall0) / seconds


def _model_section(n_servos: int = 6, repeats: int = 3) -> list[str]:
    load = _load()
    lines = [
        "## firmware_sim servo model cost",
        "",
        f"{n_servos} servos, each sent a goal and read once per simulated millisecond (a 1 kHz",
        "stream) on a 1 Hz sine of ±1200 ticks, so they move all the time; straight calls on",
        "Servo objects with a virtual clock (no pty, no protocol), one thread. The physics",
        f"model (`dynamics=True`) steps every {PHYSICS_STEP_S * 1e3:g} ms; the kinematic model",
        "evaluates the profile. CPU time of the bench thread, the lowest of "
        f"{repeats} runs of 2 s;",
        f"wall time of the same run beside it (load avg 1/5/15 min at the start: {load}).",
        "Real time needs a share well below 1: the same interpreter also runs the pty server",
        "(and, in-process, the client) under one GIL.",
        "",
        "| model | CPU µs per simulated servo-ms (incl. one write + one read) |"
        f" CPU share at 1 kHz, {n_servos} servos | wall share |",
        "|---|---:|---:|---:|",
    ]
    for name, dynamics in (("physics", True), ("kinematic", False)):
        cpu, wall = min(model_cost(dynamics, n_servos) for _ in range(repeats))
        per = cpu / (1000 * n_servos)
        lines.append(f"| {name} | {per * 1e6:.1f} | {cpu:.2f} | {wall:.2f} |")
    return [*lines, ""]


def run() -> str:
    physics = _model_section()
    load = _load()
    rows = []
    for where in ("in-process", "subprocess"):
        for n_servos in (3, 6):
            rows += _measure(where, "fast", n_servos, 0, 300)
        for rdt in (0, 250):
            for n_servos in (3, 6):
                rows += _measure(where, "realistic", n_servos, rdt, 150)
    lines = [
        "## firmware_sim round trips (dynamixel-sdk over the pty)",
        "",
        "Default SDK client (it polls the port at 100 % CPU). `in-process`: SimBus in the",
        "client's interpreter; `subprocess`: `python -m firmware_sim`. `fast` has no wire",
        "model: it is the floor of SDK + pty + sim. `realistic` paces bytes at 1 Mbps and",
        "adds Return Delay Time and a 30 µs turnaround per reply. Model = wire bytes × 10 µs",
        "+ (RDT + turnaround) per reply (dynamixel-notes.md §5; a fast sync read replies once).",
        "Target: realistic median within 25 % of the model; the excess is the fast floor.",
        "Failed calls (SDK timeouts while the machine was loaded) are retried, not timed.",
        f"Load avg 1/5/15 min when the round trips started: {load} (2 cores shared with",
        "other jobs: a loaded machine inflates the fast floor and the p99 column).",
        "",
        "| bus | timing | call | RDT µs | median µs | p99 µs | model µs | median / model |"
        " target | failed calls |",
        "|---|---|---|---:|---:|---:|---:|---:|---|---:|",
    ]
    for where, timing, name, rdt_us, med, p99, model, failed in rows:
        if timing == "fast":
            ratio, verdict = "", ""
        else:
            r = med / model
            ratio, verdict = f"{r:.2f}", ("met" if abs(r - 1) <= 0.25 else "missed")
        lines.append(f"| {where} | {timing} | {name} | {rdt_us} | {med * 1e6:.0f} | "
                     f"{p99 * 1e6:.0f} | {model * 1e6:.0f} | {ratio} | {verdict} | {failed} |")
    return "\n".join(physics + lines) + "\n"


if __name__ == "__main__":
    print(run())
