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


def _captured(monkeypatch):
    """The figures plot_motion draws (plt.close captured instead of closing them)."""
    import matplotlib.pyplot as plt

    figures = []
    monkeypatch.setattr(plt, "close", figures.append)
    return figures


def _near_first(values, limit):
    near = np.flatnonzero(np.abs(values) >= 0.9 * limit)
    return int(near[0]) if near.size else None


def test_plot_motion_marks_where_a_limit_came_near(tmp_path, monkeypatch):
    figures = _captured(monkeypatch)
    traj = plan(ARM, WAYPOINTS[:2], duration="auto")
    i = len(traj.t) // 3
    near = [{"joint": "elbow", "quantity": "current", "sample": i, "time_s": float(traj.t[i]),
             "value": 1.0, "peak": 1.1, "limit": 1.2}]
    plot_motion(str(tmp_path / "near.png"), ARM, traj, near_limits=near)
    fig = figures[0]
    assert len(fig.axes) == 3                           # no trace: path, velocity, accel.
    path_ax, vel_ax, _ = fig.axes
    marked = [line for line in path_ax.lines if line.get_label() == "limit within 10 %"]
    assert len(marked) == 1
    assert np.allclose(np.ravel(marked[0].get_xydata()), traj.poses[i, :2])
    # The velocity/acceleration panels mark the plan's own approach to its limits (a
    # fastest move rides them), not the current mark, which has no panel without a trace.
    dt = 1.0 / traj.rate_hz
    vel = np.diff(traj.joints, axis=0, prepend=traj.joints[:1]) / dt
    expected = [traj.t[k] for j, spec in enumerate(ARM.joints)
                if (k := _near_first(vel[:, j], spec.max_velocity)) is not None]
    assert expected
    assert [float(line.get_xdata()[0]) for line in vel_ax.lines
            if line.get_marker() == "x"] == expected
    monkeypatch.undo()
    import matplotlib.pyplot as plt
    plt.close(fig)


def _trace(traj, *, with_current=True):
    """A trace as the streamer records it: a read every other sample, an error that grows
    with the joint speed, currents from a sine."""
    from robodcn.stream import ExecutionTrace

    rows = np.arange(0, len(traj.t), 2)
    k = len(ARM.joints)
    error = 0.01 * np.gradient(traj.joints, axis=0)[rows] * traj.rate_hz
    current = 0.4 * np.sin(np.linspace(0, 3, len(rows)))[:, None] * np.arange(1, k + 1)
    return ExecutionTrace(
        sample=rows, t=traj.t[rows] + 0.001, ticks=traj.ticks[rows],
        tracking_error_rad=error, current_a=current if with_current else None,
        joint_names=tuple(j.name for j in ARM.joints), tracking_limit_rad=np.radians(15.0),
        current_limit_a=(3.2, 3.2, 3.2), collision_threshold_a=(1.3, 0.8, None),
        predicted_current_a=0.5 * np.ones((len(traj.t), k)))


def test_plot_motion_draws_tracking_error_and_current_against_their_limits(tmp_path,
                                                                             monkeypatch):
    figures = _captured(monkeypatch)
    traj = plan(ARM, WAYPOINTS)
    trace = _trace(traj)
    row = 7
    near = [{"joint": "elbow", "quantity": "tracking_error", "sample": int(trace.sample[row]),
             "time_s": 0.0, "value": float(abs(trace.tracking_error_rad[row, 1])),
             "peak": 0.3, "limit": float(np.radians(15.0))},
            {"joint": "shoulder", "quantity": "collision_current",
             "sample": int(trace.sample[row + 3]), "time_s": 0.0,
             "value": float(abs(trace.current_a[row + 3, 0])), "peak": 1.2, "limit": 1.3}]
    plot_motion(str(tmp_path / "traced.png"), ARM, traj, trace=trace, near_limits=near)
    fig = figures[0]
    by_label = {ax.get_ylabel(): ax for ax in fig.axes}
    err_ax, cur_ax = by_label["|tracking error| [°]"], by_label["|current| [A]"]
    assert len([ax for ax in fig.axes if ax.has_data()]) >= 5   # path, v, a, error, current

    def curves(ax):
        return [line for line in ax.lines if len(line.get_xdata()) > 2]

    def levels(ax):   # horizontal lines (axhline: x data in axes coordinates [0, 1])
        return sorted(float(line.get_ydata()[0]) for line in ax.lines
                      if list(line.get_xdata()) == [0, 1])

    def marks(ax):
        return [tuple(np.ravel(line.get_xydata())) for line in ax.lines
                if line.get_marker() == "x"]

    errors = curves(err_ax)
    assert len(errors) == 3
    for j, line in enumerate(errors):
        assert np.allclose(line.get_xdata(), trace.t)
        assert np.allclose(line.get_ydata(), np.degrees(np.abs(trace.tracking_error_rad[:, j])))
    assert np.allclose(levels(err_ax), [15.0])
    assert np.allclose(marks(err_ax), [(trace.t[row], np.degrees(near[0]["value"]))])

    measured = [line for line in curves(cur_ax) if line.get_linestyle() == "-"]
    predicted = [line for line in curves(cur_ax) if line.get_linestyle() == "--"]
    assert len(measured) == len(predicted) == 3
    for j, line in enumerate(measured):
        assert np.allclose(line.get_xdata(), trace.t)
        assert np.allclose(line.get_ydata(), np.abs(trace.current_a[:, j]))
    assert np.allclose(predicted[0].get_xdata(), traj.t)
    assert np.allclose(levels(cur_ax), [0.8, 1.3, 3.2])   # stops (wrist's off), one limit
    assert np.allclose(marks(cur_ax), [(trace.t[row + 3], near[1]["value"])])
    monkeypatch.undo()
    import matplotlib.pyplot as plt
    plt.close(fig)


