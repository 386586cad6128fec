"""Never drop the arm (issue 26 §2), as its owner would see it on firmware_sim's physics
OpenMANIPULATOR-X under gravity: every path that switches torque off — a reboot over HTTP
and on the command line, a calibration, a teach session, servo set-id — asks first and
changes nothing unasked, lowers the arm to its rest pose when confirmed (or says to hold it
where it cannot be lowered), and a calibration or a teach leaves the arm holding however it
ends; float teach from torque-off servos switches them on and the arm stays where the hand
leaves it. A hand holds and lets go of the arm through the simulator's control socket."""

from __future__ import annotations

import socket
import time
from collections.abc import Iterator

import numpy as np
import pytest
from http_helpers import call, error_of, serving_arm
from omx_helpers import OMX, joints_of, pose_of
from workflow_helpers import run_cli

from firmware_sim import control_table as fct
from firmware_sim.control_socket import ControlServer
from robodcn import kinematics
from robodcn.workflow import float_teach, release

pytest_plugins = ["omx_helpers"]     # fixtures: held_omx

#: The joints gravity loads on the omx (the yaw turns about the vertical: it holds nothing).
LOADED = ("shoulder", "elbow", "wrist")
#: The rest pose's tool height (m).
REST_Z = OMX.rest[2]


def torque_on(sim) -> list[bool]:
    return [sim.servo(i).torque_enabled for i in OMX.servo_ids]


def modes(sim) -> list[int]:
    return [sim.servo(i).operating_mode for i in OMX.servo_ids]


def heights(sim, seconds: float, every: float = 0.05) -> np.ndarray:
    """The tool point's z (m) read every ``every`` s for ``seconds``."""
    out = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        out.append(pose_of(sim)[2])
        time.sleep(every)
    return np.array(out)


def at_rest(sim) -> bool:
    """The joints within 3° of the rest pose's (the arm lies on its support there)."""
    rest_q = kinematics.ik_yawed(OMX.chain, np.array([OMX.rest]), OMX.elbow)[0]
    return bool(np.all(np.abs(joints_of(sim) - rest_q) < np.radians(3.0)))


class Hand:
    """A hand on the simulated arm through firmware_sim's control socket (``push``: an
    external torque on a joint's output shaft, N·m)."""

    def __init__(self, path: str) -> None:
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.connect(path)
        self.file = self.sock.makefile("rw", encoding="utf-8", newline="\n")

    def send(self, line: str) -> str:
        self.file.write(line + "\n")
        self.file.flush()
        answer = self.file.readline().strip()
        assert answer.startswith("ok"), (line, answer)
        return answer

    def hold(self, sim) -> None:
        """Hold the arm where it is: on each joint the torque gravity asks there."""
        torques = float_teach.gravity_torques(OMX, joints_of(sim))
        for servo_id, nm in zip(OMX.servo_ids, torques, strict=True):
            self.send(f"push {servo_id} {float(nm):.5f}")

    def let_go(self) -> None:
        for servo_id in OMX.servo_ids:
            self.send(f"push {servo_id} 0")

    def close(self) -> None:
        self.file.close()
        self.sock.close()


@pytest.fixture
def hand(held_omx, tmp_path) -> Iterator[Hand]:
    server = ControlServer(held_omx, str(tmp_path / "hand.sock"))
    h = Hand(server.path)
    try:
        yield h
    finally:
        h.close()
        server.close()


# -- reboot over HTTP -----------------------------------------------------------------------------

def test_http_reboot_asks_first_and_changes_nothing_unasked() -> None:
    with serving_arm(OMX) as (server, sa):
        z = pose_of(sa.sim)[2]
        for body in ({}, {"joint": "elbow"}, {"confirm": False}):
            status, _, answer = call(server, "POST", "/v1/reboot", body)
            assert status == 409, answer
            error = error_of(answer)
            assert error["code"] == "gravity_release" and error["field"] == "confirm", error
            assert "reboot" in error["message"] and "elbow" in error["message"]
        assert all(torque_on(sa.sim))                           # nothing rebooted
        assert np.abs(heights(sa.sim, 0.5) - z).max() < 0.002   # and nothing moved
        status, _, answer = call(server, "POST", "/v1/reboot", {"confirm": "yes"})
        assert status == 422 and error_of(answer)["field"] == "confirm", answer
        # the yaw holds nothing against gravity: no confirmation, no lowering
        status, _, answer = call(server, "POST", "/v1/reboot", {"joint": "yaw"})
        assert status == 200 and answer["servo_ids"] == [11] and not answer["lowered"], answer
        assert torque_on(sa.sim) == [False, True, True, True]
        assert abs(pose_of(sa.sim)[2] - z) < 0.002


