"""Always a way back (issue 26 §4): after a fall the omx's elbow rests on its end stop at
83.2°, 3° past its 80.2° limit, and every move was refused ("start_joints[2] … is outside
joint 'elbow''s limits"), even ``torque off --yes``. Now ``move``, ``POST /v1/moves`` and the
release's lowering first bring the arm back with a slow joint-space recovery — each joint
that is out moving only toward its range, at 20 % of its limits, announced in one line —
then carry on. On firmware_sim's physics omx, dropped by switching its torque off (the arm
falls onto its end stops), with the goals on the wire and the measured positions checked;
and the recovery itself against the planner (monotone, within the share of the limits, the
move planned first)."""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from conftest import settled
from http_helpers import LOADED_MACHINE, call, poll_move, running
from omx_helpers import OMX, joints_of
from workflow_helpers import COMPLETED, run_cli

from firmware_sim import control_table as fct
from firmware_sim.bus import SimBus
from robodcn import servo_units
from robodcn.errors import UnreachableError
from robodcn.planner import plan
from robodcn.planner.recovery import (
    RECOVERY_MARGIN,
    RECOVERY_SHARE,
    start_problems,
    with_recovery,
)
from robodcn.workflow.poses import tool_pose

pytest_plugins = ["omx_helpers"]     # fixtures: held_omx

ELBOW = 2
ELBOW_ID = OMX.servo_ids[ELBOW]
LIMIT = OMX.joints[ELBOW].max_angle
GOAL_ARG = "0.18,0.065,0.15,-20"
GOAL = [0.18, 0.065, 0.15, math.radians(-20)]
#: The recovery's speed limit on the elbow, ticks/s: the share of its velocity limit.
SHARE_TICKS_S = RECOVERY_SHARE * OMX.joints[ELBOW].max_velocity / (2 * math.pi / 4096)


def fall(sim: SimBus) -> np.ndarray:
    """Switch the arm's torque off as a power cut would and let it fall; the joints (rad)
    where it comes to rest (the elbow on its end stop past its limit)."""
    with sim.lock:
        for servo_id in OMX.servo_ids:
            assert sim.servo(servo_id).write(fct.TORQUE_ENABLE, bytes([0])) == 0
    settled(lambda: [sim.servo(i).present_position for i in OMX.servo_ids], timeout=10.0)
    q = joints_of(sim)
    assert q[ELBOW] > LIMIT + math.radians(2.5), np.degrees(q)
    return q


#: The elbow's tick 1° inside its limit: where the recovery takes it.
TARGET_TICK = int(servo_units.radians_to_ticks(
    np.array([[0.0, 0.0, LIMIT - RECOVERY_MARGIN, 0.0]]), OMX.servos)[0, ELBOW])


def recovery_goals(sim: SimBus, before: int) -> list[tuple[float, int]]:
    """The elbow's goals on the wire since ``before`` goals up to the recovery's end: the
    first that reaches :data:`TARGET_TICK` (the move follows); (time accepted, s; goal)."""
    goals = sim.timed_goal_history(ELBOW_ID)[before:]
    end = next(i for i, (_, g) in enumerate(goals) if g <= TARGET_TICK)
    return goals[:end + 1]


def wire_speed(goals: list[tuple[float, int]], window: float = 0.05) -> float:
    """The fastest the goals moved over any stretch of at least ``window`` s, ticks/s (a
    stretch, not one step: a sample the stream skipped on the loaded test machine makes
    the next step longer, not the motion faster)."""
    t = np.array([g[0] for g in goals])
    g = np.array([g[1] for g in goals], dtype=float)
    fastest = 0.0
    for i in range(len(t)):
        j = np.searchsorted(t, t[i] + window)
        if j < len(t):
            fastest = max(fastest, abs(g[j] - g[i]) / (t[j] - t[i]))
    return fastest


def check_recovery_line(err: str, start: float) -> None:
    """The announced line: the elbow, from where to where (degrees), how fast (deg/s)."""
    line = next(x for x in err.splitlines() if "recovery: " in x)
    match = re.search(r"elbow (\d+\.\d)° → (\d+\.\d)° \((\d+\.\d+)° back into its range\) at "
                      r"up to (\d+\.\d)°/s", line)
    assert match, line
    frm, to, by, speed = (float(v) for v in match.groups())
    assert frm == pytest.approx(math.degrees(start), abs=0.06)
    assert to == pytest.approx(math.degrees(LIMIT - RECOVERY_MARGIN), abs=0.06)
    assert by == pytest.approx(frm - to, abs=0.02)
    assert 0 < speed <= math.degrees(RECOVERY_SHARE * OMX.joints[ELBOW].max_velocity) + 0.05
    assert "shoulder" not in line and "wrist" not in line


