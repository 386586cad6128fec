"""The motion commands end to end in subprocesses: sim (in-process simulated bus), move and
scan against `python -m firmware_sim`, serve, Ctrl-C, and progress only on a terminal."""

from __future__ import annotations

import json
import os
import pty
import re
import select
import signal
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest
from workflow_helpers import ARM3R, COMPLETED

ROOT = Path(__file__).resolve().parent.parent
MOVE = ("--to", "0.12,0.24,60")


def robodcn(*args: str, timeout: float = 60.0, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "robodcn", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=ROOT, **kwargs)


@pytest.fixture
def firmware(request) -> Iterator[str]:
    """A `python -m firmware_sim` process; yields its device path."""
    ids = getattr(request, "param", "1,2,3")
    # the servos drive the arm the config describes (its bodies under the physics), as on
    # a real arm: the compensation's lead is computed for that arm
    arm = ("--arm", str(ARM3R)) if ids == "1,2,3" else ()
    proc = subprocess.Popen([sys.executable, "-m", "firmware_sim", "--ids", ids, *arm,
                             "--timing", "fast"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        device = proc.stdout.readline().strip()
        assert device.startswith("/dev/"), proc.stderr.read()
        yield device
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0


def test_sim_runs_a_move_and_plots(tmp_path):
    plot = tmp_path / "move.png"
    out = robodcn("sim", "--arm", ARM3R, "--from", "0.25,0.10,0", "--via", "0.12,0.24,60",
                  "--to", "-0.10,0.22,120", "--method", "kenlerp", "--beta", "0.5",
                  "--plot", str(plot))
    assert out.returncode in COMPLETED, out.stderr
    assert out.stdout.startswith("completed")
    assert plot.stat().st_size > 10_000 and plot.read_bytes()[:4] == b"\x89PNG"
    assert f"plot: {plot}" in out.stderr     # stdout is the report (JSON with --json)


# Real time end to end (a subprocess streaming at 100 Hz with servo physics): in the serial
# pass, where no other test worker competes for the two cores (a skipped sample under load
# is a real, reported degradation: tracking and the final tick suffer).
@pytest.mark.serial
@pytest.mark.parametrize("extra", [(), ("--realtime",)], ids=["normal", "realtime"])
def test_sim_json_report_sends_every_sample(extra):
    out = robodcn("sim", "--arm", ARM3R, *MOVE, "--timing", "fast", "--json", *extra)
    assert out.returncode in COMPLETED, out.stderr
    report = json.loads(out.stdout)
    assert report["stop_reason"] == "completed"
    assert report["outcome"] == ("done" if out.returncode == 0 else "degraded")
    assert (report["samples_skipped"] > 0) == (out.returncode == 5)
    assert report["samples_sent"] + report["samples_skipped"] == report["samples_total"] > 10
    # The physics sim (the default) settles to within the streamer's one-tick settle band.
    assert max(abs(e) for e in report["final_error_ticks"]) <= 1


@pytest.mark.serial
def test_move_and_scan_against_firmware_sim(firmware):
    scan = robodcn("scan", "--device", firmware, "--ids", "1-4", "--json")
    assert scan.returncode == 0, scan.stderr
    assert [s["id"] for s in json.loads(scan.stdout)["servos"]] == [1, 2, 3]
    first = robodcn("move", "--arm", ARM3R, "--device", firmware, *MOVE, "--json")
    assert first.returncode in COMPLETED, first.stderr
    # At rest within one encoder count (the physics default: friction holds a motor on
    # either side of its last tick).
    assert max(abs(e) for e in json.loads(first.stdout)["final_error_ticks"]) <= 1
    # The second move starts where the first ended (its present pose) and comes back.
    back = robodcn("move", "--arm", ARM3R, "--device", firmware, "--to", "0.25,0.10,0",
                   "--json")
    assert back.returncode in COMPLETED, back.stderr
    assert json.loads(back.stdout)["stop_reason"] == "completed"


@pytest.mark.parametrize("firmware", ["1,2"], indirect=True)
def test_move_with_a_missing_servo_is_a_bus_fault(firmware):
    out = robodcn("move", "--arm", ARM3R, "--device", firmware, *MOVE)
    assert out.returncode == 4, out.stderr
    assert "3" in out.stderr and "Traceback" not in out.stderr


def test_infeasible_move_exits_3_before_moving(firmware):
    out = robodcn("move", "--arm", ARM3R, "--device", firmware, "--to", "0.6,0.0,0")
    assert out.returncode == 3, out.stderr
    assert "out of reach" in out.stderr


def test_ctrl_c_stops_and_holds():
    proc = subprocess.Popen([sys.executable, "-m", "robodcn", "sim", "--arm", ARM3R, *MOVE,
                             "--duration", "6", "--timing", "fast", "--json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    time.sleep(2.5)  # start-up (imports, bus set-up) plus part of the move
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 130, stderr
    report = json.loads(stdout)
    assert report["stop_reason"] == "stopped"
    assert 0 < report["samples_sent"] < report["samples_total"]
    assert report["hold_goals"] is not None


def _run_on_a_terminal(args: list[str], timeout: float = 60.0) -> tuple[int, str]:
    """Run with stdin/stdout/stderr on a pseudo-terminal; returns (exit code, output)."""
    leader, follower = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "robodcn", *args], stdin=follower,
                            stdout=follower, stderr=follower, cwd=ROOT, close_fds=True)
    os.close(follower)
    chunks, deadline = [], time.monotonic() + timeout
    while time.monotonic() < deadline:
        ready, _, _ = select.select([leader], [], [], 0.1)
        if ready:
            try:
                data = os.read(leader, 4096)
            except OSError:
                break
            if not data:
                break
            chunks.append(data)
        elif proc.poll() is not None:
            break
    os.close(leader)
    return proc.wait(timeout=10), b"".join(chunks).decode(errors="replace")


def test_progress_is_shown_on_a_terminal_only():
    args = ["sim", "--arm", ARM3R, *MOVE, "--timing", "fast", "--duration", "1.5"]
    code, text = _run_on_a_terminal(args)
    assert code in COMPLETED, text
    assert re.search(r"\r\[#+ *\] +\d+\.\d%", text), text[-500:]
    plain = robodcn(*args)
    assert plain.returncode in COMPLETED
    assert "\r" not in plain.stderr and "%" not in plain.stderr


def test_serve_sim_answers_and_exits_on_sigterm():
    proc = subprocess.Popen([sys.executable, "-m", "robodcn", "serve", "--arm", ARM3R, "--sim",
                             "--port", "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=ROOT)
    try:
        line = proc.stdout.readline()
        url = re.search(r"http://[\d.]+:\d+", line)
        assert url, line + proc.stderr.read()
        with urllib.request.urlopen(url.group(0) + "/healthz", timeout=10) as response:
            assert response.status == 200
        with urllib.request.urlopen(url.group(0) + "/v1/arm", timeout=10) as response:
            assert json.loads(response.read())["name"] == "arm3r"
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=15) == 0


def test_old_port_spelling_still_works_with_a_note(firmware):
    scan = robodcn("scan", "--port", firmware, "--ids", "1-3", "--json")
    assert scan.returncode == 0, scan.stderr
    assert "--port is deprecated, use --device" in scan.stderr
    move = robodcn("move", "--arm", ARM3R, "--port", firmware, *MOVE, "--json")
    assert move.returncode in COMPLETED, move.stderr
    assert "--port is deprecated, use --device" in move.stderr
    assert json.loads(move.stdout)["outcome"] in ("done", "degraded")


def test_scan_finding_no_servo_is_a_bus_fault(firmware):
    out = robodcn("scan", "--device", firmware, "--ids", "7-9")
    assert out.returncode == 4, out.stderr
    # The last line is the verdict (the bus may log its unanswered pings above it).
    assert out.stderr.strip().splitlines()[-1] == (
        f"robodcn: no servo answered on {firmware} at 1000000 baud (ids 7,8,9)")
    assert "Traceback" not in out.stderr


def test_move_into_a_closed_pipe_exits_quietly(firmware):
    proc = subprocess.Popen([sys.executable, "-m", "robodcn", "move", "--arm", ARM3R,
                             "--device", firmware, *MOVE], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT)
    proc.stdout.close()  # like `| head -0`: the reader is gone before the report
    err = proc.stderr.read()
    assert proc.wait(timeout=60) in COMPLETED, err
    assert "Traceback" not in err and "BrokenPipe" not in err
    # The move itself ran to the end: the arm is at the goal.
    again = robodcn("move", "--arm", ARM3R, "--device", firmware, *MOVE, "--json")
    assert again.returncode in COMPLETED, again.stderr
    assert json.loads(again.stdout)["approach_s"] == 0


@pytest.mark.parametrize("name, needle", [("missing/move.png", "no such directory"),
                                          (".", "is a directory"),
                                          ("move.xyz", "cannot draw .xyz")])
def test_bad_plot_path_is_refused_before_moving(tmp_path, name, needle):
    out = robodcn("sim", "--arm", ARM3R, *MOVE, "--timing", "fast", "--plot",
                  str(tmp_path / name))
    assert out.returncode == 2, out.stderr
    assert needle in out.stderr and "--plot" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
    assert out.stdout == ""  # no report: nothing was streamed


def test_approach_is_reported_with_its_duration():
    out = robodcn("sim", "--arm", ARM3R, "--from", "0.20,0.15,30", *MOVE, "--timing", "fast")
    assert out.returncode in COMPLETED, out.stderr
    line = next(ln for ln in out.stdout.splitlines() if "approach" in ln)
    seconds = float(re.search(r"approach (\d+\.\d+) s", line).group(1))
    total = float(re.search(r"in (\d+\.\d+) s", out.stdout).group(1))
    assert 0 < seconds < total


# -- in-process: the report and exit code of what the streamer returns ----------------------------

def _main(capsys, *args: str) -> tuple[int, str, str]:
    from robodcn import cli

    code = cli.main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture
def skipping_stream(monkeypatch):
    """robodcn.stream.execute as it is, but its report says 7 samples were skipped, and it
    warns (as the streamer does when the rate is more than the baud carries)."""
    import dataclasses
    import warnings

    import robodcn.stream as stream

    real = stream.execute

    def execute(trajectory, bus, **kwargs):
        warnings.warn("1000 Hz is more than 1000000 baud carries for 3 servos", UserWarning,
                      stacklevel=2)
        report = real(trajectory, bus, **kwargs)
        fields = {f.name for f in dataclasses.fields(report)}
        count = "skipped" if "skipped" in fields else "samples_skipped"  # the newer name first
        return dataclasses.replace(report, **{count: 7}, samples_sent=report.samples_sent - 7)

    monkeypatch.setattr(stream, "execute", execute)


def test_a_run_that_skipped_samples_says_so_and_exits_5(capsys, skipping_stream):
    code, out, err = _main(capsys, "sim", "--arm", ARM3R, *MOVE, "--timing", "fast")
    assert code == 5, err
    assert "all samples sent" not in out
    total = int(re.search(r"samples sent \d+/(\d+)", out).group(1))
    assert out.startswith(f"completed with 7 of {total} samples skipped")
    assert "robodcn: warning: 1000 Hz is more than 1000000 baud carries" in err
    code, out, _ = _main(capsys, "sim", "--arm", ARM3R, *MOVE, "--timing", "fast", "--json")
    assert code == 5 and json.loads(out)["outcome"] == "degraded"


def test_serial_device_failing_is_a_bus_fault(capsys, monkeypatch):
    import robodcn.bus as bus

    class Gone:
        def __init__(self, *args, **kwargs):
            pass

        def __enter__(self):
            raise OSError(5, "Input/output error")

        def __exit__(self, *exc):
            return False

    monkeypatch.setattr(bus, "ServoBus", Gone)
    code, out, err = _main(capsys, "move", "--arm", ARM3R, "--device", "/dev/ttyGONE", *MOVE)
    assert code == 4 and out == ""
    assert err.strip() == ("robodcn: /dev/ttyGONE: the serial device failed (Input/output "
                           "error); check the cable and the adapter, then run the move again")