def test_http_reboot_confirmed_lowers_to_rest_first_and_the_arm_stays_there() -> None:
    with serving_arm(OMX) as (server, sa):
        assert pose_of(sa.sim)[2] > 0.2                        # at home, up high
        status, _, answer = call(server, "POST", "/v1/reboot", {"confirm": True},
                                 timeout=30.0)
        assert status == 200, answer
        assert answer["lowered"] and answer["hold"] is None
        assert answer["servo_ids"] == list(OMX.servo_ids)
        assert not any(torque_on(sa.sim))                      # a reboot leaves torque off
        z = heights(sa.sim, 1.0)                               # ... on an arm at rest
        assert np.abs(z - REST_Z).max() < 0.01, z
        assert at_rest(sa.sim)
        # torque off everywhere already: a reboot drops nothing, so it asks nothing
        status, _, answer = call(server, "POST", "/v1/reboot", {})
        assert status == 200 and not answer["lowered"] and answer["hold"] is None, answer
        assert np.abs(heights(sa.sim, 0.3) - REST_Z).max() < 0.01


@pytest.mark.serial    # a stop at a wall-clock moment of the lowering
def test_http_stop_stops_the_lowering_and_torque_stays_on() -> None:
    import threading

    with serving_arm(OMX) as (server, sa):
        answers = []
        worker = threading.Thread(target=lambda: answers.append(call(
            server, "POST", "/v1/torque", {"on": False, "confirm": True}, timeout=30.0)))
        worker.start()
        deadline = time.monotonic() + 5.0
        while pose_of(sa.sim)[2] > 0.22 and time.monotonic() < deadline:
            time.sleep(0.01)                                   # the lowering has begun
        status, _, stopped = call(server, "POST", "/v1/stop", {"mode": "hold"})
        worker.join(30.0)
        assert status == 200 and stopped["stopped"], stopped
        status, _, answer = answers[0]
        assert status == 409 and error_of(answer)["code"] == "stopped", answer
        assert all(torque_on(sa.sim))                          # not released: it holds
        time.sleep(0.3)                                        # the hold's own settling
        z = heights(sa.sim, 0.5)
        assert z.min() > REST_Z + 0.02 and np.ptp(z) < 0.004, z


# -- reboot, servo set-id on the command line ----------------------------------------------------

def test_cli_reboot_needs_yes_then_lowers_first(held_omx, monkeypatch, capsys):
    z = pose_of(held_omx)[2]
    argv = ["reboot", "--arm", "omx", "--device", held_omx.port_path]
    assert run_cli(monkeypatch, argv) == 2
    err = capsys.readouterr().err
    assert "reboot" in err and "fall under gravity" in err and "--yes confirms" in err
    assert all(name in err for name in LOADED)
    assert all(torque_on(held_omx)) and abs(pose_of(held_omx)[2] - z) < 0.002
    assert run_cli(monkeypatch, [*argv, "--yes"]) == 0
    out, err = capsys.readouterr()
    assert "rebooted servo(s) 11, 12, 13, 14" in out and "lowered to its rest pose" in out
    assert "lowering it to its rest pose first" in err          # the warning, before
    assert not any(torque_on(held_omx))
    assert np.abs(heights(held_omx, 0.8) - REST_Z).max() < 0.01 and at_rest(held_omx)


