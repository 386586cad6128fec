"""Online execution (robodcn.stream.online): planning from a moving state and request → first
changed goal latency on firmware_sim.

Rows:

* planning from a moving state — a 2 s plan at 1 kHz on configs/arm3r.toml, the commanded
  state at 30 %, 50 % and 70 % of it; a retarget to a new goal (geometry by the planner,
  joined by the one moving start ``path_timing.moving_start.join``: tangent, blend-out or
  brake, sampled at 1 kHz and checked; median of the runs), and the re-timing of the same
  path alone (speed scaling k = 0.5 from the moving state). Target ≤ 5 ms.
* smooth stop — the phase-plane brake from full speed.
* jerk limits (every joint's ``max_jerk`` = 20 × its acceleration limit per second) — the
  same states on the same move planned under them: the jerk-limited smooth stop
  (``brake_jerk_checked``), the speed change k = 0.5 from (σ̇, σ̈) and the retarget (through
  rest), with the largest ratio of a finite-difference velocity, acceleration or jerk on the
  wire (the three samples before the switch included) to its limit, and the stop's duration
  against the acceleration-limited brake's from the same state of the jerk-free move.
* request → first changed goal — retargets of a running 2 s move on firmware_sim (timing
  "fast", 1 kHz), the planning time, the due time of the first changed sample and its send
  time on the wire, all from the request (median over the retargets). The rule: due ≤
  planning + 2 periods.

Run alone: ``python bench/bench_online.py`` (or ``python -m bench online``).
"""

from __future__ import annotations

import math
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import robodcn  # noqa: E402
from robodcn import kinematics  # noqa: E402
from robodcn.path_timing import JointLimits  # noqa: E402
from robodcn.stream.online import State  # noqa: E402
from robodcn.stream.online.retarget import Retargeting  # noqa: E402
from robodcn.stream.online.timing import Timing  # noqa: E402
from robodcn.stream.online_path import (  # noqa: E402
    JointPath,
    brake,
    brake_jerk_checked,
    excess,
    retime,
)

MOVING_TARGET_MS = 5.0
START = (0.25, 0.10, 0.0)
GOAL = (0.05, 0.25, math.radians(80))
NEW_GOALS = [(0.20, 0.20, 0.6), (0.12, 0.22, 1.0), (0.22, 0.02, 0.2)]
RUNS = 15
JERK_RUNS = 5
LATENCY_MOVES = 3
JERK_PER_ACCEL = 20.0


def _median_ms(fn, runs: int = RUNS) -> float:
    fn()  # first call pays numpy's lazy imports
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return 1000.0 * statistics.median(times)


def _state_at(traj, path: JointPath, sigma: np.ndarray, i: int) -> State:
    """The commanded state at sample i of ``traj`` as an execution reads it."""
    return State.of_history(i, traj.joints[i - 2:i + 1], path, float(sigma[i]), 1000.0)


def planning_rows(arm) -> list[tuple[str, float, int]]:
    q0 = kinematics.ik(arm.links, np.array([START]))[0]
    traj = robodcn.plan(arm, [START, GOAL], rate_hz=1000, duration=2.0, start_joints=q0)
    path, sigma = JointPath.of_samples(traj.joints)
    limits = JointLimits.of(arm)
    timing = Timing(limits, 1000.0)
    retarget = Retargeting(arm, timing, None)
    rows = []
    for frac in (0.3, 0.5, 0.7):
        state = _state_at(traj, path, sigma, int(frac * (len(traj.t) - 1)))
        for goal in NEW_GOALS:
            samples = retarget.tail(state, [None, goal], {})
            n = sum(len(seg[1]) for seg in samples)
            ms = _median_ms(lambda st=state, g=goal: retarget.tail(st, [None, g], {}))
            rows.append((f"retarget at {frac:.0%} → ({goal[0]:.2f}, {goal[1]:.2f}, "
                         f"{math.degrees(goal[2]):.0f}°)", ms, n))
        n = len(retime(path, state.sigma, state.sd * 0.5, limits.scaled(0.5), 1000.0))
        ms = _median_ms(lambda st=state: timing.timed(st, limits.scaled(0.5)))
        rows.append((f"speed k = 0.5 at {frac:.0%} (same path)", ms, n))
        n = len(brake(path, state.sigma, state.sd, limits.a, 1000.0))
        ms = _median_ms(lambda st=state: brake(path, st.sigma, st.sd, limits.a, 1000.0))
        rows.append((f"smooth stop at {frac:.0%} (brake)", ms, n))
    return rows


