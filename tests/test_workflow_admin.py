"""pose, torque, reboot, servo info / set-id / set-baud end to end against firmware_sim over a
pty through the real dynamixel-sdk; the USB latency timer; bad input refused before the bus."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from workflow_helpers import ARM3R, NO_DEVICE, backdrive, run_cli

from firmware_sim.bus import SimBus
from robodcn import kinematics, servo_units
from robodcn.bus import lower_latency_timer
from robodcn.config import load_arm

pytest_plugins = ["workflow_fixtures"]     # fixtures: sim
ARM = load_arm(ARM3R)


def _cli(monkeypatch, sim, *argv, steps=()):
    return run_cli(monkeypatch, [*argv, "--arm", ARM3R, "--device", sim.port_path], steps)


def test_pose_prints_joints_ticks_and_fk(sim, monkeypatch, capsys):
    ticks = {1: 2400, 2: 1500, 3: 2100}
    backdrive(sim, ticks)
    assert _cli(monkeypatch, sim, "pose", "--json") == 0
    state = json.loads(capsys.readouterr().out)
    q = servo_units.ticks_to_radians(list(ticks.values()), ARM.servos)
    assert state["ticks"] == list(ticks.values())
    assert np.allclose(state["joints"], q)
    assert np.allclose(state["pose"], kinematics.fk(ARM.links, q[None])[0])
    assert _cli(monkeypatch, sim, "pose") == 0
    line = capsys.readouterr().out
    assert f"shoulder {math.degrees(q[0]):8.2f}°" in line and "ticks 2400,1500,2100" in line


def test_pose_watch_refreshes(sim, monkeypatch, capsys):
    assert _cli(monkeypatch, sim, "pose", "--watch", "--count", "3", "--interval",
                "0.01") == 0
    assert len(capsys.readouterr().out.splitlines()) == 3


def test_torque_per_joint_and_all(sim, monkeypatch, capsys):
    backdrive(sim, {1: 2200, 2: 1800, 3: 2000})
    assert _cli(monkeypatch, sim, "torque", "on", "--joint", "elbow") == 0
    assert [s.torque_enabled for s in sim.servos] == [False, True, False]
    assert _cli(monkeypatch, sim, "torque", "on") == 0
    assert all(s.torque_enabled for s in sim.servos)
    # Torque on holds where the arm is: no jump.
    assert [s.present_position for s in sim.servos] == [2200, 1800, 2000]
    assert [s.goal_position for s in sim.servos] == [2200, 1800, 2000]
    assert _cli(monkeypatch, sim, "torque", "off", "--joint", "wrist") == 0
    assert [s.torque_enabled for s in sim.servos] == [True, True, False]
    assert "torque off: servo(s) 3" in capsys.readouterr().out


def test_reboot_clears_a_hardware_error(sim, monkeypatch, capsys):
    sim.servo(3).write(64, b"\x01")
    sim.servo(3).trip(0x20)                                 # overload
    assert sim.servo(3).hardware_error == 0x20
    assert _cli(monkeypatch, sim, "servo", "info", "--json") == 0
    info = {s["id"]: s for s in json.loads(capsys.readouterr().out)["servos"]}
    assert info[3]["hardware_error"] == 0x20 and info[3]["hardware_error_names"] == "overload"
    assert _cli(monkeypatch, sim, "reboot", "--joint", "wrist") == 0
    assert sim.servo(3).hardware_error == 0
    assert "rebooted servo(s) 3" in capsys.readouterr().out


def test_servo_info_reports_each_servo(sim, monkeypatch, capsys):
    assert _cli(monkeypatch, sim, "servo", "info", "--json") == 0
    servos = json.loads(capsys.readouterr().out)["servos"]
    assert [s["id"] for s in servos] == [1, 2, 3]
    for s, servo in zip(servos, sim.servos, strict=True):
        assert s["answered"] and s["model"] == "xm430-w350" and s["firmware"] == 46
        assert s["baud"] == 1_000_000 and s["operating_mode_name"] == "position"
        assert s["voltage_v"] == servo.get(144) / 10 and s["temperature_c"] == servo.get(146)
        assert s["hardware_error"] == 0 and s["torque"] is False
    assert _cli(monkeypatch, sim, "servo", "info") == 0
    table = capsys.readouterr().out.splitlines()
    assert len(table) == 4 and "shoulder" in table[1] and "position" in table[1]


def test_set_id_changes_one_servo_and_refuses_a_taken_id(sim, monkeypatch, capsys):
    assert _cli(monkeypatch, sim, "servo", "set-id", "3", "7", "--yes") == 0
    assert [s.id for s in sim.servos] == [1, 2, 7]
    assert _cli(monkeypatch, sim, "servo", "set-id", "1", "2", "--yes") == 2
    assert "id 2 is already taken" in capsys.readouterr().err
    assert _cli(monkeypatch, sim, "servo", "set-id", "9", "10", "--yes") == 2
    assert "no servo answers at id 9" in capsys.readouterr().err
    # Without --yes a "n" answer changes nothing.
    assert _cli(monkeypatch, sim, "servo", "set-id", "7", "3", steps=["n"]) == 130
    assert [s.id for s in sim.servos] == [1, 2, 7]


def test_set_baud_switches_every_servo(sim, monkeypatch, capsys):
    assert _cli(monkeypatch, sim, "servo", "set-baud", "57600", steps=["y"]) == 0
    assert [s.baud_index for s in sim.servos] == [1, 1, 1]
    assert "now at 57600 baud" in capsys.readouterr().out
    assert _cli(monkeypatch, sim, "pose", "--baud", "57600") == 0


def test_set_baud_refuses_when_an_id_answers_at_the_new_rate(monkeypatch, capsys):
    bus = SimBus([1, 2, 3, 11], "xm430-w350", baud=1_000_000, timing="fast", log=False)
    # Servo 11 is set to id 3 at 57 600 baud: switching 1..3 there would put two on id 3.
    assert bus.servo(11).write(8, b"\x01") == 0 and bus.servo(11).write(7, b"\x03") == 0
    bus.start()
    try:
        code = run_cli(monkeypatch, ["servo", "set-baud", "57600", "--yes", "--arm", ARM3R,
                                     "--device", bus.port_path])
        assert code == 2 and "id(s) [3] already answer" in capsys.readouterr().err
        assert [s.baud_index for s in bus.servos] == [3, 3, 3, 1]
    finally:
        bus.close()


@pytest.mark.parametrize(("argv", "needle"), [
    (["torque", "on", "--joint", "thumb"], "--joint 'thumb'"),
    (["reboot", "--joint", "thumb"], "--joint 'thumb'"),
    (["servo", "set-id", "4", "4", "--yes"], "NEW must differ"),
    (["servo", "set-baud", "1000000", "--yes"], "BAUD 1000000 is the present"),
    (["pose", "--arm", "no-such-arm"], "'no-such-arm'"),
])
def test_bad_input_is_refused_before_the_bus_opens(monkeypatch, capsys, argv, needle):
    code = run_cli(monkeypatch, [*argv, "--device", NO_DEVICE])
    err = capsys.readouterr().err
    assert code == 2 and needle in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("argv", [["servo", "set-id", "1", "253"], ["pose", "--baud", "1200"],
                                  ["servo", "set-baud", "4500000"], ["torque", "sideways"]])
def test_bad_values_are_usage_errors(monkeypatch, capsys, argv):
    with pytest.raises(SystemExit) as exc:
        run_cli(monkeypatch, [*argv, "--device", NO_DEVICE])
    err = capsys.readouterr().err
    # The CLI's one-line usage error: "robodcn <command>: argument <OPTION>: ..." (no traceback).
    assert exc.value.code == 2 and ": argument " in err and len(err.strip().splitlines()) == 1


def test_a_missing_device_is_a_bus_fault(monkeypatch, capsys):
    assert run_cli(monkeypatch, ["pose", "--device", NO_DEVICE]) == 4
    assert NO_DEVICE in capsys.readouterr().err


def test_latency_timer_is_lowered_when_writable(tmp_path, monkeypatch):
    timer = tmp_path / "ttyUSB7" / "latency_timer"
    timer.parent.mkdir()
    timer.write_text("16\n")
    result = lower_latency_timer("/dev/ttyUSB7", sysfs=tmp_path)
    assert (result.before, result.after, result.changed) == (16, 1, True)
    assert timer.read_text().strip() == "1"
    assert "set the USB latency timer to 1 ms (was 16 ms)" in result.message("/dev/ttyUSB7")
    assert lower_latency_timer("/dev/ttyUSB7", sysfs=tmp_path).message("/dev/ttyUSB7") is None
    # Not writable: the message names the fix.
    timer.write_text("16\n")

    def refuse(self, *args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(Path, "write_text", refuse)
    result = lower_latency_timer("/dev/ttyUSB7", sysfs=tmp_path)
    assert (result.before, result.changed) == (16, False)
    assert f"echo 1 | sudo tee {timer}" in result.message("/dev/ttyUSB7")
    assert lower_latency_timer("/dev/pts/3", sysfs=tmp_path).before is None


def test_commands_as_processes_against_python_m_firmware_sim():
    import signal
    import subprocess
    import sys

    from conftest import ROOT

    proc = subprocess.Popen([sys.executable, "-m", "firmware_sim", "--ids", "1,2,3", "--timing",
                             "fast"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=ROOT)
    try:
        device = proc.stdout.readline().strip()
        assert device.startswith("/dev/"), proc.stderr.read()

        def robodcn(*args):
            return subprocess.run([sys.executable, "-m", "robodcn", *args, "--device", device],
                                  capture_output=True, text=True, timeout=60, cwd=ROOT)

        out = robodcn("torque", "on", "--arm", "arm3r")
        assert out.returncode == 0, out.stderr
        out = robodcn("servo", "info", "--arm", "arm3r", "--json")
        assert out.returncode == 0, out.stderr
        assert [s["torque"] for s in json.loads(out.stdout)["servos"]] == [True] * 3
        out = robodcn("pose", "--arm", "arm3r", "--json")
        assert out.returncode == 0, out.stderr
        assert json.loads(out.stdout)["ticks"] == [2048, 2048, 2048]
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0


@pytest.mark.parametrize("argv", [["pose"], ["pose", "--json"], ["torque", "off"],
                                  ["servo", "info"], ["servo", "info", "--json"]])
def test_servos_of_another_model_are_warned_about(monkeypatch, capsys, argv):
    """pose / torque / servo info carry on (they are how one finds out) but say it."""
    models = {1: "xm430-w350", 2: "xl430-w250", 3: "xm430-w350"}
    with SimBus((1, 2, 3), model=models, timing="fast", log=False) as other:
        code = _cli(monkeypatch, other, *argv)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    warnings = [line for line in captured.err.splitlines() if "warning" in line]
    assert len(warnings) == 1, captured.err
    assert warnings[0].startswith("robodcn: warning: servo 2 (joint 'elbow') answers as model "
                                  "xl430-w250") and "the config says xm430-w350" in warnings[0]
    assert "warning" not in captured.out


def test_servos_of_the_configured_model_bring_no_warning(sim, monkeypatch, capsys):
    for argv in (["pose"], ["torque", "off"], ["servo", "info"]):
        assert _cli(monkeypatch, sim, *argv) == 0
        assert "warning" not in capsys.readouterr().err
