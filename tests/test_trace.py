"""ExecutionReport.trace: every feedback read recorded (issue 11 §5) — time, ticks, tracking
error and current per joint, in the joint's sign, consistent with the report's figures."""

from __future__ import annotations

import json
import math

import numpy as np
from conftest import ARM3R, lockstep_arm

from robodcn.planner import plan
from robodcn.stream import ExecutionTrace, execute
from robodcn.stream.trace import TraceRecorder

MOVE = [(0.25, 0.10, 0.0), (0.12, 0.24, math.radians(60)), (-0.10, 0.22, math.radians(120))]


def _run(**kwargs):
    """The move on the physics sim, on virtual time (conftest.lockstep_arm): the lag and
    the currents the trace records are the physics' answer to the schedule, not to how
    late a loaded host sent it (late samples skipped made the wrist's lag a jump)."""
    traj = plan(ARM3R, MOVE, method="kenlerp", beta=0.5, duration="auto")
    with lockstep_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as (sa, clock):
        report = execute(traj, sa.bus, tracking_limit=None, clock=clock, **kwargs)
    assert report.stop_reason == "completed", report.message
    assert report.samples_sent == len(traj.t) and report.lateness_max_s == 0.0
    return traj, report


def test_the_trace_holds_every_read_and_agrees_with_the_report():
    traj, report = _run(compensation=False)
    trace = report.trace
    assert isinstance(trace, ExecutionTrace)
    n, k = len(trace), len(ARM3R.joints)
    assert n == report.feedback_reads and n <= len(traj.t)
    assert trace.ticks.shape == trace.tracking_error_rad.shape == trace.current_a.shape == (n, k)
    assert np.all(np.diff(trace.sample) > 0) and np.all(np.diff(trace.t) > 0)
    assert trace.sample[-1] == len(traj.t) - 1           # the last sample always reads
    # Read after its sample's write: never before that sample's due time (plan clock).
    assert np.all(trace.t >= traj.t[trace.sample] - 1e-9)
    assert np.allclose(np.abs(trace.tracking_error_rad).max(axis=0),
                       report.tracking_error_max_rad)
    assert np.allclose(np.abs(trace.current_a).max(axis=0), report.current_peak_a)
    assert trace.joint_names == report.joint_names
    assert trace.current_limit_a == report.current_limit_a
    assert trace.collision_threshold_a == report.collision_threshold_a
    assert trace.predicted_current_a.shape == (len(traj.t), k)


def test_the_trace_is_in_the_joints_sign():
    """The wrist's servo is mounted reversed (direction -1): in joint sign an uncompensated
    servo lags behind the plan's velocity on every joint, and its current follows the
    plan's predicted current."""
    traj, report = _run(compensation=False)
    trace = report.trace
    vel = np.gradient(traj.joints, axis=0)[trace.sample]
    predicted = trace.predicted_current_a[trace.sample]
    for j in range(len(ARM3R.joints)):
        assert np.corrcoef(trace.tracking_error_rad[:, j], vel[:, j])[0, 1] < -0.5, j
        # Present Current is noisy next to the model (r ≈ 0.3–0.6 here); the wrong sign
        # would make it negative.
        assert np.corrcoef(trace.current_a[:, j], predicted[:, j])[0, 1] > 0.1, j
    assert ARM3R.servos[2].direction == -1


def test_to_dict_leaves_the_trace_out_unless_asked():
    _, report = _run()
    assert "trace" not in report.to_dict()
    data = json.loads(json.dumps(report.to_dict(trace=True)))["trace"]
    assert len(data["t"]) == len(report.trace) == len(data["current_a"])
    assert data["joint_names"] == list(report.joint_names)


def test_the_recorder_is_preallocated_and_grows_only_past_its_samples():
    rec = TraceRecorder(2, [1, -1], np.array([0.5, 0.25]))
    buffers = rec.t, rec.ticks
    rec.record(0, 0.0, np.array([10, 20]), np.array([1.0, 2.0]), None)
    rec.record(1, 0.01, np.array([11, 21]), np.array([-1.0, 4.0]), np.array([0.1, 0.2]))
    assert (rec.t, rec.ticks) == buffers                 # no reallocation within n
    rec.record(5, 0.05, np.array([12, 22]), np.array([0.0, 0.0]), None)
    trace = rec.trace(("a", "b"))
    assert trace.sample.tolist() == [0, 1, 5] and trace.ticks[:, 1].tolist() == [20, 21, 22]
    assert np.allclose(trace.tracking_error_rad, [[0.5, -0.5], [-0.5, -1.0], [0.0, 0.0]])
    assert np.allclose(trace.current_a[1], [0.1, -0.2])
    assert np.isnan(trace.current_a[[0, 2]]).all()
    assert rec.trace(("a", "b")).current_a is not None
    assert TraceRecorder(3, [1], np.ones(1)).trace(("a",)).current_a is None