def jerk_rows(arm) -> list[tuple[str, float, int, float, str]]:
    """(operation, median ms, samples, wire excess, note) under jerk limits (module doc)."""
    import dataclasses
    jerk_arm = dataclasses.replace(arm, joints=tuple(
        dataclasses.replace(j, max_jerk=JERK_PER_ACCEL * j.max_acceleration)
        for j in arm.joints))
    q0 = kinematics.ik(arm.links, np.array([START]))[0]
    plain = robodcn.plan(arm, [START, GOAL], rate_hz=1000, duration=2.0, start_joints=q0)
    traj = robodcn.plan(jerk_arm, [START, GOAL], rate_hz=1000, duration=2.0, start_joints=q0)
    limits = JointLimits.of(jerk_arm)
    timing = Timing(limits, 1000.0)
    retarget = Retargeting(jerk_arm, timing, None)
    path, sigma = JointPath.of_samples(traj.joints)
    plain_path, plain_sigma = JointPath.of_samples(plain.joints)
    rows = []
    for frac in (0.3, 0.5, 0.7):
        i = int(frac * (len(traj.t) - 1))
        state = _state_at(traj, path, sigma, i)
        sd = state.sd
        stop = brake_jerk_checked(path, state.sigma, sd, state.sdd, limits, 1000.0,
                                  state.history)
        ms = _median_ms(lambda st=state: brake_jerk_checked(
            path, st.sigma, st.sd, st.sdd, limits, 1000.0, st.history), JERK_RUNS)
        psd = (plain_sigma[i] - plain_sigma[i - 1]) * 1000.0
        plain_stop = brake(plain_path, float(plain_sigma[i]), psd, limits.a, 1000.0)
        over = excess(np.vstack([state.history, path.at(stop)]), limits, 1000.0)
        rows.append((f"smooth stop at {frac:.0%}", ms, len(stop), over,
                     f"{len(stop)} ms vs {len(plain_stop)} ms jerk-free"))
        tail = timing.timed(state, limits.scaled(0.5))
        ms = _median_ms(lambda st=state: timing.timed(st, limits.scaled(0.5)), JERK_RUNS)
        over = excess(np.vstack([state.history, path.at(tail)]), limits, 1000.0)
        rows.append((f"speed k = 0.5 at {frac:.0%}", ms, len(tail), over, ""))
        goal = NEW_GOALS[0]
        segments = retarget.tail(state, [None, goal], {})
        ms = _median_ms(lambda st=state, g=goal: retarget.tail(st, [None, g], {}),
                        JERK_RUNS)
        joints = np.vstack([state.history, *(seg[0] for seg in segments)])
        rows.append((f"retarget at {frac:.0%} → ({goal[0]:.2f}, {goal[1]:.2f}, "
                     f"{math.degrees(goal[2]):.0f}°)", ms, len(joints) - 3,
                     excess(joints, limits, 1000.0), "through rest"))
    return rows