def test_cli_reboot_with_a_servo_in_alert_says_hold_it_and_still_reboots(
        held_omx, monkeypatch, capsys):
    """An overloaded servo shuts its torque off: the streamer refuses a lowering then, so
    the user is told to hold the arm, and the reboot that clears the alert goes on."""
    held_omx.servo(14).trip(0x20)                               # the wrist overloads
    argv = ["reboot", "--arm", "omx", "--device", held_omx.port_path]
    assert run_cli(monkeypatch, argv) == 2                      # asked: it says hold it
    err = capsys.readouterr().err
    assert "servo(s) in alert" in err and "hold it" in err and "--yes confirms" in err
    assert held_omx.servo(14).hardware_error                    # nothing rebooted
    assert run_cli(monkeypatch, [*argv, "--yes"]) == 0
    out, err = capsys.readouterr()
    assert "cannot be lowered first" in err and "hold it" in err, err
    assert "rebooted servo(s) 11, 12, 13, 14 (torque is off)" in out
    assert held_omx.servo(14).hardware_error == 0


def test_servo_set_id_on_a_loaded_joint_needs_yes(held_omx, monkeypatch, capsys):
    argv = ["servo", "set-id", "13", "20", "--arm", "omx", "--device", held_omx.port_path]
    assert run_cli(monkeypatch, argv) == 2
    err = capsys.readouterr().err
    assert "servo set-id 13 20" in err and "elbow" in err and "--yes confirms" in err
    assert all(torque_on(held_omx)) and held_omx.servo(13).torque_enabled
    assert held_omx.servo(13).get(fct.ID) == 13                 # not changed


def test_servo_set_baud_of_an_arm_under_gravity_needs_yes(held_omx, monkeypatch, capsys):
    argv = ["servo", "set-baud", "57600", "--arm", "omx", "--device", held_omx.port_path]
    assert run_cli(monkeypatch, argv) == 2
    err = capsys.readouterr().err
    assert "servo set-baud 57600" in err and "--yes confirms" in err
    assert all(name in err for name in LOADED)
    assert all(torque_on(held_omx))                             # nothing written
    assert all(held_omx.servo(i).get(fct.BAUD_RATE) == 3 for i in OMX.servo_ids)


# -- calibrate ------------------------------------------------------------------------------------

