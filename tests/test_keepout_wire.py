"""Keep-out zones as the user meets them (issue 26 §3), on firmware_sim through the real
dynamixel-sdk: the issue's reproductions on the command line (``sim``, ``move``) exit 3
naming the zone and the depth with no goal sent to any servo; over HTTP a plan, a move and
a replacement into a zone are 422 ``keep_out`` and ``GET /v1/arm`` lists the zones; a jog
key that would go through the table is refused; ``teach`` does not record a pose inside a
zone."""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import shutil
import subprocess
import sys
import time
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import ARM3R, CONFIGS, open_bus, settled
from http_helpers import call, error_of, poll_move, serving_arm, start_move
from omx_helpers import OMX
from workflow_helpers import backdrive, run_cli

import robodcn.web
from firmware_sim.bus import SimBus
from robodcn import kinematics, servo_units, simulated
from robodcn.cli.jog_cmd import Jogger
from robodcn.errors import KeepOutError
from robodcn.workflow.teach import Teaching

pytest_plugins = ["omx_helpers", "workflow_fixtures"]     # fixtures: held_omx, sim

DEG = math.pi / 180.0
BELOW_PLATE = "0.2,0,-0.1,-90"          # the issue's: 10 cm below the mounting plate
IN_BASE = "0.03,0,0.03,-90"             # 3 cm from the yaw axis, inside the base servo


def goals_and_positions(sim: SimBus, ids) -> dict[int, tuple[int, int]]:
    """Per servo (goals accepted so far, present position)."""
    return {i: (len(sim.goal_history(i)), sim.servo(i).present_position) for i in ids}


def unmoved(before: dict, after: dict) -> bool:
    """No goal accepted in between, every servo within 3 ticks of where it was (a held
    joint droops a tick or two under gravity)."""
    return all(after[i][0] == before[i][0] and abs(after[i][1] - before[i][1]) <= 3
               for i in before)


@contextlib.contextmanager
def watched_sims(monkeypatch) -> Iterator[list[tuple[dict, dict]]]:
    """``robodcn.simulated.simulated_arm`` (what ``robodcn sim`` runs) wrapped so the test
    sees each simulator's servos when the command opened it and when it closed it."""
    seen: list[tuple[dict, dict]] = []
    real = simulated.simulated_arm

    @contextlib.contextmanager
    def watched(arm, **kw):
        with real(arm, **kw) as sa:
            before = goals_and_positions(sa.sim, arm.servo_ids)
            try:
                yield sa
            finally:
                seen.append((before, goals_and_positions(sa.sim, arm.servo_ids)))

    monkeypatch.setattr(simulated, "simulated_arm", watched)
    yield seen


# -- the command line -----------------------------------------------------------------------------

@pytest.mark.parametrize("target, zone, depth", [(BELOW_PLATE, "'floor'", "100.0 mm"),
                                                 (IN_BASE, "'base'", "8.0 mm")])
def test_sim_refuses_the_issues_targets_and_no_servo_moves(monkeypatch, capsys, target, zone,
                                                           depth) -> None:
    with watched_sims(monkeypatch) as seen:
        code = run_cli(monkeypatch, ["sim", "--arm", "omx", "--to", target, "--timing",
                                     "fast"])
    err = capsys.readouterr().err
    assert code == 3, err
    assert f"{depth} inside the arm's keep-out zone {zone}" in err and "(--to)" in err
    assert len(seen) == 1 and unmoved(*seen[0])


def test_move_on_the_wire_refuses_and_sends_no_goal(held_omx, monkeypatch, capsys) -> None:
    before = goals_and_positions(held_omx, OMX.servo_ids)
    code = run_cli(monkeypatch, ["move", "--arm", "omx", "--device", held_omx.port_path,
                                 "--to", BELOW_PLATE])
    err = capsys.readouterr().err
    assert code == 3 and "keep-out zone 'floor'" in err, err
    assert unmoved(before, goals_and_positions(held_omx, OMX.servo_ids))
    assert all(held_omx.servo(i).torque_enabled for i in OMX.servo_ids)    # still held


