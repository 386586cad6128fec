"""``robodcn follow`` from a pipe: the real command in a subprocess (``python -m robodcn``)
on a simulated arm (firmware_sim over a pty through dynamixel-sdk), targets written to its
stdin at their own pace."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
from conftest import ARM3R, ROOT


def _command(*extra: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "robodcn", "follow", "--sim", "--timing",
                             "fast", "--dynamics", "off", "--rate", "100", "--arm",
                             str(ARM3R.source), *extra],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)


def _home() -> np.ndarray:
    from robodcn import kinematics
    return kinematics.ik(ARM3R.links, np.array([ARM3R.home]), ARM3R.elbow)[0]


def _ended_at_rest(proc: subprocess.Popen, err: str) -> None:
    """Exit 0: at rest on the last target (5, degraded, only where the loaded host made the
    loop skip samples: the summary says so)."""
    summary = err.strip().splitlines()[-1]
    assert proc.returncode == 0 or (proc.returncode == 5 and "skipped" in summary), err


def test_targets_from_a_pipe_then_eof_rest_at_the_last_and_exit_0():
    home = _home()
    proc = _command()
    lines = [json.dumps({"joints": list(home + 0.01 * k)}) for k in range(1, 21)]
    lines.insert(5, "not json")
    lines.insert(9, json.dumps({"joints": [9.0, 0.0, 0.0]}))
    lines.insert(12, json.dumps({"joints": list(home), "speed": 2}))
    for line in lines:
        proc.stdin.write(line + "\n")
        proc.stdin.flush()
        time.sleep(1 / 30)
    _out, err = proc.communicate(timeout=60)
    _ended_at_rest(proc, err)
    bad = [ln for ln in err.splitlines() if ln.startswith("robodcn: line ")]
    assert bad[0].startswith("robodcn: line 6: line: not JSON"), bad
    assert bad[1].startswith("robodcn: line 10: joints: joints: joint 'shoulder'"), bad
    assert bad[2].startswith("robodcn: line 13: speed: unknown field"), bad
    summary = err.strip().splitlines()[-1]
    assert summary.startswith("follow: 20 target(s) taken, 3 refused"), summary


def test_ctrl_c_stops_smoothly_and_exits_130():
    home = _home()
    proc = _command()
    proc.stdin.write(json.dumps({"joints": list(home + np.array([0.8, -0.6, 0.8]))}) + "\n")
    proc.stdin.flush()
    assert proc.stderr.readline().startswith("follow: ")      # the session is open
    time.sleep(0.3)                                            # the arm on its way
    proc.send_signal(signal.SIGINT)
    _out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    summary = err.strip().splitlines()[-1]
    assert summary == "follow: 1 target(s) taken, 0 refused; stopped by Ctrl-C", summary


def test_a_pose_stream_and_a_bad_pose():
    from robodcn import kinematics
    start = kinematics.fk(ARM3R.links, _home()[None])[0]
    proc = _command("--space", "pose")
    for k in range(10):
        pose = list(start + np.array([0.002 * k, 0.0, 0.0]))
        proc.stdin.write(json.dumps({"pose": pose}) + "\n")
        proc.stdin.flush()
        time.sleep(1 / 30)
    proc.stdin.write(json.dumps({"pose": [3.0, 0.0, 0.0]}) + "\n")
    _out, err = proc.communicate(timeout=60)
    _ended_at_rest(proc, err)
    assert "robodcn: line 11: pose: pose (x=3" in err
    assert err.strip().splitlines()[-1].startswith("follow: 10 target(s) taken, 1 refused")
