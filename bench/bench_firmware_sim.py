"""firmware_sim round trips through the real dynamixel-sdk: fast timing, and realistic
timing at 1 Mbps against the wire-time formula (dynamixel-notes.md §5).

Wire bytes (10 bits a byte): PING 10 + 14; Sync Read 14 + N out, 15·N back; Fast Sync
Read 14 + N out, 8 + 8·N back. Return Delay Time adds RDT per replying servo (sync read)
or once (fast sync read: the sim's model). Target: realistic median within 25 % of
wire time plus return delays.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

from dynamixel_sdk import COMM_SUCCESS, GroupSyncRead, PacketHandler, PortHandler

from firmware_sim.bus import SimBus

BAUD = 1_000_000
BYTE_S = 10 / BAUD
PH = PacketHandler(2.0)


def _samples(fn: Callable[[], int], n: int) -> list[float]:
    for _ in range(10):            # warm-up
        fn()
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        result = fn()
        out.append(time.perf_counter() - t0)
        if result != COMM_SUCCESS:
            raise RuntimeError(f"bench call failed: {PH.getTxRxResult(result)}")
    return out


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


def _measure(timing: str, n_servos: int, rdt_units: int, n: int) -> list[tuple]:
    rows = []
    with SimBus(ids=range(1, n_servos + 1), timing=timing, baud=BAUD, log=False) as bus:
        port = PortHandler(bus.port_path)
        port.openPort()
        port.setBaudRate(BAUD)
        try:
            for sid in range(1, n_servos + 1):
                PH.write1ByteTxRx(port, sid, 9, rdt_units)
            rdt = rdt_units * 2e-6
            for name, (fn, wire_bytes) in _cases(port, n_servos).items():
                if name == "PING" and n_servos != 3:
                    continue
                xs = _samples(fn, n)
                replies = 1 if name == "PING" or name.startswith("fast") else n_servos
                model = wire_bytes * BYTE_S + replies * rdt
                rows.append((timing, name, rdt_units * 2, statistics.median(xs), _p99(xs), model))
        finally:
            port.closePort()
    return rows


def run() -> str:
    rows = []
    for n_servos in (3, 6):
        rows += _measure("fast", n_servos, 0, 300)
    for rdt in (0, 250):
        for n_servos in (3, 6):
            rows += _measure("realistic", n_servos, rdt, 150)
    lines = [
        "## firmware_sim round trips (dynamixel-sdk over the pty)",
        "",
        "In-process SimBus; the SDK client spins in the same interpreter. `fast` has no",
        "wire model (floor of SDK + pty + sim); `realistic` paces bytes at 1 Mbps and adds",
        "Return Delay Time and a 30 µs turnaround. Model = wire bytes × 10 µs + RDT per reply",
        "(dynamixel-notes.md §5). Target: realistic median within 25 % of the model.",
        "",
        "| timing | call | RDT µs | median µs | p99 µs | model µs | median / model | target |",
        "|---|---|---:|---:|---:|---:|---:|---|",
    ]
    for timing, name, rdt_us, med, p99, model in rows:
        if timing == "fast":
            ratio, verdict = "", ""
        else:
            r = med / model
            ratio, verdict = f"{r:.2f}", ("met" if abs(r - 1) <= 0.25 else "missed")
        lines.append(f"| {timing} | {name} | {rdt_us} | {med * 1e6:.0f} | {p99 * 1e6:.0f} | "
                     f"{model * 1e6:.0f} | {ratio} | {verdict} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(run())