# -- HTTP -----------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def omx_server() -> Iterator[tuple[Any, Any]]:
    with serving_arm(OMX, request_timeout=10.0) as pair:
        yield pair


def test_http_lists_the_zones_and_answers_422_for_a_plan_into_one(omx_server) -> None:
    server, sa = omx_server
    status, _, arm = call(server, "GET", "/v1/arm")
    assert status == 200
    floor, base = arm["keep_out"]
    assert floor == {"name": "floor", "kind": "floor", "axis": "z", "height": 0.0}
    assert base["kind"] == "cylinder" and base["radius"] == OMX.workspace.base_radius
    assert base["top"] == OMX.shoulder_height
    assert arm["config"]["workspace"]["floor_z"] == 0.0
    below = [0.2, 0.0, -0.1, -math.pi / 2]
    status, _, body = call(server, "POST", "/v1/trajectories",
                           {"waypoints": [list(OMX.home), below]})
    error = error_of(body)
    assert status == 422 and error["code"] == "keep_out" and error["field"] == "waypoints[1]"
    assert error["keepout"]["zone"] == "floor" and error["keepout"]["point"] == "tool"
    assert error["keepout"]["depth_m"] == pytest.approx(0.1)
    before = goals_and_positions(sa.sim, OMX.servo_ids)
    status, _, body = call(server, "POST", "/v1/moves", {"waypoints": [below]})
    assert status == 422 and error_of(body)["code"] == "keep_out"
    assert unmoved(before, goals_and_positions(sa.sim, OMX.servo_ids))


def test_http_a_joint_under_the_plate_refuses_a_path_naming_sample_and_point(omx_server) -> None:
    server, _ = omx_server
    # the wrist 1.7 cm under the plate while the tool rests 5 mm above it
    status, _, body = call(server, "POST", "/v1/trajectories",
                           {"waypoints": [list(OMX.home), [0.27, 0.0, 0.005, 10 * DEG]]})
    error = error_of(body)
    assert status == 422 and error["code"] == "keep_out"
    v = error["violation"]
    assert v["quantity"] == "keepout" and v["zone"] == "floor" and v["point"] == "wrist"
    assert v["value"] > 0 and v["position"][2] == pytest.approx(-v["value"])
    assert isinstance(error["sample"], int) and error["sample"] == v["sample"]


def test_http_a_replacement_into_a_zone_is_refused_and_the_move_goes_on(omx_server) -> None:
    server, sa = omx_server
    goal = [0.16, 0.06, 0.20, -0.2]
    move = start_move(server, {"waypoints": [goal], "duration": 3.0}, 0.2)
    status, _, body = call(server, "POST", "/v1/moves",
                           {"waypoints": [[0.2, 0.0, -0.1, -math.pi / 2]], "replace": True})
    assert status == 422 and error_of(body)["code"] == "keep_out", body
    done = poll_move(server, move["id"], lambda m: m["status"] not in ("queued", "running"))
    assert done["status"] in ("done", "degraded"), done
    ticks = settled(lambda: [sa.sim.servo(i).present_position for i in OMX.servo_ids])
    q = servo_units.ticks_to_radians(np.array([ticks]), OMX.servos)
    assert np.allclose(kinematics.fk_yawed(OMX.chain, q)[0, :3], goal[:3], atol=4e-3)


def test_http_a_joint_trajectory_through_the_plate_is_refused_before_moving(omx_server
                                                                           ) -> None:
    """A ROS-style JointTrajectory (what the ROS 2 node's FollowJointTrajectory sends as
    the move body) from the present joints down through the plate: 422 keep_out naming
    its point, nothing moves."""
    server, sa = omx_server
    _, _, state = call(server, "GET", "/v1/state")
    below = kinematics.ik_yawed(OMX.chain, np.array([[0.2, 0.0, -0.1, -math.pi / 2]]),
                                OMX.elbow)[0]
    trajectory = {"joint_names": list(OMX.joint_names), "points": [
        {"positions": list(state["joints"]), "time_from_start": {"sec": 0, "nanosec": 0}},
        {"positions": below.tolist(), "time_from_start": {"sec": 4, "nanosec": 0}}]}
    before = goals_and_positions(sa.sim, OMX.servo_ids)
    status, _, body = call(server, "POST", "/v1/moves", {"trajectory": trajectory})
    error = error_of(body)
    assert status == 422 and error["code"] == "keep_out", error
    assert error["field"].startswith("trajectory.points[") and "'floor'" in error["message"]
    assert error["keepout"]["zone"] == "floor" and error["keepout"]["depth_m"] > 0
    assert unmoved(before, goals_and_positions(sa.sim, OMX.servo_ids))