def latency_rows(arm) -> list[tuple[float, float, float]]:
    """Retargets of running moves on ``python -m firmware_sim`` in its own process (as
    servos are: the simulator does not share the interpreter, and so the planning, with
    the streaming loop)."""
    from bench.bench_stream import BAUD, _seat, _Sim
    from robodcn.bus import ServoBus
    from robodcn.servo_units import radians_to_ticks, ticks_to_radians
    from robodcn.stream import start
    goals = [(0.2, 0.15, 0.2), (0.15, 0.2, 0.5), (0.1, 0.22, 0.9), (0.05, 0.25, 1.2),
             (0.1, 0.2, 0.8), (0.15, 0.18, 0.4)]
    out = []
    with _Sim(timing="fast") as sim, \
            ServoBus(sim.path, BAUD, servos=arm.servos, rx_timeout_ms=10) as bus:
        bus.verify()
        bus.configure()
        seat = radians_to_ticks(kinematics.ik(arm.links, np.array([START])), arm.servos)[0]
        for _ in range(LATENCY_MOVES):  # each from START, retargeted six times
            _seat(bus, seat)  # a goal step in joint space (the sim starts stretched out)
            here = ticks_to_radians(bus.read_positions()[None], arm.servos)[0]
            traj = robodcn.plan(arm, [tuple(kinematics.fk(arm.links, here[None])[0]), GOAL],
                                rate_hz=1000, duration=3.0, start_joints=here)
            ex = start(traj, bus, skip_late=False)
            for k, goal in enumerate(goals):
                while ex.sample < 150 + 100 * k and not ex.done:
                    time.sleep(0.002)
                ex.retarget([None, goal])
            ex.wait(30)
            out += ex.latencies()
    return out


def run() -> str:
    arm = robodcn.load_arm(ROOT / "configs" / "arm3r.toml")
    load = os.getloadavg()[0]
    lines = ["## Online execution (retarget, speed, smooth stop)", "",
             f"configs/arm3r.toml, 1 kHz; load average {load:.1f} on {os.cpu_count()} cores "
             "while measuring. Planning from a moving state (2 s path at 1 kHz), median of "
             f"{RUNS} runs; target ≤ {MOVING_TARGET_MS:g} ms.", "",
             "| operation | median ms | samples planned | ≤ target |", "|---|---:|---:|:-:|"]
    for name, ms, n in planning_rows(arm):
        lines.append(f"| {name} | {ms:.2f} | {n} | {'✓' if ms <= MOVING_TARGET_MS else '✗'} |")
    lines += ["", f"Under jerk limits (max_jerk = {JERK_PER_ACCEL:g} × max_acceleration /s on "
              "every joint), the same move and states; wire excess = the largest "
              "finite-difference velocity, acceleration or jerk over its limit (≤ 1 keeps "
              f"every limit), median of {JERK_RUNS} runs:", "",
              "| operation | median ms | samples | wire excess | note |",
              "|---|---:|---:|---:|---|"]
    for name, ms, n, over, note in jerk_rows(arm):
        lines.append(f"| {name} | {ms:.1f} | {n} | {over:.3f} | {note} |")
    lat = latency_rows(arm)
    lines += ["", "Request → first changed goal on firmware_sim (1 kHz, timing fast, "
              f"{len(lat)} retargets of {LATENCY_MOVES} running moves; milliseconds from the "
              "request, median; the last column counts the retargets whose first changed "
              "goal was due within planning + 2 periods). firmware_sim runs in its own process "
              "(`python -m firmware_sim --timing fast`); planning shares the interpreter with "
              "the streaming loop, so it takes longer and varies more than in the table "
              "above:", "",
              "| planning ms | first changed goal due ms | sent ms | due − planning "
              "(rule ≤ 2 periods = 2 ms) | within the rule |", "|---:|---:|---:|---:|---:|"]
    if lat:
        plan_ms = 1000 * statistics.median(p for p, _, _, _ in lat)
        due_ms = 1000 * statistics.median(d for _, d, _, _ in lat)
        sent_ms = 1000 * statistics.median(s for _, _, s, _ in lat)
        excess = 1000 * statistics.median(d - p for p, d, _, _ in lat)
        within = sum(d - p <= 0.002 for p, d, _, _ in lat)
        lines.append(f"| {plan_ms:.1f} | {due_ms:.1f} | {sent_ms:.1f} | {excess:.1f} | "
                     f"{within} of {len(lat)} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(run())
