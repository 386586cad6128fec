"""Follow a stream of targets (robodcn.stream.follow, the online generator robodcn.online).

Rows, each against its bar (issue 28):

* generator compute per period — the session's work for one sample (its generator step
  toward the newest input and the sample's goal ticks: ``FollowSamples._make``) while a
  30 Hz stream at 40 % of the limits is followed at 1 kHz, p50/p99/max; arm3r with jerk
  limits (3 joints) and the omx (4 joints, torque limits); bar p99 ≤ 0.5 ms. Beside it the
  cost of taking a target (``Follower.target``: checks, IK-free joints, the torque check on
  the omx), which runs on the caller's thread.
* reaction — a target taken while the loop is held between two samples (virtual time): the
  first goal that changes is due at the next sample (bar: no later than the next period),
  at 100 Hz and 1 kHz.
* time-optimal — 22 random step targets from rest and 22 from motion on arm3r with jerk
  limits and on the omx: the generator's time to the target against Ruckig's offline
  duration for the same v, a, j and initial state (bar ≤ 1.02 × + one period).
* tracking — that 30 Hz stream followed on firmware_sim (virtual time): the lag that fits
  best, the RMS error after it (bars: lag ≤ one target period + 2 bus periods, RMS ≤ 0.5°),
  the slowest joint speed mid-stream (never at rest), the peak acceleration and jerk
  against the limits; beside it LeRobot-style linear interpolation of the same 30 Hz
  stream at the bus rate (its peak acceleration and jerk against the limits).
* HTTP — ``PUT /v1/follow/target`` on one keep-alive connection to ``serve``'s stack on a
  simulated arm (in this process), 200 targets at 100 Hz: median and p99 (bars ≤ 5 ms,
  ≤ 20 ms).

Run alone: ``python -m bench follow``.
"""

from __future__ import annotations

import dataclasses
import http.client
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ruckig import InputParameter, Ruckig, Trajectory  # noqa: E402

import robodcn  # noqa: E402
from robodcn import servo_units  # noqa: E402
from robodcn.online import Generator, Input  # noqa: E402
from robodcn.path_timing import JointLimits  # noqa: E402
from robodcn.simulated import simulated_arm  # noqa: E402
from robodcn.stream import VirtualClock, follow  # noqa: E402
from robodcn.stream.following import source as follow_source  # noqa: E402

RATE = 1000.0
GAP = 1.0 / 30.0
SHARE = 0.4
TARGETS = 70
STEPS = 22
P99_BAR_MS = 0.5
PUT_MEDIAN_BAR_MS = 5.0
PUT_P99_BAR_MS = 20.0


def _arms():
    arm3r = robodcn.load_arm(str(ROOT / "configs" / "arm3r.toml"))
    jerk = dataclasses.replace(arm3r, joints=tuple(
        dataclasses.replace(j, max_jerk=20.0 * j.max_acceleration) for j in arm3r.joints))
    return arm3r, jerk, robodcn.load_arm("omx")


def _signal(arm, q0, share=SHARE, hz=0.8):
    """Joint j: a_j·(1 − cos ω_j t), ω_j = 2π·hz·(1, 0.75, 1.25, 0.9)[j], at ``share`` of
    the velocity and acceleration limits (as tests/test_follow.py)."""
    v = np.array([j.max_velocity for j in arm.joints])
    a = np.array([j.max_acceleration for j in arm.joints])
    w = 2 * math.pi * hz * np.array([1.0, 0.75, 1.25, 0.9])[:len(q0)]
    amp = np.minimum(share * v / w, share * a / w ** 2) * np.array([1, -1, 1, -1])[:len(q0)]
    return lambda t: q0 + amp * (1 - np.cos(w * np.asarray(t, dtype=float)[..., None]))


def _session(arm, rate, steps, **kw):
    """A follow session on virtual time on a kinematic simulated ``arm``: for each (time s,
    op) hold the loop there and run ``op(follower)``; the follower, its report."""
    with simulated_arm(arm, timing="fast", dynamics=False) as sa:
        clock = VirtualClock()
        clock.hold(0.0)
        f = follow(sa.bus, arm, rate_hz=rate, clock=clock, watchdog_ms=0, skip_late=False,
                   **kw)
        try:
            assert clock.wait_parked(), f.error
            t0 = f.stream.t_start
            for t, op in steps:
                clock.hold(t0 + t)
                assert clock.wait_parked(), f.error
                op(f)
        finally:
            clock.release()
        report = f.wait(120)
        q0 = servo_units.ticks_to_radians(np.array([f.source.ticks[0]]), arm.servos)[0]
    return f, report, q0