def test_http_a_follow_target_under_the_plate_is_422_and_the_session_goes_on(omx_server
                                                                            ) -> None:
    server, _ = omx_server
    status, _, move = call(server, "POST", "/v1/follow", {"space": "pose"})
    assert status == 201, move
    try:
        status, _, body = call(server, "PUT", "/v1/follow/target",
                               {"pose": [0.2, 0.0, -0.1, -math.pi / 2]})
        error = error_of(body)
        assert status == 422 and error["code"] == "keep_out" and error["field"] == "pose"
        assert error["keepout"]["zone"] == "floor"
        near = [OMX.home[0] + 0.01, OMX.home[1], OMX.home[2] - 0.01, OMX.home[3]]
        status, _, answer = call(server, "PUT", "/v1/follow/target", {"pose": near})
        assert status == 200 and answer == {"seq": 1}, answer
    finally:
        call(server, "DELETE", "/v1/follow")
    done = poll_move(server, move["id"], lambda m: m["status"] != "following")
    assert done["report"]["stop_reason"] == "completed", done["report"]


# -- jog and teach --------------------------------------------------------------------------------

def test_a_jog_key_through_the_table_is_refused_and_the_arm_stays_above() -> None:
    with simulated.simulated_arm(OMX, timing="fast") as sa:
        out = io.StringIO()
        jog = Jogger(OMX, sa.bus, step=0.1, step_rad=5 * DEG, method="sclerp", rate_hz=100.0,
                     out=out)
        start = jog.target.copy()
        # out 10 cm, then down 10 cm three times: the third would put the tool 6 cm under;
        # each key once the move before it has ended (new moves from rest: a loaded machine
        # may miss an in-flight switch, which the jog tests of retargets cover), then q
        pending = ["right", "s", "s", "s"]

        def read_key(timeout: float) -> str | None:
            time.sleep(timeout)
            if jog.execution is not None and not jog.execution.done:
                return None
            return pending.pop(0) if pending else "q"

        jog.run(read_key)
        assert "refused: keep-out zone 'floor', the tool" in out.getvalue()
        want = start + np.array([0.1, 0.0, -0.2, 0.0])
        assert np.allclose(jog.target, want, atol=1e-9)          # the refused step undone
        end = kinematics.fk_yawed(OMX.chain, servo_units.ticks_to_radians(
            np.array([[sa.sim.servo(i).present_position for i in OMX.servo_ids]]),
            OMX.servos))[0]
        # where the last accepted key left it (within what a loaded machine's skipped
        # samples leave of a physics arm's tracking), well above the plate
        assert end[2] == pytest.approx(want[2], abs=1e-2) and end[2] > 0.025


def _arm3r_with_box(tmp_path, center) -> str:
    text = (CONFIGS / "arm3r.toml").read_text()
    lo = [c - 0.02 for c in center]
    hi = [c + 0.02 for c in center]
    text += f'\n[[workspace.keep_out]]\nname = "fixture"\nmin = {lo}\nmax = {hi}\n'
    path = tmp_path / "arm.toml"
    path.write_text(text)
    return str(path)


