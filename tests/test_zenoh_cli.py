"""``robodcn serve --sim --zenoh`` and ``robodcn fleet`` as the user runs them: processes on
loopback (explicit 127.0.0.1 endpoints, no scouting), a clean exit on SIGINT."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import pytest
from conftest import ROOT
from zenoh_helpers import free_port


def _robodcn(*args: str, **kw) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "robodcn", *args], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)


def _run(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "robodcn", *args], env=env, text=True,
                          capture_output=True, timeout=60)


def test_serve_zenoh_then_fleet_ls_and_state() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    serve = _robodcn("serve", "--sim", "--port", "0", "--zenoh", "--zenoh-listen", endpoint,
                     "--zenoh-connect", endpoint, "--name", "bench1")
    try:
        first = serve.stdout.readline()
        assert "robodcn/bench1" in first, first + serve.stderr.read()
        assert serve.stdout.readline().startswith("robodcn: serving")
        ls = _run("fleet", "ls", "--zenoh-connect", endpoint)
        assert ls.returncode == 0, ls.stderr
        name, _host, motion, pose = ls.stdout.strip().split("\t")
        assert (name, motion) == ("bench1", "at rest") and pose.startswith("pose [")
        state = _run("fleet", "state", "bench1", "--count", "2", "--zenoh-connect", endpoint)
        assert state.returncode == 0, state.stderr
        lines = [json.loads(line) for line in state.stdout.splitlines()]
        assert len(lines) == 2 and {line["arm"] for line in lines} == {"bench1"}
        assert all(len(line["joints"]) == 3 for line in lines)
        missing = _run("fleet", "state", "nobody", "--count", "1", "--zenoh-connect", endpoint)
        assert missing.returncode == 2 and "'nobody' is not live" in missing.stderr
        serve.send_signal(signal.SIGINT)
        assert serve.wait(15) == 0, serve.stderr.read()
    finally:
        if serve.poll() is None:
            serve.kill()
            serve.wait()


@pytest.mark.parametrize("args, field", [
    (["--zenoh-listen", "tcp/0.0.0.0:7447", "--zenoh"], "--zenoh-listen"),
    (["--zenoh-connect", "tcp/127.0.0.1:7447"], "--zenoh-connect"),
    (["--zenoh", "--name", "a b"], "--name"),
    (["--ros2", "--plan-only"], "--ros2"),
])
def test_serve_zenoh_usage_errors(args: list[str], field: str) -> None:
    out = _run("serve", *([] if "--plan-only" in args else ["--sim"]), "--port", "0", *args)
    assert out.returncode == 2, out.stdout + out.stderr
    assert field in out.stderr


def test_fleet_ls_with_no_arm_says_so() -> None:
    out = _run("fleet", "ls", "--zenoh-connect", f"tcp/127.0.0.1:{free_port()}",
               "--timeout", "0.5")
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "no arm is live on this Zenoh network"