def _stream_steps(signal, took_target):
    def op(k):
        def go(f):
            t = time.perf_counter()
            f.target(joints=signal(k * GAP))
            took_target.append(time.perf_counter() - t)
        return go
    steps = [(k * GAP, op(k)) for k in range(TARGETS)]
    steps.append((TARGETS * GAP, lambda f: f.end()))
    return steps


def tracking(arm, label):
    """One 30 Hz stream followed at 1 kHz: compute per period, target cost, tracking."""
    with simulated_arm(arm, timing="fast", dynamics=False) as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], arm.servos)[0]
    signal = _signal(arm, q0)
    made, took_target, inputs = [], [], []
    real, update = follow_source.FollowSamples._make, Generator.update

    def timed(self, i):
        t = time.perf_counter()
        real(self, i)
        made.append(time.perf_counter() - t)

    def recorded(self, inp=None):
        inputs.append(inp)
        return update(self, inp)
    follow_source.FollowSamples._make = timed
    Generator.update = recorded
    try:
        f, report, _ = _session(arm, RATE, _stream_steps(signal, took_target))
    finally:
        follow_source.FollowSamples._make = real
        Generator.update = update
    # the generator alone on the same inputs, in a tight loop (no simulator thread, no GIL
    # contention): what a period costs the session's own computation
    replay = Generator(f.generator.limits, RATE, f.source.joints[0],
                       position_limits=f.generator.position_limits)
    alone = []
    for inp in inputs[1:]:
        t = time.perf_counter()
        replay.update(inp)
        alone.append(time.perf_counter() - t)
    index, _, joints = f.sent()
    t = index / RATE
    mid = (t > 0.3) & (t < (TARGETS - 3) * GAP)
    fits = [(float(np.sqrt(np.mean((joints[mid] - signal(t[mid] - lag)) ** 2))), lag)
            for lag in np.arange(0.0, 0.08, 0.0005)]
    rms, lag = min(fits)
    v = np.diff(joints, axis=0) * RATE
    a = np.diff(v, axis=0) * RATE
    jk = np.diff(a, axis=0) * RATE
    vmax = np.array([j.max_velocity for j in arm.joints])
    amax = np.array([j.max_acceleration for j in arm.joints])
    jmax = np.array([j.max_jerk or math.inf for j in arm.joints])
    # LeRobot-style: the same 30 Hz targets, linearly interpolated at the bus rate
    knots = np.arange(TARGETS) * GAP
    tl = np.arange(0.0, knots[-1], 1.0 / RATE)
    lin = np.column_stack([np.interp(tl, knots, signal(knots)[:, j])
                           for j in range(len(q0))])
    lv = np.diff(lin, axis=0) * RATE
    la = np.diff(lv, axis=0) * RATE
    lj = np.diff(la, axis=0) * RATE
    ms = np.array(made) * 1e3
    gen_ms = np.array(alone) * 1e3
    mv, ma = v[mid[1:]], a[mid[2:]]
    mj = jk[mid[3:]]
    return {
        "gen_p50": np.percentile(gen_ms, 50), "gen_p99": np.percentile(gen_ms, 99),
        "gen_max": gen_ms.max(),
        "mid_v": float((np.abs(mv) / vmax).max()), "mid_a": float((np.abs(ma) / amax).max()),
        "mid_j": float((np.abs(mj) / jmax).max()) if np.isfinite(jmax).all() else None,
        "label": label, "p50": np.percentile(ms, 50), "p99": np.percentile(ms, 99),
        "max": ms.max(), "periods": len(ms),
        "target_ms": 1e3 * float(np.median(took_target)),
        "target_p99_ms": 1e3 * float(np.percentile(took_target, 99)),
        "lag_ms": lag * 1e3, "rms_deg": math.degrees(rms),
        "min_speed": float(np.abs(v[mid[1:]]).max(axis=1).min()),
        "a_share": float((np.abs(a) / amax).max()), "v_share": float((np.abs(v) / vmax).max()),
        "j_share": float((np.abs(jk) / jmax).max()) if np.isfinite(jmax).all() else None,
        "lin_a_share": float((np.abs(la) / amax).max()),
        "lin_j_share": float((np.abs(lj) / (jmax if np.isfinite(jmax).all() else
                                            50.0 * amax)).max()),
        "outcome": report.outcome}