def test_teach_does_not_record_a_pose_inside_a_zone(sim, monkeypatch, capsys, tmp_path
                                                    ) -> None:
    inside, clear = (30.0, -60.0, 40.0), [(10.0, -60.0, 40.0), (70.0, -50.0, 0.0)]

    def ticks_of(q_deg):
        ticks = servo_units.radians_to_ticks(np.radians(q_deg), ARM3R.servos)
        return dict(zip(ARM3R.servo_ids, (int(t) for t in ticks), strict=True))

    def at(q_deg, line=""):
        def step():
            backdrive(sim, ticks_of(q_deg))
            return line
        return step

    tool = kinematics.fk(ARM3R.links, np.radians([inside]))[0]
    arm = _arm3r_with_box(tmp_path, tool[:2].tolist())
    out = tmp_path / "poses.toml"
    steps = [at(inside), at(clear[0]), at(clear[1]), "q"]
    code = run_cli(monkeypatch, ["teach", "--arm", arm, "--device", sim.port_path, "--out",
                                 str(out)], steps)
    err = capsys.readouterr().err
    assert code == 0, err
    assert "not recorded: the arm's tool point" in err and "keep-out zone 'fixture'" in err
    assert "mm inside" in err
    data = tomllib.loads(out.read_text())
    got = np.array([[w["x"], w["y"]] for w in data["waypoints"]])
    want = kinematics.fk(ARM3R.links, np.radians(clear))[:, :2]
    assert got.shape == (2, 2) and np.allclose(got, want, atol=2e-3)


def test_teaching_the_omx_refuses_a_pose_under_the_plate() -> None:
    # the issue's: a pose at z −0.09 m, backdriven on torque-off servos (kinematic sim)
    with SimBus((*OMX.servo_ids, OMX.gripper.servo.id), timing="fast", log=False) as sim:
        with open_bus(sim, OMX.servos) as bus:
            teaching = Teaching(bus, OMX)
            below = kinematics.ik_yawed(OMX.chain, np.array([[0.2, 0.0, -0.09, -90 * DEG]]),
                                        OMX.elbow)[0]
            ticks = servo_units.radians_to_ticks(below, OMX.servos)
            backdrive(sim, dict(zip(OMX.servo_ids, (int(t) for t in ticks), strict=True)))
            with pytest.raises(KeepOutError) as info:
                teaching.record()
            assert info.value.zone == "floor" and info.value.depth == pytest.approx(
                0.09, abs=2e-3)
            assert "keep-out zone 'floor'" in info.value.message and len(teaching) == 0
            home = kinematics.ik_yawed(OMX.chain, np.array([OMX.home]), OMX.elbow)[0]
            ticks = servo_units.radians_to_ticks(home, OMX.servos)
            backdrive(sim, dict(zip(OMX.servo_ids, (int(t) for t in ticks), strict=True)))
            pose = teaching.record()
            assert len(teaching) == 1 and np.allclose(pose[:3], OMX.home[:3], atol=2e-3)
        assert not sim.errors, sim.errors


# -- the console --------------------------------------------------------------------------------

STATIC = Path(robodcn.web.__file__).resolve().parent / "static"
NODE_SCRIPT = """
import { sideRects, boxSection } from %s;
let input = "";
process.stdin.on("data", (d) => { input += d; });
process.stdin.on("end", () => {
  const { arm, yaws } = JSON.parse(input);
  const model = { yawed: arm.pose_axes.length === 4, zones: arm.keep_out };
  process.stdout.write(JSON.stringify(yaws.map((y) => sideRects(model, y, 1.0))));
});
"""