def test_a_trace_without_currents_adds_only_the_tracking_panel(tmp_path, monkeypatch):
    figures = _captured(monkeypatch)
    traj = plan(ARM, WAYPOINTS)
    plot_motion(str(tmp_path / "nocurrent.png"), ARM, traj, trace=_trace(traj,
                                                                          with_current=False))
    labels = [ax.get_ylabel() for ax in figures[0].axes]
    assert "|tracking error| [°]" in labels and "|current| [A]" not in labels
    monkeypatch.undo()
    import matplotlib.pyplot as plt
    plt.close(figures[0])


def test_sim_plot_draws_the_tracking_error_and_current_of_the_run(tmp_path, monkeypatch,
                                                                    capsys):
    from robodcn import cli

    figures = _captured(monkeypatch)
    png = tmp_path / "sim.png"
    code = cli.main(["sim", "--arm", str(ARM.source), "--from", "0.25,0.10,0",
                     "--via", "0.12,0.24,60", "--to", "-0.10,0.22,120", "--method", "kenlerp",
                     "--beta", "0.5", "--duration", "auto", "--timing", "fast",
                     "--plot", str(png)])
    out = capsys.readouterr()
    assert code in (0, 5), out.out                     # 5: samples skipped on a loaded host
    assert png.read_bytes()[:4] == b"\x89PNG" and f"plot: {png}" in out.err
    fig = figures[0]
    drawn = [ax for ax in fig.axes if ax.has_data()]
    assert len(drawn) >= 5
    by_label = {ax.get_ylabel(): ax for ax in fig.axes}
    for label in ("velocity [°/s]", "acceleration [°/s²]", "|tracking error| [°]",
                  "|current| [A]"):
        assert by_label[label].has_data(), label
    reads = [len(line.get_xdata()) for line in by_label["|current| [A]"].lines
             if line.get_linestyle() == "-"]
    assert reads and min(reads) > 50                  # one point per feedback read
    monkeypatch.undo()
    import matplotlib.pyplot as plt
    plt.close(fig)


def _inside(ax, points) -> bool:
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    x, y = np.asarray(points, dtype=float).T
    return bool(np.all((x0 <= x) & (x <= x1) & (y0 <= y) & (y <= y1)))


def _arrow_tips(ax) -> np.ndarray:
    """Where the tool-axis arrows of ``ax`` end (data units, scale_units="xy")."""
    from matplotlib.quiver import Quiver

    quiver = next(c for c in ax.collections if isinstance(c, Quiver))
    return quiver.XY + np.column_stack([quiver.U, quiver.V]) / quiver.scale


def test_the_path_views_hold_the_whole_path_and_its_arrows_and_do_not_overlap(tmp_path,
                                                                             monkeypatch):
    """The OM-X side view was cut at the right (quiver scales the view to the arrows'
    tails) and the top view's label ran into it; a planar arm's view likewise."""
    from robodcn.workflow import resolve_arm

    figures = _captured(monkeypatch)
    omx = resolve_arm("omx")
    cases = [(omx, [omx.home, (0.2, 0.1, 0.15, 0.0)]), (ARM, WAYPOINTS[:2])]
    for arm, waypoints in cases:
        traj = plan(arm, waypoints)
        plot_motion(str(tmp_path / f"{arm.name}.png"), arm, traj)
    (omx_fig, planar_fig) = figures
    side, top = omx_fig.axes[:2]
    r = np.hypot(*np.asarray(plan(omx, cases[0][1]).poses)[:, :2].T)
    assert _inside(side, np.column_stack([r, plan(omx, cases[0][1]).poses[:, 2]]))
    assert _inside(side, _arrow_tips(side))
    renderer = omx_fig.canvas.get_renderer()
    side_box = side.get_tightbbox(renderer)
    top_box = top.get_tightbbox(renderer)
    assert side_box.x1 < top_box.x0, "the top view overlaps the side view"
    path = planar_fig.axes[0]
    assert _inside(path, _arrow_tips(path))
    monkeypatch.undo()
    import matplotlib.pyplot as plt
    for fig in figures:
        plt.close(fig)
