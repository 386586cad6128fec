"""Tool-space limits (issue 30): the optimal law under a tool speed and acceleration against
toppra's optimum on the same joint path, and the straight line at a constant tool speed.

The joint path is the planner's own (its dense IK samples in joint-space arc length:
``build_pieces`` + ``by_arc_length``). toppra (``TOPPRA``, interpolation discretisation,
1000 stages, a cubic spline through the same samples) times it with the tool's arc length σ
(the cumulative chord of the tool point, :func:`robodcn.dynamics.tool_point`) added as an
extra path coordinate whose velocity and acceleration limits are the tool speed and
acceleration (|σ̇| ≤ v, |σ̈| ≤ a: the same constraints as ours), beside the joints' own
limits. Ours is ``robodcn.path_timing.time_optimal(tool=...)`` on the same samples, and the
whole plan (``robodcn.plan``, 100 Hz, validated sample by sample: the tool's finite
differences within the limits) with its planning time. Target: ours ≤ 1.02 × toppra's (the
plan: + one period). The line: seplerp from (0.25, 0.10, 0°) to (0.15, 0.20, 0°) on arm3r at
0.05 m/s and 0.5 m/s²; target |speed − 0.05| ≤ 0.5 % over the cruise.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np

import robodcn
from bench.bench_planner import median_seconds
from robodcn.config import load_arm
from robodcn.contract.request import PlanRequest
from robodcn.dynamics import tool_point
from robodcn.path_timing import JointLimits, time_optimal
from robodcn.path_timing.tool import ToolLimits
from robodcn.planner.arc import by_arc_length
from robodcn.planner.pieces import build_pieces
from robodcn.planner.tool_peak import tool_speeds

ROOT = Path(__file__).resolve().parent.parent
RATIO_TARGET = 1.02
LINE_TARGET = 0.005
RATE = 100.0
#: (arm, move, waypoints, method, tool speed m/s, tool acceleration m/s²)
CASES = (
    ("arm3r", "line", [[0.25, 0.10, 0.0], [0.15, 0.20, 0.0]], "seplerp", 0.05, 0.5),
    ("arm3r", "to (0.12, 0.24, 60°)", [[0.25, 0.10, 0.0], [0.12, 0.24, 1.0472]], "sclerp",
     0.10, 1.0),
    ("arm3r", "sweep", [[0.30, -0.05, 0.3], [0.10, 0.25, 0.9]], "kenlerp", 0.20, 2.0),
    ("arm2r", "line", [[0.25, 0.10], [0.15, 0.20]], "seplerp", 0.05, 0.5),
    ("arm2r", "arc", [[0.25, 0.0], [0.0, 0.25]], "sclerp", 0.25, 1.0),
    ("omx", "low → side", [[0.25, 0.0, 0.05, 0.0], [0.0, 0.25, 0.15, 0.0]], "seplerp", 0.10,
     0.5),
    ("omx", "high → low", [[0.12, -0.15, 0.22, 0.0], [0.26, 0.05, 0.04, -0.3]], "dlb", 0.25,
     2.0),
)


def arm_named(name: str) -> robodcn.Arm:
    return load_arm(ROOT / "configs" / f"{name}.toml")


def joint_path(arm: robodcn.Arm, waypoints: list[list[float]], method: str
               ) -> tuple[np.ndarray, np.ndarray]:
    """The planner's dense joint path (s, q) of a one-segment move (joint arc length)."""
    req = PlanRequest(arm=arm, waypoints=waypoints, method=method, rate_hz=RATE,
                      beta=0.0 if method == "kenlerp" else 1.0)
    pieces, _ = build_pieces(req)
    assert pieces is not None and len(pieces) == 1
    piece = by_arc_length(req, pieces)[0]
    return piece.s, piece.q


def ours(arm: robodcn.Arm, s: np.ndarray, q: np.ndarray, speed: float, accel: float
         ) -> float:
    """Our optimal law's duration on (s, q) under the joint and tool limits."""
    lim = JointLimits.of(arm, torque=False)
    tool = ToolLimits.of(arm, speed, None, accel)
    return time_optimal(q, s, lim.v, lim.a, tool=tool).duration


