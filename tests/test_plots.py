"""robodcn.plots: the motion plot (arm, waypoints, approach, stop, velocity/acceleration
against limits) and the workspace plot; planning never imports matplotlib."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
from conftest import ARM3R, ROOT

from robodcn import kinematics, servo_units
from robodcn.planner import plan
from robodcn.plots import approach_end, arm_points, plot_motion, plot_workspace, waypoint_samples
from robodcn.workflow.check import workspace_samples

ARM = ARM3R
WAYPOINTS = [ARM.home, (0.12, 0.24, np.radians(60)), (-0.10, 0.22, np.radians(120))]


def test_arm_points_end_at_fk():
    q = np.radians([30.0, -70.0, 20.0])
    pts = arm_points(ARM.links, q)
    assert pts.shape == (4, 2) and np.allclose(pts[0], 0.0)
    assert np.allclose(pts[-1], kinematics.fk(ARM.links, q[None])[0][:2])
    assert np.allclose(np.hypot(*np.diff(pts, axis=0).T), ARM.links)


def test_approach_end_is_where_the_path_starts():
    start = np.radians([0.0, 0.0, 0.0])
    traj = plan(ARM, WAYPOINTS, start_joints=start)
    i = approach_end(traj)
    assert i > 0 and np.allclose(traj.poses[i, :2], WAYPOINTS[0][:2], atol=1e-6)
    assert np.allclose(traj.joints[0], start)
    assert approach_end(plan(ARM, WAYPOINTS)) == 0
    marks = waypoint_samples(traj, np.asarray(WAYPOINTS))
    assert marks[0] == i and marks[-1] == len(traj.t) - 1 and marks == sorted(marks)


def test_plot_motion_writes_a_png(tmp_path):
    traj = plan(ARM, WAYPOINTS, start_joints=np.zeros(3))
    half = len(traj.t) // 2
    samples = [(t, tuple(k)) for t, k in zip(traj.t[:half], traj.ticks[:half], strict=True)]
    png = tmp_path / "motion.png"
    plot_motion(str(png), ARM, traj, samples=samples,
                stop={"t": float(traj.t[half]), "reason": "stopped"})
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 20_000
    q = servo_units.ticks_to_radians(np.array([s[1] for s in samples]), ARM.servos)
    assert np.allclose(q, traj.joints[:half], atol=np.pi / 4096)


def test_plot_workspace_writes_a_png(tmp_path):
    png = tmp_path / "ws.png"
    plot_workspace(str(png), ARM, workspace_samples(ARM, per_joint=11))
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_planning_and_the_plots_module_do_not_import_matplotlib():
    code = ("import sys, robodcn, robodcn.plots, robodcn.workflow.files; "
            "robodcn.plan(robodcn.load_arm('configs/arm3r.toml'), [[0.25, 0.1, 0], "
            "[0.12, 0.24, 1]]); print('matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def test_plot_motion_marks_where_a_limit_came_near(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    figures = []
    monkeypatch.setattr(plt, "close", figures.append)
    traj = plan(ARM, WAYPOINTS[:2])
    i = len(traj.t) // 3
    near = [{"joint": "elbow", "quantity": "current", "sample": i, "time_s": float(traj.t[i]),
             "value": 1.0, "peak": 1.1, "limit": 1.2}]
    plot_motion(str(tmp_path / "near.png"), ARM, traj, near_limits=near)
    path_ax, vel_ax = figures[0].axes[:2]
    marked = [line for line in path_ax.lines if line.get_label() == "limit within 10 %"]
    assert len(marked) == 1
    assert np.allclose(np.ravel(marked[0].get_xydata()), traj.poses[i, :2])
    assert [list(line.get_xdata()) for line in vel_ax.lines
            if line.get_marker() == "x"] == [[traj.t[i]]]
    monkeypatch.undo()
    plt.close(figures[0])