# -- the recovery, planned ----------------------------------------------------------------------

def _fallen() -> np.ndarray:
    return np.array([0.0, math.radians(-60.1), math.radians(83.2), math.radians(40.1)])


def test_only_the_joint_outside_its_limits_is_a_problem():
    q = _fallen()
    problems = start_problems(OMX, q)
    assert [(p.kind, p.joint, p.index) for p in problems] == [("joint_limit", "elbow", 2)]
    assert problems[0].limit == LIMIT
    assert problems[0].target == pytest.approx(LIMIT - RECOVERY_MARGIN)
    assert start_problems(OMX, np.array([0.0, -1.05, 0.35, 0.70])) == ()
    below = q.copy()
    below[1] = OMX.joints[1].min_angle - 0.02
    assert {p.joint: p.target for p in start_problems(OMX, below)}["shoulder"] == \
        pytest.approx(OMX.joints[1].min_angle + RECOVERY_MARGIN)


def test_the_recovery_moves_the_out_joint_toward_its_range_within_the_share():
    q = _fallen()
    traj, recovery = with_recovery(OMX, q, lambda start: plan(
        OMX, [tool_pose(OMX, np.asarray(start)), GOAL], start_joints=start))
    assert recovery is not None and [r.joint for r in recovery.joints] == ["elbow"]
    n = recovery.samples
    part = traj.joints[:n + 1]
    assert np.array_equal(traj.joints[0], q)                      # from where the arm is
    assert np.all(part[:-1, [0, 1, 3]] == q[[0, 1, 3]])           # the others stay
    assert np.allclose(part[-1], traj.request.start_joints, atol=1e-6)   # the move's start
    elbow = part[:, ELBOW]
    assert np.all(np.diff(elbow) <= 1e-9)                         # toward its range only
    assert elbow[-1] == pytest.approx(LIMIT - RECOVERY_MARGIN, abs=1e-6)
    v = np.abs(np.diff(elbow)) * traj.rate_hz
    a = np.abs(np.diff(elbow, 2)) * traj.rate_hz ** 2
    joint = OMX.joints[ELBOW]
    assert v.max() <= RECOVERY_SHARE * joint.max_velocity * 1.001
    assert a.max() <= RECOVERY_SHARE * joint.max_acceleration * 1.001
    assert recovery.joints[0].speed == pytest.approx(v.max(), rel=0.05)
    # then the move, planned from the recovered joints, ends at the goal
    assert traj.request.start_joints[ELBOW] == pytest.approx(LIMIT - RECOVERY_MARGIN)
    assert np.allclose(traj.poses[-1], GOAL, atol=1e-6)
    assert np.array_equal(traj.ticks[:n], servo_units.radians_to_ticks(part[:-1], OMX.servos))


def test_a_move_that_cannot_be_planned_from_the_recovered_pose_is_refused_first():
    calls = []

    def unreachable(start):
        calls.append(start)
        raise UnreachableError("out of reach", field="waypoints[1]")

    with pytest.raises(UnreachableError):
        with_recovery(OMX, _fallen(), unreachable)
    assert len(calls) == 1 and calls[0][ELBOW] == pytest.approx(LIMIT - RECOVERY_MARGIN)


def test_a_recovery_that_would_push_the_arm_deeper_into_the_table_is_refused():
    """The shoulder pushed by hand to 152° (only a simulator without a table allows it):
    the tool 266 mm below the mounting plate. Swinging the shoulder back into its range
    would take the tool deeper first: refused naming the floor zone, before anything
    moves (a point inside a keep-out zone may only leave it)."""
    from robodcn.errors import KeepOutError

    q = servo_units.ticks_to_radians(np.array([2048, 3782, 1674, 2048]), OMX.servos)
    with pytest.raises(KeepOutError) as info:
        with_recovery(OMX, q, lambda start: plan(
            OMX, [tool_pose(OMX, np.asarray(start)), GOAL], start_joints=start))
    assert info.value.field == "start_joints" and "floor" in info.value.message


# -- the command line, on the wire -------------------------------------------------------------