def reaction(arm, rate):
    """The first changed sample after a target taken between samples 100 and 101."""
    held_at = 100.5 / rate
    with simulated_arm(arm, timing="fast", dynamics=False) as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], arm.servos)[0]
    f, _, _ = _session(arm, rate, [(held_at, lambda f: f.target(joints=q0 + 0.3)),
                                   (held_at + 0.5, lambda f: f.end())])
    index, _, joints = f.sent()
    moved = index[np.flatnonzero(np.abs(joints - joints[0]).max(axis=1) > 1e-12)[0]]
    return float((moved / rate - held_at) * 1e3), 1e3 / rate


def _ruckig(limits, state, target):
    k = len(target)
    ip = InputParameter(k)
    ip.current_position, ip.current_velocity, ip.current_acceleration = map(list, state)
    ip.target_position = list(target)
    ip.max_velocity, ip.max_acceleration = list(limits.v), list(limits.a)
    ip.max_jerk = list(limits.jerk)
    law = Trajectory(k)
    Ruckig(k).calculate(ip, law)
    return law.duration


def optimality(arm, moving):
    rng = np.random.default_rng(28 + moving)
    limits = JointLimits.of(arm, torque=False)
    lo = np.array([j.min_angle for j in arm.joints])
    hi = np.array([j.max_angle for j in arm.joints])
    worst = 0.0
    for _ in range(STEPS):
        q = rng.uniform(lo + 0.2 * (hi - lo), hi - 0.2 * (hi - lo))
        qd = rng.uniform(-0.8, 0.8, len(q)) * limits.v if moving else np.zeros(len(q))
        qdd = (rng.uniform(-0.5, 0.5, len(q)) * limits.a if moving and limits.j is not None
               else np.zeros(len(q)))
        target = rng.uniform(lo, hi)
        gen = Generator(limits, RATE, q, qd=qd, qdd=qdd)
        n = 1
        sample = gen.update(Input(target=target))
        while not sample.reached:
            sample = gen.update()
            n += 1
        worst = max(worst, (n / RATE - 1 / RATE) / _ruckig(limits, (q, qd, qdd), target))
    return worst


def put_latency(arm):
    import threading

    from robodcn.controller import ArmController
    from robodcn.http import make_server

    with simulated_arm(arm, timing="fast") as sa:
        controller = ArmController(arm, sa.bus, execute_options={"watchdog_ms": 1000})
        server = make_server(arm, controller, request_timeout=5.0)
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        try:
            host, port = server.server_address[:2]
            conn = http.client.HTTPConnection(host, port, timeout=5)

            def send(method, path, body):
                conn.request(method, path, body=json.dumps(body).encode(),
                             headers={"Content-Type": "application/json",
                                      "Host": f"{host}:{port}"})
                resp = conn.getresponse()
                return resp.status, json.loads(resp.read())
            status, move = send("POST", "/v1/follow", {"rate_hz": 100})
            assert status == 201, move
            ticks = [sa.sim.servo(i).present_position for i in arm.servo_ids]
            q0 = servo_units.ticks_to_radians(np.array([ticks]), arm.servos)[0]
            took = []
            for k in range(200):
                t = time.perf_counter()
                status, answer = send("PUT", "/v1/follow/target",
                                      {"joints": list(q0 + 0.001 * k)})
                took.append(time.perf_counter() - t)
                assert status == 200, answer
                time.sleep(0.01)
            send("DELETE", "/v1/follow", {})
            floor = []
            for _ in range(200):
                t = time.perf_counter()
                conn.request("GET", "/healthz", headers={"Host": f"{host}:{port}"})
                conn.getresponse().read()
                floor.append(time.perf_counter() - t)
                time.sleep(0.01)
            conn.close()
        finally:
            controller.close()
            server.shutdown()
            server.server_close()
    ms, base = np.array(took) * 1e3, np.array(floor) * 1e3
    return (float(np.median(ms)), float(np.percentile(ms, 99)), float(np.median(base)),
            float(np.percentile(base, 99)))