@pytest.mark.skipif(shutil.which("node") is None, reason="needs node to run the page's module")
def test_the_console_paints_exactly_the_zones_over_the_reach_shading(omx_server, tmp_path
                                                                      ) -> None:
    """What zones.js paints over the side view's reach shading (the page's own module, run
    by node on GET /v1/arm's answer) covers a point of the arm's plane at a yaw exactly when
    the zone geometry of robodcn.config says it lies inside a zone (a 2 mm grid)."""
    server, _ = omx_server
    _, _, arm = call(server, "GET", "/v1/arm")
    ws = omx_with_box().workspace
    # the service's answer, with a box as GET /v1/arm lists one on an arm that has it
    assert ws.zone_list(planar=False)[:2] == arm["keep_out"]
    arm["keep_out"] = ws.zone_list(planar=False)
    script = tmp_path / "zones_probe.mjs"
    script.write_text(NODE_SCRIPT % json.dumps((STATIC / "zones.js").as_uri()))
    yaws = [0.0, math.radians(20), math.radians(90), math.pi]
    out = subprocess.run(["node", str(script)], input=json.dumps({"arm": arm, "yaws": yaws}),
                         capture_output=True, text=True, timeout=60, check=True)
    per_yaw = json.loads(out.stdout)
    u, v = np.meshgrid(np.arange(-0.3, 0.3, 0.002) + 0.001, np.arange(-0.2, 0.3, 0.002) + 0.001)
    for yaw, rects in zip(yaws, per_yaw, strict=True):
        painted = np.zeros(u.shape, dtype=bool)
        for u0, v0, u1, v1 in rects:
            painted |= (u > u0) & (u < u1) & (v > v0) & (v < v1)
        points = np.stack([u * math.cos(yaw), u * math.sin(yaw), v], axis=-1)
        inside = (ws.depths(points) > 0).any(axis=-1)
        assert np.array_equal(painted, inside), yaw
    # the box is cut by the plane at 0°, 20° and (behind the axis, r < 0) 180°, not at 90°
    assert [len(rects) for rects in per_yaw] == [3, 3, 2, 3]


def omx_with_box():
    from robodcn.config import arm_from_dict
    data = OMX.to_dict()
    data["workspace"]["keep_out"] = [{"name": "pillar", "min": [0.1, -0.05, 0.0],
                                      "max": [0.16, 0.05, 0.08]}]
    return arm_from_dict(data, source="pillar.toml")