def toppra_tool_timing(arm: robodcn.Arm, s: np.ndarray, q: np.ndarray, speed: float,
                       accel: float) -> tuple[float, float]:
    """(duration, seconds to solve) of toppra's optimum on (s, q) with the tool's arc length
    σ(s) as an extra path coordinate limited to ``speed`` and ``accel`` (module doc)."""
    import toppra
    from toppra import algorithm, constraint

    logging.getLogger("toppra").setLevel(logging.ERROR)
    lim = JointLimits.of(arm, torque=False)
    p = tool_point(ToolLimits.of(arm, speed).chain, q)
    sigma = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    v = np.append(lim.v, speed)
    a = np.append(lim.a, accel)
    start = time.perf_counter()
    path = toppra.SplineInterpolator(s, np.column_stack([q, sigma]))
    interp = constraint.DiscretizationType.Interpolation
    cons = [constraint.JointVelocityConstraint(np.stack([-v, v], axis=1)),
            constraint.JointAccelerationConstraint(np.stack([-a, a], axis=1),
                                                   discretization_scheme=interp)]
    inst = algorithm.TOPPRA(cons, path, gridpoints=np.linspace(s[0], s[-1], 1001),
                            parametrizer="ParametrizeConstAccel")
    duration = inst.compute_trajectory(0.0, 0.0).duration
    return duration, time.perf_counter() - start


def line_cruise(traj: robodcn.Trajectory, speed: float, accel: float) -> np.ndarray:
    """The tool speeds of the cruise: past each ramp (v/a) and two periods of rounding."""
    v = tool_speeds(traj)[0]
    t = traj.t
    ramp = speed / accel + 2.0 / traj.rate_hz
    return v[(t > ramp) & (t < traj.t[-1] - ramp)]


def run() -> str:
    try:
        import toppra  # noqa: F401
    except ImportError:
        return "## Tool-space limits vs toppra\n\ntoppra is not installed: skipped.\n"
    ok = lambda good: "✅" if good else "❌"  # noqa: E731
    rows = [
        "## Tool-space limits vs toppra",
        "",
        __doc__.split("\n\n", 1)[1].replace("\n", " ").strip(),
        "",
        "| arm | move | method | tool v, a | ours (s) | toppra (s) | ratio (target ≤ "
        f"{RATIO_TARGET:g}) | without tool limits (s) | plan (100 Hz): duration, peak tool "
        "speed, time | solve: ours / toppra (ms) |",
        "|---|---|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    worst = 0.0
    for arm_name, move, waypoints, method, speed, accel in CASES:
        arm = arm_named(arm_name)
        s, q = joint_path(arm, waypoints, method)
        mine = ours(arm, s, q, speed, accel)
        lim = JointLimits.of(arm, torque=False)
        bare = time_optimal(q, s, lim.v, lim.a).duration
        t_ours = median_seconds(lambda a=arm, s=s, q=q, v=speed, c=accel: ours(a, s, q, v, c), 5)
        theirs, t_theirs = toppra_tool_timing(arm, s, q, speed, accel)
        ratio = mine / theirs
        worst = max(worst, ratio)
        kw = dict(method=method, beta=0.0 if method == "kenlerp" else 1.0, rate_hz=RATE,
                  tool_speed=speed, tool_acceleration=accel)
        traj = robodcn.plan(arm, waypoints, **kw)
        t_plan = median_seconds(lambda a=arm, w=waypoints, kw=kw: robodcn.plan(a, w, **kw), 5)
        rows.append(
            f"| {arm_name} | {move} | {method} | {speed:g} m/s, {accel:g} m/s² | {mine:.4f} | "
            f"{theirs:.4f} | {ratio:.4f} {ok(ratio <= RATIO_TARGET)} | {bare:.4f} | "
            f"{traj.duration:.2f} s, {tool_speeds(traj)[0].max():.4f} m/s, {t_plan * 1e3:.1f} ms "
            f"| {t_ours * 1e3:.1f} / {t_theirs * 1e3:.1f} |")
    arm = arm_named("arm3r")
    line = robodcn.plan(arm, CASES[0][2], method="seplerp", tool_speed=0.05,
                        tool_acceleration=0.5, rate_hz=RATE)
    cruise = line_cruise(line, 0.05, 0.5)
    off = float(np.abs(cruise / 0.05 - 1.0).max())
    rows += ["", f"Worst ratio: {worst:.4f} (target ≤ {RATIO_TARGET:g}) "
             f"{ok(worst <= RATIO_TARGET)}.",
             "", f"Straight line on arm3r at 0.05 m/s: {cruise.shape[0]} cruise samples, "
             f"speed {cruise.min():.5f}..{cruise.max():.5f} m/s, worst |speed − 0.05| "
             f"{off * 100:.3f} % (target ≤ {LINE_TARGET * 100:g} %) {ok(off <= LINE_TARGET)}."]
    return "\n".join(rows) + "\n"


if __name__ == "__main__":
    print(run())