def test_calibrate_asks_before_torque_off_and_a_no_changes_nothing(held_omx, monkeypatch,
                                                                  capsys, tmp_path):
    z = pose_of(held_omx)[2]
    out = tmp_path / "cal.toml"
    code = run_cli(monkeypatch, ["calibrate", "--arm", "omx", "--device", held_omx.port_path,
                                 "--out", str(out)], ["n"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "calibration switches torque off" in err and "--yes confirms" in err
    assert all(name in err for name in LOADED)
    assert all(torque_on(held_omx))
    assert np.abs(heights(held_omx, 0.5) - z).max() < 0.002 and not out.exists()


@pytest.mark.serial    # a hand on the real clock
@pytest.mark.parametrize("abort", ["end of input", "Ctrl-C"])
def test_calibrate_confirmed_lowers_first_and_an_abort_leaves_it_holding(
        held_omx, hand, monkeypatch, capsys, tmp_path, abort):
    """y: lowered to rest, torque off, the hand lifts the arm toward the reference pose and
    holds it; the calibration is aborted there: torque on, position mode, holding where
    the hand left it."""
    def lift() -> str:
        assert not any(torque_on(held_omx)) and at_rest(held_omx)
        hand.hold(held_omx)
        hand.send(f"move 12 {2048 - 400}")                     # shoulder up, by hand
        hand.hold(held_omx)
        return ""

    def interrupt() -> str:
        raise KeyboardInterrupt

    end = [] if abort == "end of input" else [interrupt]
    code = run_cli(monkeypatch, ["calibrate", "--arm", "omx", "--device",
                                 held_omx.port_path, "--out", str(tmp_path / "c.toml")],
                   ["y", lift, *end])
    err = capsys.readouterr().err
    assert code == (2 if abort == "end of input" else 130), err
    assert "lowering it to its rest pose first" in err
    assert "the arm holds where it is (torque on, position mode)" in err
    assert all(torque_on(held_omx)) and modes(held_omx) == [3, 3, 3, 3]
    left = pose_of(held_omx)[2]
    hand.let_go()
    assert np.abs(heights(held_omx, 1.0) - left).max() < 0.005   # held, not dropped


# -- teach ---------------------------------------------------------------------------------------

@pytest.mark.serial    # the float loop's refresh rate on the real clock
def test_float_teach_from_torque_off_switches_torque_on_and_the_arm_stays(
        held_omx, hand, monkeypatch, capsys, tmp_path):
    """A freshly powered arm (torque off) that a hand holds up: teach --float switches the
    joints on in current control; the hand lets go and the elbow does not sag."""
    hand.hold(held_omx)
    for servo_id in OMX.servo_ids:
        held_omx.servo(servo_id).write(fct.TORQUE_ENABLE, b"\x00")
    assert not any(torque_on(held_omx))
    seen = {}

    def let_go() -> str:            # at the first prompt: the float is on
        hand.let_go()
        seen["floating"] = (torque_on(held_omx), modes(held_omx))
        seen["q"] = joints_of(held_omx)
        seen["z"] = heights(held_omx, 1.0)
        seen["q_after"] = joints_of(held_omx)
        return "q"

    code = run_cli(monkeypatch, ["teach", "--arm", "omx", "--device", held_omx.port_path,
                                 "--out", str(tmp_path / "f.toml"), "--float"], [let_go])
    err = capsys.readouterr().err
    assert code == 2, err                                       # no waypoint: not written
    assert seen["floating"] == ([True] * 4, [0, 0, 0, 0])       # current control, torque on
    z = seen["z"]
    assert np.ptp(z) < 0.004, z                                 # it stays where it was left
    sag = np.degrees(np.abs(seen["q_after"] - seen["q"]))
    assert sag.max() < 1.0, sag                                 # the elbow too
    assert "it stays where you leave it" in err and "torque on" in err
    assert "the arm holds where it was left (position mode)" in err
    assert all(torque_on(held_omx)) and modes(held_omx) == [3, 3, 3, 3]


def test_teach_without_float_lowers_first_and_ends_holding(held_omx, hand, monkeypatch,
                                                           capsys, tmp_path):
    def lift() -> str:
        assert not any(torque_on(held_omx)) and at_rest(held_omx)
        hand.hold(held_omx)
        return ""

    code = run_cli(monkeypatch, ["teach", "--arm", "omx", "--device", held_omx.port_path,
                                 "--out", str(tmp_path / "t.toml"), "--yes"],
                   [lift, "q"])
    err = capsys.readouterr().err
    assert code == 2, err                                       # one pose: not written
    assert "teach lets arm 'omx' fall under gravity" in err
    assert "teach: the arm holds where it is (torque on, position mode)" in err
    assert all(torque_on(held_omx)) and modes(held_omx) == [3, 3, 3, 3]
    hand.let_go()
    assert np.ptp(heights(held_omx, 0.6)) < 0.005


# -- the guard itself -----------------------------------------------------------------------------

def test_joints_off_already_or_unloaded_need_no_confirmation(held_omx):
    """The check counts only joints that are on and loaded: the yaw alone, or a joint
    whose torque is off already, drops nothing."""
    q = joints_of(held_omx)
    assert release.check_release(OMX, q).joints == LOADED
    assert not release.check_release(OMX, q, [11]).falls
    assert release.check_release(OMX, q, [13]).joints == ("elbow",)
    assert not release.check_release(OMX, q, [15]).falls        # the gripper: no joint


def test_the_library_stream_refuses_to_release_an_arm_under_gravity():
    """``robodcn.execute(..., release=True)`` switches torque off at the end of a stream: on
    an arm under gravity it is refused before anything is sent (the guard releases it)."""
    from robodcn import execute, plan
    from robodcn.errors import GravityReleaseError
    from robodcn.simulated import simulated_arm

    with simulated_arm(OMX, timing="fast") as s:
        q = joints_of(s.sim)
        trajectory = plan(OMX, [kinematics.fk_yawed(OMX.chain, q[None])[0], OMX.home],
                          start_joints=q)
        before = {i: len(s.sim.goal_history(i)) for i in OMX.servo_ids}
        with pytest.raises(GravityReleaseError) as err:
            execute(trajectory, s.bus, release=True)
        assert err.value.field == "release" and "shoulder" in err.value.message
        assert {i: len(s.sim.goal_history(i)) for i in OMX.servo_ids} == before
        assert all(torque_on(s.sim))