def test_move_after_a_fall_recovers_the_elbow_then_moves(held_omx, monkeypatch, capsys):
    q = fall(held_omx)
    before = len(held_omx.goal_history(ELBOW_ID))
    start_tick = held_omx.servo(ELBOW_ID).present_position
    code = run_cli(monkeypatch, ["move", "--arm", "omx", "--device", held_omx.port_path,
                                 "--to", GOAL_ARG, "--compensation", "off"])
    err = capsys.readouterr().err
    assert code in COMPLETED, err
    check_recovery_line(err, q[ELBOW])
    timed = recovery_goals(held_omx, before)
    goals = [g for _, g in timed]
    # from the present to 1° inside (a sample skipped on a loaded machine may step past the
    # recovery's last goal into the move's first ones)
    assert goals[0] <= start_tick and goals[-1] <= TARGET_TICK < goals[-2]
    assert np.all(np.diff(goals) <= 0)                      # toward its range only
    # 20 % of the velocity limit (a tick of rounding over the 50 ms window)
    assert wire_speed(timed) <= SHARE_TICKS_S * 1.05 + 20
    # the move carried on: the tool at the goal (within the sag of a P loop without the
    # gravity lead: compensation is off to put the plan itself on the wire), every joint
    # inside its limits
    q_end = joints_of(held_omx)
    assert np.allclose(tool_pose(OMX, q_end)[:3], GOAL[:3], atol=0.012)
    assert all(j.min_angle <= v <= j.max_angle for j, v in zip(OMX.joints, q_end,
                                                                strict=True))