def run() -> str:
    arm3r, jerk, omx = _arms()
    load = os.getloadavg()
    rows = [tracking(jerk, "arm3r, jerk limits (3 joints)"), tracking(omx, "omx (4 joints, "
                                                                             "torque limits)")]
    react = [(rate, *reaction(arm3r, rate)) for rate in (100.0, 1000.0)]
    optimal = [(name, moving, optimality(a, moving)) for name, a in
               (("arm3r, jerk limits", jerk), ("omx", omx)) for moving in (False, True)]
    put = put_latency(arm3r)
    ok = lambda good: "✓" if good else "✗"  # noqa: E731
    out = [
        "## Follow a stream of targets (issue 28)",
        "",
        f"A smooth target streamed at 30 Hz ({TARGETS} targets) at {SHARE:.0%} of the "
        "velocity and acceleration limits, followed at 1 kHz on firmware_sim (kinematic "
        "servos, virtual time: the loop is held at each target's arrival). Load average "
        f"{load[0]:.1f} on {os.cpu_count()} cores at the start.",
        "",
        "| arm | generator/period p50 / p99 / max ms (bar p99 ≤ 0.5) | in the session "
        "(with the simulator thread) p50 / p99 ms | target() median / p99 ms "
        "| lag ms (bar ≤ 35.3) | RMS after lag ° (bar ≤ 0.5) | slowest mid-stream rad/s | "
        "peak v, a, j / limit mid-stream (whole session) | linear interp. peak a, j / "
        "limit |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        j = "—" if r["j_share"] is None else f"{r['j_share']:.2f}"
        mj = "—" if r["mid_j"] is None else f"{r['mid_j']:.2f}"
        out.append(
            f"| {r['label']} | {r['gen_p50']:.3f} / {r['gen_p99']:.3f} / {r['gen_max']:.2f} "
            f"{ok(r['gen_p99'] <= P99_BAR_MS)} | {r['p50']:.3f} / {r['p99']:.2f} "
            f"| {r['target_ms']:.2f} / {r['target_p99_ms']:.2f} "
            f"| {r['lag_ms']:.1f} {ok(r['lag_ms'] <= 1e3 * GAP + 2)} | {r['rms_deg']:.3f} "
            f"{ok(r['rms_deg'] <= 0.5)} | {r['min_speed']:.3f} {ok(r['min_speed'] > 0.01)} "
            f"| {r['mid_v']:.2f}, {r['mid_a']:.2f}, {mj} ({r['v_share']:.2f}, "
            f"{r['a_share']:.2f}, {j}) | {r['lin_a_share']:.1f}, {r['lin_j_share']:.0f} |")
    out += ["",
            "Linear interpolation's jerk is against the arm's jerk limit (the omx has none: "
            "against 50 × its acceleration limit, the session's own smoothing jerk). Its "
            "acceleration is a spike of Δv/T at every target. The whole session's peaks "
            "include its start (from rest toward a stream already moving) and its end "
            "(to rest at the last target as fast as the limits allow). target() on the omx "
            "includes the torque check (the law's rigid-body inverse dynamics with the "
            "payload), on the caller's thread.",
            "",
            "| reaction: rate | first changed goal after the target ms | next period ms | "
            "within |",
            "|---|---|---|---|"]
    for rate, after, period in react:
        out.append(f"| {rate:g} Hz | {after:.2f} | {period:.1f} | {ok(after <= period)} |")
    out += ["", f"| time-optimal ({STEPS} random steps) | from | worst (generator − 1 period) "
                "/ Ruckig | bar ≤ 1.02 |", "|---|---|---|---|"]
    for name, moving, worst in optimal:
        out.append(f"| {name} | {'motion' if moving else 'rest'} | {worst:.4f} | "
                   f"{ok(worst <= 1.02)} |")
    out += ["", "| PUT /v1/follow/target, keep-alive, 200 targets at 100 Hz | median ms | "
                "p99 ms |", "|---|---|---|",
            f"| serve's stack, simulated arm3r, in the bench process | {put[0]:.2f} "
            f"{ok(put[0] <= PUT_MEDIAN_BAR_MS)} | {put[1]:.2f} "
            f"{ok(put[1] <= PUT_P99_BAR_MS)} |",
            f"| GET /healthz on the same connection after the session (the server's floor "
            f"on this host) | {put[2]:.2f} | {put[3]:.2f} |"]
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    print(run())
