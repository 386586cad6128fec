"""Collision stop and overload recovery (issue 11 §4) on the physics sim."""

from __future__ import annotations

import math
import threading

import numpy as np
from conftest import ARM3R

from robodcn.planner import plan
from robodcn.simulated import simulated_arm
from robodcn.stream import execute

MOVE = [(0.25, 0.10, 0.0), (0.12, 0.24, math.radians(60))]


def test_an_obstacle_stops_the_move_with_a_collision_report():
    traj = plan(ARM3R, MOVE, method="sclerp", duration=2.0)
    q0, q1 = np.degrees(traj.joints[0, 0]), np.degrees(traj.joints[-1, 0])
    block = q0 + 0.4 * (q1 - q0)
    with simulated_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as sa:
        sa.sim.servo(1).set_obstacle(float(block))
        report = execute(traj, sa.bus, tracking_limit=None)
        held = sa.bus.read_positions()
    assert report.stop_reason == "collision", report.message
    assert report.outcome == "collision"
    hit = report.collision
    assert hit is not None and hit["joint"] == "shoulder" and hit["servo_id"] == 1
    assert hit["current_a"] > hit["threshold_a"] == report.collision_threshold_a[0]
    # Where on the path: the sample's time and pose, past the obstacle's share of the path.
    assert hit["time_s"] == traj.t[hit["sample"]]
    assert np.allclose(hit["pose"], traj.poses[hit["sample"]])
    assert report.samples_sent < report.samples_total
    assert report.hold_goals is not None
    assert np.abs(held - np.array(report.hold_goals)).max() <= 5
    assert report.to_dict()["outcome"] == "collision"


def test_the_same_move_without_obstacle_is_not_a_collision():
    traj = plan(ARM3R, MOVE, method="sclerp", duration=2.0)
    with simulated_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as sa:
        report = execute(traj, sa.bus, tracking_limit=None)
    assert report.stop_reason == "completed", report.message
    assert report.collision is None
    assert all(p < t for p, t in zip(report.current_peak_a, report.collision_threshold_a,
                                      strict=True))


def test_overload_recovery_reboots_holds_and_does_not_resume():
    traj = plan(ARM3R, MOVE, method="sclerp", duration=2.0)
    with simulated_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as sa:
        timer = threading.Timer(0.5, sa.sim.servo(2).trip, args=(0x20,))
        timer.start()
        try:
            report = execute(traj, sa.bus, tracking_limit=None, recover=True)
        finally:
            timer.cancel()
        servo = sa.sim.servo(2)
        assert servo.hardware_error == 0 and servo.torque_enabled
        assert abs(servo.goal_position - servo.present_position) <= 5
    assert report.stop_reason == "hardware_alert", report.message
    assert [r["servo_id"] for r in report.recovered] == [2]
    assert report.recovered[0]["recovered"] is True
    assert report.samples_sent < report.samples_total


def test_a_collision_is_the_move_status_collision_in_the_controller():
    from robodcn.controller import ArmController

    traj = plan(ARM3R, [ARM3R.home, (0.12, 0.24, math.radians(60))], method="sclerp",
                duration=2.0)
    q0, q1 = np.degrees(traj.joints[0, 0]), np.degrees(traj.joints[-1, 0])
    with simulated_arm(ARM3R, timing="fast") as sa:
        sa.sim.servo(1).set_obstacle(float(q0 + 0.4 * (q1 - q0)))
        controller = ArmController(ARM3R, sa.bus, execute_options={"watchdog_ms": 1000,
                                                                   "tracking_limit": None})
        try:
            record = controller.wait(controller.start_move(traj).id, timeout=10)
        finally:
            controller.close()
    assert record.status == "collision", record.error
    assert record.report is not None and record.report.collision["joint"] == "shoulder"
    assert record.to_dict()["status"] == "collision"


