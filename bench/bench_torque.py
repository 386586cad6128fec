"""Torque-limited optimal timing (issue 19) against toppra's torque-limited optimum, side by side.

Every case is a move of the OpenMANIPULATOR-X (configs/omx.toml: ``max_torque_nm`` on every
joint; links, payload at the tool point, gravity and the servos' rotor inertia in
robodcn.dynamics) with 0 and 0.5 kg. The joint path is the planner's own (its dense IK
samples in joint-space arc length: ``build_pieces`` + ``by_arc_length``); on it
``robodcn.path_timing.time_optimal(torque=...)`` and toppra (``TOPPRA`` with
``JointVelocityConstraint``, ``JointAccelerationConstraint`` and ``JointTorqueConstraint``
calling robodcn's inverse dynamics, interpolation discretisation, 1000 stages, a cubic
spline through the same samples) time the same path in the same run. "fast" is the OM-X
with acceleration limits of 60 rad/s² and velocity limits of 4 rad/s, so the servos' torque,
not the acceleration limit, binds; the packaged limits rarely let it bind. The planner's
whole plan (``robodcn.plan``, 100 Hz, validated sample by sample against the torque limits)
is shown with its planning time.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from pathlib import Path

import numpy as np

import robodcn
from bench.bench_planner import median_seconds
from robodcn.config import load_arm, rigid_chain
from robodcn.contract.request import PlanRequest
from robodcn.dynamics import inverse_dynamics
from robodcn.path_timing import JointLimits, time_optimal
from robodcn.planner.arc import by_arc_length
from robodcn.planner.pieces import build_pieces

ROOT = Path(__file__).resolve().parent.parent
RATIO_TARGET = 1.02
RATE = 100.0
MOVES = {
    "low → side": [[0.25, 0.0, 0.05, 0.0], [0.0, 0.25, 0.15, 0.0]],
    "high → low": [[0.12, -0.15, 0.22, 0.0], [0.26, 0.05, 0.04, -0.3]],
    "reach": [[0.28, 0.0, 0.12, 0.0], [0.05, -0.2, 0.25, 0.5]],
}


def fast(arm: robodcn.Arm) -> robodcn.Arm:
    return dataclasses.replace(arm, joints=tuple(
        dataclasses.replace(j, max_acceleration=60.0, max_velocity=4.0) for j in arm.joints))


def joint_path(arm: robodcn.Arm, waypoints: list[list[float]], payload: float
               ) -> tuple[np.ndarray, np.ndarray]:
    req = PlanRequest(arm=arm, waypoints=waypoints, payload_kg=payload, rate_hz=RATE)
    pieces, _ = build_pieces(req)
    assert pieces is not None and len(pieces) == 1
    piece = by_arc_length(req, pieces)[0]
    return piece.s, piece.q


def toppra_timing(arm: robodcn.Arm, s: np.ndarray, q: np.ndarray, payload: float):
    """(duration, seconds to solve) of toppra's torque-limited optimum."""
    import toppra
    from toppra import algorithm, constraint

    logging.getLogger("toppra").setLevel(logging.ERROR)
    lim = JointLimits.of(arm, payload)
    chain = rigid_chain(arm)
    tau = np.array(arm.max_torques, dtype=float)
    interp = constraint.DiscretizationType.Interpolation

    def solve() -> float:
        path = toppra.SplineInterpolator(s, q)
        cons = [constraint.JointVelocityConstraint(np.stack([-lim.v, lim.v], axis=1)),
                constraint.JointAccelerationConstraint(np.stack([-lim.a, lim.a], axis=1),
                                                       discretization_scheme=interp),
                constraint.JointTorqueConstraint(
                    lambda qq, vv, aa: inverse_dynamics(chain, qq, vv, aa, payload),
                    np.stack([-tau, tau], axis=1), np.zeros(q.shape[1]),
                    discretization_scheme=interp)]
        inst = algorithm.TOPPRA(cons, path, gridpoints=np.linspace(s[0], s[-1], 1001),
                                parametrizer="ParametrizeConstAccel")
        return inst.compute_trajectory(0.0, 0.0).duration

    start = time.perf_counter()
    duration = solve()  # once: its per-point Python callbacks take about a second
    return duration, time.perf_counter() - start


def run() -> str:
    packaged = load_arm(ROOT / "configs" / "omx.toml")
    try:
        import toppra  # noqa: F401
    except ImportError:
        return "## Torque-limited timing vs toppra\n\ntoppra is not installed: skipped.\n"
    ok = lambda good: "✅" if good else "❌"  # noqa: E731
    rows = [
        "## Torque-limited timing vs toppra",
        "",
        __doc__.split("\n\n", 1)[1].replace("\n", " ").strip(),
        "",
        "| arm | move | payload | ours (s) | toppra (s) | ratio (target ≤ "
        f"{RATIO_TARGET:g}) | ours without torque (s) | solve: ours / toppra (ms) | plan "
        "(100 Hz): duration, time |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    worst = 0.0
    for arm_name, arm in (("omx", packaged), ("fast", fast(packaged))):
        for move, waypoints in MOVES.items():
            for payload in (0.0, 0.5):
                s, q = joint_path(arm, waypoints, payload)
                lim = JointLimits.of(arm, payload)
                ours = time_optimal(q, s, lim.v, lim.a, torque=lim.torque).duration
                bare = time_optimal(q, s, lim.v, lim.a).duration
                t_ours = median_seconds(
                    lambda q=q, s=s, lim=lim: time_optimal(q, s, lim.v, lim.a,
                                                           torque=lim.torque), 5)
                theirs, t_theirs = toppra_timing(arm, s, q, payload)
                ratio = ours / theirs
                worst = max(worst, abs(ratio - 1.0))
                traj = robodcn.plan(arm, waypoints, payload_kg=payload, rate_hz=RATE)
                t_plan = median_seconds(
                    lambda arm=arm, w=waypoints, p=payload: robodcn.plan(
                        arm, w, payload_kg=p, rate_hz=RATE), 5)
                rows.append(
                    f"| {arm_name} | {move} | {payload:g} kg | {ours:.4f} | {theirs:.4f} | "
                    f"{ratio:.4f} {ok(abs(ratio - 1.0) <= RATIO_TARGET - 1.0)} | {bare:.4f} | "
                    f"{t_ours * 1e3:.1f} / {t_theirs * 1e3:.1f} | {traj.duration:.2f} s, "
                    f"{t_plan * 1e3:.1f} ms |")
    rows += ["", f"Worst |ratio − 1|: {worst * 100:.2f} % (target ≤ "
             f"{(RATIO_TARGET - 1) * 100:g} %) {ok(worst <= RATIO_TARGET - 1.0)}."]
    return "\n".join(rows) + "\n"


if __name__ == "__main__":
    print(run())