def test_check_config_names_the_zones(monkeypatch, capsys) -> None:
    assert run_cli(monkeypatch, ["check-config", "omx"]) == 0
    out = capsys.readouterr().out
    assert ("keep-out: 'floor' (z < 0.000 m); 'base' (the cylinder r < 0.038 m about the yaw "
            "axis, up to z = 0.076 m)") in out
    assert run_cli(monkeypatch, ["check-config", "omx", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["keep_out"] == OMX.workspace.zone_list(False)
    assert run_cli(monkeypatch, ["check-config", "arm3r"]) == 0
    assert "keep-out" not in capsys.readouterr().out


def test_a_retarget_whose_samples_leave_for_a_zone_is_refused_and_the_move_goes_on(
        monkeypatch, tmp_path) -> None:
    """The samples a retarget sends after its switch (its moving start's blend may leave
    the planned path) are checked too: here they are turned 0.4 rad about the base, into a
    box the planned paths keep clear of; the retarget is refused, nothing changes, and the
    move ends where it was going."""
    from robodcn.config import load_arm
    from robodcn.planner import plan
    from robodcn.stream import start
    from robodcn.stream.online.retarget import Retargeting

    goal, other = (0.25, 0.10, 0.0), (0.2, 0.15, 0.3)
    turn = np.array([0.4, 0.0, 0.0])                 # rad about the base, joint 0
    q_other = kinematics.ik(ARM3R.links, np.array([other]), ARM3R.elbow)[0]
    turned = kinematics.fk(ARM3R.links, (q_other + turn)[None])[0]
    arm = load_arm(_arm3r_with_box(tmp_path, turned[:2].tolist()))
    real = Retargeting.tail

    def turned_tail(self, state, target, options):
        segments = real(self, state, target, options)
        joints, sigma, path = segments[-1]
        return [*segments[:-1], (joints + turn, sigma, path)]

    monkeypatch.setattr(Retargeting, "tail", turned_tail)
    with simulated.simulated_arm(arm, timing="fast", dynamics=False) as sa:
        q0 = servo_units.ticks_to_radians(sa.bus.read_positions()[None], arm.servos)[0]
        start_pose = kinematics.fk(arm.links, q0[None])[0]
        traj = plan(arm, [start_pose, goal], start_joints=q0, duration=2.0)
        ex = start(traj, sa.bus, arm=arm, compensation=False)
        while ex.sample < 40 and not ex.done:
            time.sleep(0.01)
        with pytest.raises(KeepOutError) as info:
            ex.retarget([None, other])
        assert info.value.zone == "fixture" and info.value.violation.quantity == "keepout"
        report = ex.wait(30)
        assert report is not None and report.outcome in ("done", "degraded")
        q = servo_units.ticks_to_radians(sa.bus.read_positions()[None], arm.servos)
        assert np.allclose(kinematics.fk(arm.links, q)[0, :2], goal[:2], atol=3e-3)


# -- a follow session (the online generator) ----------------------------------------------------

def test_a_follow_session_refuses_targets_into_a_zone_and_laws_through_one() -> None:
    """A follow session on the omx (firmware_sim, real SDK): a pose target under the plate
    and a joint target whose law from the commanded state swings the arm through the plate
    (both ends clear) are refused (KeepOutError, counted as refused; nothing sent toward
    them), a clear target is taken and reached."""
    from robodcn.stream import follow

    start = np.array([0.585, 0.971, 0.244, -1.383])      # leaning forward, low
    through = [-1.632, 0.81, -0.758, 1.673]             # clear, but the way there is not
    with simulated.simulated_arm(OMX, timing="fast", dynamics=False,
                                 start_joints=start) as sa:
        before = goals_and_positions(sa.sim, OMX.servo_ids)
        f = follow(sa.bus, OMX, space="joints", watchdog_ms=0)
        try:
            below = kinematics.ik_yawed(OMX.chain, np.array([[0.2, 0.0, -0.05, -90 * DEG]]),
                                        OMX.elbow)[0]
            with pytest.raises(KeepOutError) as info:
                f.target(joints=below.tolist())
            assert info.value.zone == "floor" and info.value.field == "joints"
            with pytest.raises(KeepOutError) as info:
                f.target(joints=through)
            v = info.value.violation
            assert v is not None and v.zone == "floor" and v.sample > 0
            assert f.refused == 2 and f.taken == 0
            time.sleep(0.2)
            held = goals_and_positions(sa.sim, OMX.servo_ids)
            assert all(abs(held[i][1] - before[i][1]) <= 2 for i in OMX.servo_ids)
            clear = (start + np.array([0.3, -0.2, 0.0, 0.0])).tolist()
            f.target(joints=clear)
            assert f.taken == 1
            f.end()
            report = f.wait(30)
        finally:
            if not f.done:
                f.stop("hold")
                f.wait(10)
        assert report is not None and report.outcome in ("done", "degraded"), report
        q = servo_units.ticks_to_radians(sa.bus.read_positions()[None], OMX.servos)[0]
        assert np.allclose(q, clear, atol=3e-3)


def test_robodcn_follow_refuses_a_line_under_the_plate_and_goes_on() -> None:
    """``robodcn follow --arm omx`` (a process, targets on stdin): a pose under the plate is
    one stderr line naming its line, field and zone; the next target is taken."""
    env = {**os.environ, "PYTHONPATH": str(CONFIGS.parent)}
    proc = subprocess.Popen([sys.executable, "-m", "robodcn", "follow", "--sim", "--timing",
                             "fast", "--dynamics", "off", "--arm", "omx", "--space", "pose"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=CONFIGS.parent)
    below = [0.2, 0.0, -0.1, -math.pi / 2]
    near = [OMX.home[0] + 0.01, OMX.home[1], OMX.home[2] - 0.01, OMX.home[3]]
    _out, err = proc.communicate(json.dumps({"pose": below}) + "\n"
                                 + json.dumps({"pose": near}) + "\n", timeout=120)
    lines = err.strip().splitlines()
    assert proc.returncode in (0, 5), err
    refused = [ln for ln in lines if ln.startswith("robodcn: line ")]
    assert len(refused) == 1 and refused[0].startswith("robodcn: line 1: pose: "), refused
    assert "100.0 mm inside the arm's keep-out zone 'floor'" in refused[0]
    assert lines[-1].startswith("follow: 1 target(s) taken, 1 refused"), lines[-1]