def test_servos_with_a_d_gain_get_no_default_collision_stop_and_a_warning():
    from conftest import ARM2R

    from robodcn.config import arm_from_dict

    traj = plan(ARM2R, [(0.18, 0.08, 0.0), (0.02, 0.20, 0.0)], duration="auto")
    with simulated_arm(ARM2R, timing="fast", start_joints=traj.joints[0]) as sa:
        assert all(d > 0 for d in sa.bus.position_d_gains)     # XL430 factory D gain
        report = execute(traj, sa.bus, tracking_limit=None)
    assert report.stop_reason == "completed", report.message
    assert report.collision_threshold_a == (None, None)
    assert [w["code"] for w in report.warnings] == ["collision_stop_off"]
    # A configured threshold still applies.
    data = ARM2R.to_dict()
    data["joints"][0]["collision_current_a"] = 2.0
    arm = arm_from_dict(data)
    traj = plan(arm, [(0.18, 0.08, 0.0), (0.02, 0.20, 0.0)], duration="auto")
    with simulated_arm(arm, timing="fast", start_joints=traj.joints[0]) as sa:
        report = execute(traj, sa.bus, tracking_limit=None)
    assert report.collision_threshold_a == (2.0, None)


def test_bad_collision_options_are_refused_before_any_write():
    import pytest

    from robodcn.errors import InputError
    from robodcn.stream import ExecutionOptions

    with pytest.raises(InputError) as err:
        ExecutionOptions(collision_current=(1.0, -1.0, 1.0))
    assert err.value.field == "collision_current[1]"
    with pytest.raises(InputError) as err:
        ExecutionOptions(collision_cycles=0)
    assert err.value.field == "collision_cycles"
    traj = plan(ARM3R, MOVE, method="sclerp", duration=1.0)
    with simulated_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as sa:
        before = [len(sa.sim.goal_history(i)) for i in ARM3R.servo_ids]
        with pytest.raises(InputError) as err:
            execute(traj, sa.bus, collision_current=(1.0, 1.0))
        assert [len(sa.sim.goal_history(i)) for i in ARM3R.servo_ids] == before
    assert err.value.field == "collision_current"


def test_cli_sim_collision_exits_4_and_reports_where(monkeypatch, capsys, tmp_path):
    import contextlib

    import robodcn.plots
    import robodcn.simulated
    from robodcn import cli

    to = (0.12, 0.24, math.radians(60))
    traj = plan(ARM3R, [ARM3R.home, to], method="sclerp", duration=2.0)
    q0, q1 = np.degrees(traj.joints[0, 0]), np.degrees(traj.joints[-1, 0])
    real = robodcn.simulated.simulated_arm

    @contextlib.contextmanager
    def with_obstacle(*args, **kwargs):
        with real(*args, **kwargs) as sa:
            sa.sim.servo(1).set_obstacle(float(q0 + 0.4 * (q1 - q0)))
            yield sa

    drawn = {}
    monkeypatch.setattr(robodcn.simulated, "simulated_arm", with_obstacle)
    monkeypatch.setattr(robodcn.plots, "plot_motion",
                        lambda path, arm, traj, **kw: drawn.update(kw))
    code = cli.main(["sim", "--arm", str(ARM3R.source), "--to", "0.12,0.24,60",
                     "--method", "sclerp", "--duration", "2", "--timing", "fast",
                     "--tracking-limit", "90", "--plot", str(tmp_path / "hit.png")])
    out = capsys.readouterr().out
    assert code == 4, out
    assert out.startswith("collision after "), out
    assert "  collision at shoulder: " in out
    shoulder = next(line for line in out.splitlines() if line.startswith("  shoulder "))
    assert "°/s, current " in shoulder and "predicted " in shoulder
    assert "collision stop " in shoulder and "collision stop off" not in shoulder
    assert "near limit: shoulder current vs the collision stop" in out
    marks = drawn["near_limits"]
    assert any(m["joint"] == "shoulder" and m["quantity"] == "collision_current"
               for m in marks)
    assert drawn["stop"]["reason"] == "collision"
