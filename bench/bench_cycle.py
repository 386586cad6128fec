"""The 100 Hz cycle's work on a dry run (issue 27 §2): what one sample costs the host.

``serve --sim`` and ``sim`` stream to firmware_sim in the same process: the stream thread
(Sync Write, Fast Sync Read every sample, feedback, step guard) and the simulator thread
(the servos' physics driving the OM-X's bodies) share one interpreter. A 100 Hz move on a
loaded machine ended ``degraded`` with late samples (cycle work p50 2.9 ms, p99 13 ms);
the cost per cycle decides how much of a 10 ms period is left when a CPU hog takes its
share. Here: a 3 s OM-X move at 100 Hz (omx.toml, home → (0.2, 0.05, 0.15, −0.2),
realistic wire timing, physics on, compensation on, the service's execute options), run
alone and beside a CPU hog (one busy subprocess per core); per cycle the stream thread's
CPU time and the whole process's (both threads), the report's cycle work (write start to
the end of its reads, wall) p50 / p99, and the samples skipped.

Where a cycle's time went (cProfile on each thread, thread CPU time): the simulator's
physics (the OM-X's coupled bodies stepped every 0.5 ms: ~0.1 ms a step, 20 a cycle) and,
before the keep-up between packets stopped refreshing every servo's Present items
(``Servo.advance``), that refresh; a reply waits for the catch-up to now. The stream
thread's ~0.7 ms is mostly the SDK and pyserial; robodcn's own per-cycle code (feedback
decode, collision check, step guard, records) is ~0.2 ms.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import os
import time
from collections.abc import Iterator

import robodcn
from robodcn.simulated import simulated_arm
from robodcn.stream import execute

RATE = 100.0
DURATION_S = 3.0
GOAL = [0.2, 0.05, 0.15, -0.2]


def _spin(until: float) -> None:
    while time.monotonic() < until:
        pass


@contextlib.contextmanager
def hog(seconds: float) -> Iterator[None]:
    """One busy process per core, for at most ``seconds`` (a CPU hog)."""
    until = time.monotonic() + seconds
    procs = [multiprocessing.Process(target=_spin, args=(until,), daemon=True)
             for _ in range(os.cpu_count() or 1)]
    for p in procs:
        p.start()
    try:
        yield
    finally:
        for p in procs:
            p.terminate()
            p.join(5)


def cycle(beside_hog: bool) -> dict[str, float]:
    """One move: per-cycle CPU (ms) of the stream thread and the process, the report's
    work p50 / p99 (ms), samples skipped and sent."""
    arm = robodcn.load_arm("omx")
    traj = robodcn.plan(arm, [list(arm.home), GOAL], duration=DURATION_S, rate_hz=RATE)
    with simulated_arm(arm, timing="realistic", start_joints=traj.joints[0]) as sa:
        sa.carry(traj.request.payload_kg if traj.request is not None else None)
        with hog(DURATION_S + 5.0) if beside_hog else contextlib.nullcontext():
            c0, p0 = time.thread_time(), time.process_time()
            report = execute(traj, sa.bus, approach=True, release=False)
            c1, p1 = time.thread_time(), time.process_time()
    n = max(1, report.samples_total)  # per scheduled period (skipped ones cost nothing)
    return {"stream_ms": 1e3 * (c1 - c0) / n, "process_ms": 1e3 * (p1 - p0) / n,
            "work_p50_ms": 1e3 * report.work_p50_s, "work_p99_ms": 1e3 * report.work_p99_s,
            "skipped": report.skipped, "samples": report.samples_total}


def physics_ms(repeats: int = 5, seconds: float = 2.0) -> float:
    """firmware_sim's CPU (ms) per simulated 10 ms of the OM-X moving on its physics: 4
    servos on one plant, each sent a goal (a ±300-tick sine at 1 Hz) and read once per 10 ms
    on a virtual clock, no pty; the lowest of ``repeats`` runs (process CPU time)."""
    from firmware_sim import control_table as fct
    from firmware_sim.bus import SimBus
    from firmware_sim.bus_config import SimBusConfig
    from firmware_sim.clock import VirtualClock
    from robodcn.simulated import sim_arm_document

    arm = robodcn.load_arm("omx")
    best = float("inf")
    for _ in range(repeats):
        clock = VirtualClock()
        sim = SimBus(config=SimBusConfig(
            ids=arm.servo_ids, model={s.id: s.model for s in arm.servos}, timing="fast",
            log=False, dynamics=True, arm=sim_arm_document(arm), clock=clock))
        servos = [sim.servo(i) for i in arm.servo_ids]
        for s in servos:
            s.write(fct.TORQUE_ENABLE, bytes([1]))
        base = [s.get(fct.PRESENT_POSITION) for s in servos]
        cycles = round(seconds * RATE)
        c0 = time.process_time()
        for k in range(cycles):
            clock.advance(1.0 / RATE)
            for s, b in zip(servos, base, strict=True):
                goal = int(b + 300 * math.sin(2 * math.pi * k / RATE))
                s.write(fct.GOAL_POSITION, goal.to_bytes(4, "little", signed=True))
                s.update()
        best = min(best, 1e3 * (time.process_time() - c0) / cycles)
    return best


def run() -> str:
    physics = physics_ms()
    rows = []
    for beside_hog in (False, True):
        r = cycle(beside_hog)
        rows.append(f"| {'beside a hog (1 busy process a core)' if beside_hog else 'alone'} | "
                    f"{r['stream_ms']:.2f} | {r['process_ms']:.2f} | {r['work_p50_ms']:.2f} / "
                    f"{r['work_p99_ms']:.2f} | {r['skipped']} of {r['samples']} |")
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    return "\n".join([
        "## The 100 Hz cycle's work on a dry run (issue 27 §2)",
        "",
        "OM-X on firmware_sim in the same process (`serve --sim`'s setup: realistic timing,",
        "physics on, 4 servos), a 3 s move at 100 Hz with the service's options. CPU per",
        "cycle: the stream thread's, and the process's (stream + simulator threads); cycle",
        "work: write start to the end of its reads (wall). Load average when the run ended: "
        f"{load}.",
        "",
        "| run | stream thread CPU ms / cycle | process CPU ms / cycle | cycle work p50 / p99 ms "
        "| skipped |",
        "|---|---:|---:|---:|---:|",
        *rows,
        "",
        f"firmware_sim's physics alone (`physics_ms`: the OM-X's 4 servos moving on one plant, "
        f"a goal and a read per servo every 10 ms, virtual clock, lowest of 5): "
        f"**{physics:.2f} ms CPU per simulated 10 ms** — most of the process's cycle cost; "
        "the stream thread's own (SDK, pyserial, feedback, step guard) is the first column.",
    ])
