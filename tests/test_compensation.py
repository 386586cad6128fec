"""Tracking compensation on the physics sim (issue 11 §3): with the arm's default masses,
the compensated stream's RMS tracking error is at most 1/5 of the uncompensated one and its
max ≤ 0.5° per joint, for the `make demo` move and for another fastest-possible move."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ARM3R, lockstep_arm

from robodcn.planner import plan
from robodcn.stream import execute

DEMO = [(0.25, 0.10, 0.0), (0.12, 0.24, math.radians(60)), (-0.10, 0.22, math.radians(120))]
SWEEP = [(0.30, 0.05, 0.0), (0.05, 0.30, math.radians(90))]


def run(traj, compensation: bool):
    """The report of a run on virtual time (conftest.lockstep_arm), every sample sent on
    time: a sample skipped late (a loaded machine; the in-process simulator shares the CPU
    with the streamer) is a goal jump the motor lags behind, which is not what compensation
    is measured on."""
    with lockstep_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as (sa, clock):
        report = execute(traj, sa.bus, compensation=compensation, tracking_limit=None,
                         settle=0.5, clock=clock)
        assert not sa.sim.errors, sa.sim.errors
    assert report.stop_reason == "completed", report.message
    assert report.compensation is compensation
    assert report.samples_skipped == 0 and report.lateness_max_s == 0.0
    return report


@pytest.mark.parametrize("waypoints,method", [(DEMO, "kenlerp"), (SWEEP, "sclerp")],
                         ids=["make-demo", "auto-sweep"])
def test_compensation_follows_the_plan_five_times_better(waypoints, method):
    traj = plan(ARM3R, waypoints, method=method, beta=0.5, duration="auto")
    off = run(traj, False)
    on = run(traj, True)
    rms_off, rms_on = np.array(off.tracking_error_rms_rad), np.array(on.tracking_error_rms_rad)
    # The uncompensated servo really lags (the physics model), else the ratio means nothing.
    assert math.degrees(max(off.tracking_error_max_rad)) > 2.0
    assert (rms_on <= rms_off / 5).all(), (np.degrees(rms_on), np.degrees(rms_off))
    assert np.degrees(on.tracking_error_max_rad).max() <= 0.5, \
        np.degrees(on.tracking_error_max_rad)


def test_compensated_goals_lead_the_plan_and_stay_inside_the_limits():
    from robodcn.stream.compensation import compensated_ticks

    traj = plan(ARM3R, DEMO, method="kenlerp", beta=0.5, duration="auto")
    limits = np.array([[s.min_tick, s.max_tick] for s in ARM3R.servos])
    goals = compensated_ticks(traj.joints, 1 / traj.rate_hz, ARM3R.servos, limits, arm=ARM3R)
    lead = (goals - traj.ticks) * np.sign(np.gradient(traj.ticks, axis=0))
    moving = np.abs(np.gradient(traj.ticks.astype(float), axis=0)) > 5
    assert (lead[moving] > 0).all()                      # ahead of the plan while moving
    assert ((goals >= limits[:, 0]) & (goals <= limits[:, 1])).all()


@pytest.mark.serial
def test_cli_sim_switches_physics_and_compensation(capsys):
    """Real time (the CLI streams on the wall clock against the physics sim): run alone in
    the serial pass. Beside other tests, late-skipped samples left the compensated arm 2
    ticks off and a 260 ms stall tripped the Bus Watchdog."""
    import json

    from robodcn import cli

    move = ["sim", "--arm", str(ARM3R.source), "--from", "0.25,0.10,0", "--to",
            "0.12,0.24,60", "--timing", "fast", "--json"]
    def sim(*extra):
        code = cli.main([*move, *extra])
        report = json.loads(capsys.readouterr().out)
        # 5: completed with samples skipped — the in-process simulator shares the CPU with
        # the streamer, and on a loaded machine (two CPU hogs on two cores reproduce it) a
        # few slots pass; the report says so and the exit code follows it.
        assert report["stop_reason"] == "completed", report["message"]
        assert code == {"done": 0, "degraded": 5}[report["outcome"]], report["headline"]
        return report

    kinematic = sim("--dynamics", "off")                       # compensation off with it
    assert kinematic["compensation"] is False
    assert max(kinematic["tracking_error_max_ticks"]) == 0     # each goal reached at once
    physics = sim("--compensation", "off")
    assert physics["compensation"] is False
    assert max(physics["tracking_error_max_ticks"]) > 10       # the motor lags
    assert physics["current_peak_a"][0] > 0
    # P-only control against Coulomb friction rests short of the goal (a dead band of
    # several ticks); the compensated goals bring it to within one encoder count.
    assert max(abs(e) for e in physics["final_error_ticks"]) > 1
    compensated = sim()
    assert compensated["compensation"] is True
    assert max(abs(e) for e in compensated["final_error_ticks"]) <= 1


def test_limit_steps_without_a_step_limit_keeps_the_goals():
    """An unlimited joint (no arm: step ∞) keeps its goals; 0·∞ made the first NaN."""
    from robodcn.stream.compensation import limit_steps

    goals = np.array([[100.0, 10.0], [140.0, 12.0], [150.0, 40.0]])
    out = limit_steps(goals, [np.inf, np.inf], start=[90.0, 0.0])
    assert np.array_equal(out, goals)
    mixed = limit_steps(goals, [np.inf, 5.0], start=[90.0, 0.0])
    assert np.array_equal(mixed[:, 0], goals[:, 0]) and np.isfinite(mixed).all()
    assert np.abs(np.diff(np.concatenate([[0.0], mixed[:, 1]]))).max() <= 5.0 + 1e-12
