"""Time-optimal path timing (robodcn.path_timing) against the toppra package, side by side.

Every case is a joint path built with robodcn's public API (``plan`` with the linear profile
and a long fixed duration samples q(s) along the interpolated screw path; s = t / T), timed by
our TOPP-RA + jerk pass and by toppra 0.6 (``ta.algorithm.TOPPRA``, cubic spline through the
same samples, one rest-to-rest run per piece between stops). Jerk limits: 10 × each joint's
acceleration limit per second (the configs have none yet).
"""

from __future__ import annotations

import itertools
import math
import os
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import robodcn
from robodcn.path_timing import time_optimal

ROOT = Path(__file__).resolve().parent.parent
JERK_PER_ACCEL = 10.0  # 1/s: jerk limit = 10 × acceleration limit
TOPPRA_RATIO_TARGET = 1.02
PLAN_TARGET_MS = 10.0
MOVING_TARGET_MS = 5.0
_PATH_DURATION = 40.0  # s, of the linear sampling plan (slow: only its geometry is used)
_PATH_RATE = 100.0


@dataclass
class Case:
    """One joint path: q (n, k) at s (n,) in [0, 1], the s of its stops, and its request."""

    name: str
    arm: robodcn.Arm
    waypoints: list[list[float]]
    method: str
    beta: float
    blend: bool
    q: np.ndarray
    s: np.ndarray
    stops: list[float]

    @property
    def limits(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        v = np.array([j.max_velocity for j in self.arm.joints])
        a = np.array([j.max_acceleration for j in self.arm.joints])
        return v, a, JERK_PER_ACCEL * a

    def quintic_auto(self) -> tuple[float, np.ndarray]:
        """Today's quintic ``duration="auto"`` and its own peak joint jerk (FD at 1 kHz)."""
        traj = robodcn.plan(self.arm, self.waypoints, method=self.method, beta=self.beta,
                            blend=self.blend, profile="quintic", rate_hz=1000)
        jerk = np.abs(np.diff(traj.joints, 3, axis=0)).max(axis=0) * 1000.0 ** 3
        return traj.duration, jerk


def joint_path(arm: robodcn.Arm, waypoints: list[list[float]], method: str, beta: float,
               blend: bool) -> tuple[np.ndarray, np.ndarray, list[float]]:
    """q(s) samples, s, and the s of every via where the path stops (none when blended)."""
    traj = robodcn.plan(arm, waypoints, method=method, beta=beta, blend=blend,
                        profile="linear", duration=_PATH_DURATION, rate_hz=_PATH_RATE)
    s = traj.t / traj.t[-1]
    stops = []
    if not blend:
        for via in waypoints[1:-1]:
            i = int(np.argmin(np.linalg.norm(traj.poses[:, :2] - np.asarray(via[:2]), axis=1)))
            stops.append(float(s[i]))
    return traj.joints, s, stops


def cases() -> list[Case]:
    """≥ 20 varied paths: 2R and 3R, every method, single moves, stops at vias and blends."""
    arm3 = robodcn.load_arm(ROOT / "configs" / "arm3r.toml")
    arm2 = robodcn.load_arm(ROOT / "configs" / "arm2r.toml")
    d = math.radians
    vias3 = [[0.25, 0.10, 0.0], [0.2, 0.15, d(20)], [0.15, 0.2, d(40)], [0.12, 0.24, d(60)],
             [0.05, 0.25, d(80)]]
    single3 = [[0.25, 0.10, 0.0], [0.05, 0.28, d(90)]]
    vias2 = [[0.18, 0.08, 0.0], [0.12, 0.14, 0.0], [0.02, 0.2, 0.0], [-0.1, 0.15, 0.0]]
    single2 = [[0.18, 0.08, 0.0], [-0.05, 0.2, 0.0]]
    specs = []
    for method, beta in (("sclerp", 1.0), ("kenlerp", 0.5), ("kenlerp", 2.0), ("seplerp", 1.0),
                         ("dlb", 1.0)):
        specs.append((arm3, single3, method, beta, False))
        specs.append((arm3, vias3, method, beta, False))
        specs.append((arm3, vias3, method, beta, True))
    for method, beta in (("sclerp", 1.0), ("kenlerp", 2.0), ("seplerp", 1.0), ("dlb", 1.0)):
        specs.append((arm2, single2, method, beta, False))
        specs.append((arm2, vias2, method, beta, False))
        specs.append((arm2, vias2, method, beta, True))
    out = []
    for arm, wp, method, beta, blend in specs:
        q, s, stops = joint_path(arm, wp, method, beta, blend)
        kind = "single" if len(wp) == 2 else ("blend" if blend else "stops")
        label = method if method != "kenlerp" else f"kenlerp β={beta:g}"
        out.append(Case(f"{arm.name} {label} {kind}", arm, wp, method, beta, blend, q, s, stops))
    return out


def toppra_duration(case: Case) -> float:
    """toppra's time-optimal duration on the same samples: one run per piece between stops."""
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    ta.setup_logging("WARNING")
    v, a, _ = case.limits
    cuts = [0, *(int(np.argmin(np.abs(case.s - x))) for x in case.stops), case.s.shape[0] - 1]
    total = 0.0
    for lo, hi in itertools.pairwise(cuts):
        path = ta.SplineInterpolator(case.s[lo:hi + 1], case.q[lo:hi + 1])
        instance = algo.TOPPRA([constraint.JointVelocityConstraint(v),
                                constraint.JointAccelerationConstraint(a)], path,
                               parametrizer="ParametrizeConstAccel")
        traj = instance.compute_trajectory(0.0, 0.0)
        if traj is None:
            raise RuntimeError(f"toppra failed on {case.name}")
        total += float(traj.duration)
    return total


def ours(case: Case, jerk: bool | np.ndarray = False, **kw: object):
    v, a, j = case.limits
    if isinstance(jerk, np.ndarray):
        j, jerk = jerk, True
    return time_optimal(case.q, case.s, v, a, j if jerk else None, stops=case.stops, **kw)


def median_seconds(fn: Callable[[], object], repeat: int, warmup: int = 2) -> float:
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def _ok(flag: bool) -> str:
    return "✓" if flag else "✗"


def accuracy_rows(all_cases: list[Case]) -> tuple[list[str], dict[str, float]]:
    rows = ["| path | ours (s) | toppra (s) | ours / toppra | jerk 10a (s) | "
            "jerk 10a / optimum (✓ ≤ quintic) | jerk = quintic's (s) | quintic auto (s) | "
            "ours ms | toppra ms |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    worst = {"ratio": 0.0, "jerk_vs_quintic": 0.0, "jerk_ratio_min": math.inf,
             "jerk_ratio_max": 0.0, "qjerk_vs_quintic": 0.0}
    free_blend: dict[str, dict[str, float]] = {}
    blend_vs_stop = {}
    for case in all_cases:
        t0 = time.perf_counter()
        law = ours(case)
        t_ours = time.perf_counter() - t0
        t0 = time.perf_counter()
        ref = toppra_duration(case)
        t_ref = time.perf_counter() - t0
        jl = ours(case, jerk=True)
        quintic, quintic_jerk = case.quintic_auto()
        jq = ours(case, jerk=quintic_jerk)
        worst["qjerk_vs_quintic"] = max(worst["qjerk_vs_quintic"], jq.duration / quintic)
        ratio = law.duration / ref
        worst["ratio"] = max(worst["ratio"], ratio)
        worst["jerk_vs_quintic"] = max(worst["jerk_vs_quintic"], jl.duration / quintic)
        worst["jerk_ratio_min"] = min(worst["jerk_ratio_min"], jl.duration / law.duration)
        worst["jerk_ratio_max"] = max(worst["jerk_ratio_max"], jl.duration / law.duration)
        if len(case.waypoints) > 2:
            key, kind = case.name.rsplit(" ", 1)[0], "blend" if case.blend else "stops"
            blend_vs_stop.setdefault(key, {})[kind] = jl.duration
            free_blend.setdefault(key, {})[kind] = law.duration
        rows.append(f"| {case.name} | {law.duration:.4f} | {ref:.4f} | {ratio:.4f} "
                    f"{_ok(ratio <= TOPPRA_RATIO_TARGET)} | {jl.duration:.4f} | "
                    f"{jl.duration / law.duration:.3f} {_ok(jl.duration <= quintic)} | "
                    f"{jq.duration:.4f} {_ok(jq.duration <= quintic)} | {quintic:.3f} | "
                    f"{t_ours * 1e3:.2f} | {t_ref * 1e3:.2f} |")
    worst["blend_over_stops"] = max(p["blend"] / p["stops"] for p in blend_vs_stop.values())
    worst["free_blend_over_stops"] = max(p["blend"] / p["stops"] for p in free_blend.values())
    return rows, worst


def speed_rows() -> list[str]:
    """A 10 s, 1 kHz plan (interpolation + IK + timing) and a 2 s moving-start timing."""
    arm = robodcn.load_arm(ROOT / "configs" / "arm3r.toml")
    v = np.array([j.max_velocity for j in arm.joints])
    a = np.array([j.max_acceleration for j in arm.joints])
    # a long, slow-limit path: 10 s at these limits (scaled down)
    wp = [[0.25, 0.10, 0.0], [0.05, 0.28, math.radians(90)]]
    s = np.linspace(0.0, 1.0, 10_001)

    def joints(s: np.ndarray) -> np.ndarray:
        poses = robodcn.interpolate(wp[0], wp[1], s, method="sclerp")
        return robodcn.kinematics.ik_path(arm.links, poses, elbow=arm.elbow)

    q = joints(s)
    probe = time_optimal(q, s, v, a)
    k = probe.duration / 10.0  # speed scale that makes the optimal move last ~10 s
    kk = min(1.0, k * 1.0)

    def plan_10s() -> object:
        qq = joints(s)
        law = time_optimal(qq, s, v, a, scale=kk)
        return law.sample(1000.0)

    def plan_10s_jerk() -> object:
        qq = joints(s)
        law = time_optimal(qq, s, v, a, JERK_PER_ACCEL * a, scale=kk, rate_hz=1000.0)
        return law.sample(1000.0)

    t_plan = median_seconds(plan_10s, 15)
    t_plan_j = median_seconds(plan_10s_jerk, 7)
    d10 = time_optimal(q, s, v, a, scale=kk).duration
    t_timing = median_seconds(lambda: time_optimal(q, s, v, a, scale=kk), 15)
    ref = toppra_compute(q, s, v * kk, a * kk * kk)
    # moving start: a 2 s path at 1 kHz from half the admissible speed
    s2 = np.linspace(0.0, 1.0, 2001)
    q2 = joints(s2)
    k2 = min(1.0, time_optimal(q2, s2, v, a).duration / 2.0)
    sd0 = 0.5 / 2.0
    t_moving = median_seconds(lambda: time_optimal(q2, s2, v, a, sd_start=sd0, scale=k2)
                              .sample(1000.0), 15)
    t_moving_j = median_seconds(lambda: time_optimal(q2, s2, v, a, JERK_PER_ACCEL * a,
                                                     sd_start=sd0, sdd_start=0.0, scale=k2,
                                                     rate_hz=1000.0).sample(1000.0), 7)
    return [
        f"| 10 s path at 1 kHz (10,001 samples; optimal {d10:.2f} s): interpolate + IK + "
        f"timing + sampling, no jerk limit | {t_plan * 1e3:.2f} ms | ≤ {PLAN_TARGET_MS:g} ms "
        f"{_ok(t_plan * 1e3 <= PLAN_TARGET_MS)} |",
        f"| · same, with jerk limits | {t_plan_j * 1e3:.2f} ms | — |",
        f"| · our timing alone (TOPP-RA, {10_001:,} samples) | {t_timing * 1e3:.2f} ms | — |",
        f"| · toppra 0.6 on the same path (spline + TOPPRA, default grid) | "
        f"{ref * 1e3:.2f} ms = {ref / t_timing:.1f}× ours | — |",
        f"| 2 s path at 1 kHz from a moving start (ṡ₀ = {sd0:g}/s): timing + sampling | "
        f"{t_moving * 1e3:.2f} ms | ≤ {MOVING_TARGET_MS:g} ms "
        f"{_ok(t_moving * 1e3 <= MOVING_TARGET_MS)} |",
        f"| · same, with jerk limits | {t_moving_j * 1e3:.2f} ms | — |",
    ]


def toppra_compute(q: np.ndarray, s: np.ndarray, v: np.ndarray, a: np.ndarray) -> float:
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    ta.setup_logging("WARNING")

    def run() -> object:
        path = ta.SplineInterpolator(s, q)
        instance = algo.TOPPRA([constraint.JointVelocityConstraint(v),
                                constraint.JointAccelerationConstraint(a)], path,
                               parametrizer="ParametrizeConstAccel")
        return instance.compute_trajectory(0.0, 0.0)

    return median_seconds(run, 5, warmup=1)


def run() -> str:
    load = os.getloadavg()[0]
    all_cases = cases()
    rows, worst = accuracy_rows(all_cases)
    out = [
        "## Path timing: time-optimal, jerk-limited (robodcn.path_timing) vs toppra",
        "",
        f"{len(all_cases)} joint paths (configs/arm3r.toml, configs/arm2r.toml; every method; "
        "single moves, stops at every via, blends), timed by `time_optimal` (TOPP-RA with "
        "closed-form stage LPs, ≤ 1000 stages) and by toppra 0.6 in the same run. Jerk limits "
        f"{JERK_PER_ACCEL:g} × the acceleration limit per second. Load average at the start: "
        f"{load:.2f} (2 cores shared with other jobs: medians rise with it).",
        "",
        "| measurement | figure | target |",
        "|---|---|---|",
        f"| worst duration ratio ours / toppra (no jerk limit) | {worst['ratio']:.4f} | "
        f"≤ {TOPPRA_RATIO_TARGET} {_ok(worst['ratio'] <= TOPPRA_RATIO_TARGET)} |",
        f"| worst jerk-limited (j = 10 a) / quintic `auto` | {worst['jerk_vs_quintic']:.3f} | "
        f"≤ 1 {_ok(worst['jerk_vs_quintic'] <= 1.0)} |",
        f"| worst jerk-limited (j = the quintic plan's own peak jerk) / quintic `auto` | "
        f"{worst['qjerk_vs_quintic']:.3f} | ≤ 1 {_ok(worst['qjerk_vs_quintic'] <= 1.0)} |",
        f"| jerk-limited / jerk-free optimum | {worst['jerk_ratio_min']:.3f}–"
        f"{worst['jerk_ratio_max']:.3f} | — |",
        f"| worst blend / stop-at-every-via, no jerk limit | "
        f"{worst['free_blend_over_stops']:.3f} | ≤ 1 "
        f"{_ok(worst['free_blend_over_stops'] <= 1.0)} |",
        f"| worst blend / stop-at-every-via, j = 10 a | {worst['blend_over_stops']:.3f} | "
        f"≤ 1 {_ok(worst['blend_over_stops'] <= 1.0)} |",
        *speed_rows(),
        "",
        *rows,
    ]
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    print(run())