def test_torque_off_after_a_fall_recovers_lowers_and_releases(held_omx, monkeypatch, capsys):
    q = fall(held_omx)
    with held_omx.lock:
        for servo_id in OMX.servo_ids:            # as the next session finds it: held
            assert held_omx.servo(servo_id).write(fct.TORQUE_ENABLE, bytes([1])) == 0
    before = len(held_omx.goal_history(ELBOW_ID))
    start_tick = held_omx.servo(ELBOW_ID).present_position
    code = run_cli(monkeypatch, ["torque", "off", "--arm", "omx", "--device",
                                 held_omx.port_path, "--yes"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    check_recovery_line(captured.err, q[ELBOW])
    assert "after lowering it to its rest pose" in captured.out
    goals = [g for _, g in recovery_goals(held_omx, before)]
    # the goals are led by the position loop's lag and the gravity load (compensation on,
    # the lead steps in with the first sample): toward the range only
    assert goals[0] <= start_tick and len(goals) > 1
    assert np.all(np.diff(goals) <= 0)
    assert not any(held_omx.servo(i).torque_enabled for i in OMX.servo_ids)


def test_torque_off_where_no_lowering_can_be_planned_asks_to_hold_and_releases(
        monkeypatch, capsys):
    """The tool pointing back over the base: no path to the rest pose; --yes still
    releases, after asking the user to hold the arm."""
    from robodcn.simulated import simulated_arm

    behind = [0.0, -1.2, -1.2, 0.5]
    with simulated_arm(OMX, timing="fast", start_joints=behind) as sa:
        sa.bus.close()
        code = run_cli(monkeypatch, ["torque", "off", "--arm", "omx", "--device",
                                     sa.sim.port_path, "--yes"])
        captured = capsys.readouterr()
        assert code == 0, captured.err
        assert "cannot be lowered first" in captured.err and "hold it" in captured.err
        assert "torque off: servo(s) 11, 12, 13, 14" in captured.out
        assert not any(sa.sim.servo(i).torque_enabled for i in OMX.servo_ids)


def test_a_refused_move_names_from_only_when_it_was_typed(monkeypatch, capsys):
    """The tool back over the base, joints inside their limits: ``move --to home`` is
    refused naming the present pose, not a --from the user never typed."""
    from robodcn.simulated import simulated_arm

    with simulated_arm(OMX, timing="fast", start_joints=[0.0, -1.2, -1.2, 0.5],
                       dynamics=False) as sa:
        sa.bus.close()
        home = ",".join(f"{v:g}" for v in (*OMX.home[:3], 0.0))
        assert run_cli(monkeypatch, ["move", "--arm", "omx", "--device", sa.sim.port_path,
                                     "--to", home]) == 3
        err = capsys.readouterr().err
        assert "--from" not in err and "the present pose" in err
        assert run_cli(monkeypatch, ["move", "--arm", "omx", "--device", sa.sim.port_path,
                                     "--from", "-0.2426,0,0.3484,108.8", "--to", home]) in (2, 3)
        assert "--from" in capsys.readouterr().err


# -- HTTP ----------------------------------------------------------------------------------------

@pytest.fixture
def fallen_server() -> Iterator[tuple[Any, SimBus, np.ndarray]]:
    """A service on the physics omx whose arm has fallen (torque off, at rest): (server,
    the simulator, the joints where it lies)."""
    from robodcn.controller import ArmController
    from robodcn.http import make_server
    from robodcn.simulated import simulated_arm

    with simulated_arm(OMX, timing="fast") as sa:
        q = fall(sa.sim)
        sa.bus.configure()                      # the service starts: torque on, holding
        controller = ArmController(OMX, sa.bus, execute_options=LOADED_MACHINE)
        try:
            with running(make_server(OMX, controller, request_timeout=10.0)) as server:
                yield server, sa.sim, q
        finally:
            controller.close()
    assert not sa.sim.errors, sa.sim.errors


def test_an_http_move_after_a_fall_recovers_then_moves(fallen_server, caplog):
    server, sim, q = fallen_server
    caplog.set_level("WARNING", logger="robodcn.admission")
    status, _, reply = call(server, "POST", "/v1/moves", {"waypoints": [GOAL]})
    assert status == 202, reply
    recovery = reply["recovery"]
    assert [r["joint"] for r in recovery["joints"]] == ["elbow"]
    elbow = recovery["joints"][0]
    assert elbow["start"] == pytest.approx(q[ELBOW], abs=1e-3)
    assert elbow["target"] == pytest.approx(LIMIT - RECOVERY_MARGIN)
    assert elbow["speed"] <= RECOVERY_SHARE * OMX.joints[ELBOW].max_velocity
    assert any("recovery: elbow" in r.getMessage() for r in caplog.records)
    done = poll_move(server, reply["id"], lambda b: b["status"] not in ("queued", "running"),
                     timeout=30)
    assert done["status"] in ("done", "degraded"), done
    # measured: while the elbow was still past its limit it only came down, at no more
    # than the recovery's speed (reads 10 ms apart; two ticks of read noise)
    status, _, record = call(server, "GET", f"/v1/moves/{reply['id']}/record")
    assert status == 200
    t = np.array(record["t"])
    e = np.array(record["joints"])[:, ELBOW]
    out = t <= recovery["duration_s"]
    tick = 2 * math.pi / 4096
    assert np.all(np.diff(e[out]) <= 2 * tick)
    assert e[out].max() <= q[ELBOW] + 2 * tick
    window = t[out][-1] - t[out][0]
    assert (e[out][0] - e[out][-1]) / window <= \
        RECOVERY_SHARE * OMX.joints[ELBOW].max_velocity * 1.2
    assert np.allclose(tool_pose(OMX, joints_of(sim))[:3], GOAL[:3], atol=0.005)


def test_run_of_a_saved_trajectory_after_a_fall_recovers_then_approaches(
        held_omx, monkeypatch, capsys, tmp_path):
    """``run`` of a saved Trajectory: its joint-space approach was refused from the fallen
    pose; now the recovery comes first, then the approach to its first sample, then it."""
    saved = tmp_path / "goal.json"
    assert run_cli(monkeypatch, ["plan", "--arm", "omx", "--to", GOAL_ARG, "--format", "json",
                                 "--out", str(saved), "--quiet"]) == 0
    capsys.readouterr()
    q = fall(held_omx)
    before = len(held_omx.goal_history(ELBOW_ID))
    code = run_cli(monkeypatch, ["run", str(saved), "--arm", "omx", "--device",
                                 held_omx.port_path, "--compensation", "off"])
    err = capsys.readouterr().err
    assert code in COMPLETED, err
    check_recovery_line(err, q[ELBOW])
    goals = [g for _, g in recovery_goals(held_omx, before)]
    assert goals[-1] <= TARGET_TICK < goals[-2] and np.all(np.diff(goals) <= 0)
    assert np.allclose(tool_pose(OMX, joints_of(held_omx))[:3], GOAL[:3], atol=0.012)


def test_an_http_joint_trajectory_after_a_fall_recovers_then_approaches(fallen_server):
    """A JointTrajectory body (the ROS shape) from the fallen pose: its approach was refused
    ("start_joints[2] … outside joint 'elbow''s limits"); now recovery, approach, then it."""
    server, sim, q = fallen_server
    first = [0.0, -0.6, 0.4, 0.4]
    last = [0.3, -0.3, 0.2, 0.3]
    body = {"trajectory": {"joint_names": list(OMX.joint_names), "points": [
        {"positions": first, "time_from_start": {"sec": 0}},
        {"positions": last, "time_from_start": {"sec": 2}}]}}
    status, _, reply = call(server, "POST", "/v1/moves", body)
    assert status == 202, reply
    assert [r["joint"] for r in reply["recovery"]["joints"]] == ["elbow"]
    done = poll_move(server, reply["id"], lambda b: b["status"] not in ("queued", "running"),
                     timeout=30)
    assert done["status"] in ("done", "degraded"), done["report"]["headline"]
    status, _, traj = call(server, "GET", f"/v1/moves/{reply['id']}/trajectory")
    n = reply["recovery"]["samples"]
    assert np.allclose(traj["joints"][0], q, atol=1e-9)                # from the fallen pose
    assert traj["joints"][n][ELBOW] == pytest.approx(LIMIT - RECOVERY_MARGIN, abs=1e-6)
    assert np.allclose(traj["joints"][-1], last, atol=1e-6)
    # where it ended is the in-position check's (degraded when off); near the end here
    assert np.allclose(joints_of(sim), last, atol=math.radians(2.0))
