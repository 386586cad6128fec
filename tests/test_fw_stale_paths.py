"""firmware_sim after ``kill -9``: its --link and --control paths are taken over on restart."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from firmware_sim.control_socket import take_over_stale_socket

ROOT = Path(__file__).resolve().parent.parent


def _start(link: Path, ctl: Path) -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-m", "firmware_sim", "--ids", "1",
                             "--link", str(link), "--control", str(ctl)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = proc.stdout.readline()
    if not first.startswith("/dev/"):
        proc.kill()
        _, err = proc.communicate(timeout=10)
        pytest.fail(f"firmware_sim did not start: {err}")
    return proc


def _answers(ctl: Path) -> str:
    with socket.socket(socket.AF_UNIX) as s:
        s.connect(str(ctl))
        f = s.makefile("rw")
        f.write("get 1\n")
        f.flush()
        return f.readline()


def test_a_killed_simulator_s_link_and_socket_are_taken_over(tmp_path):
    link, ctl = tmp_path / "ttyDXL", tmp_path / "ctl"
    first = _start(link, ctl)
    first.send_signal(signal.SIGKILL)
    first.communicate(timeout=10)
    assert os.path.islink(link) and ctl.exists()        # what kill -9 leaves behind
    # another process opens a pty now: the kernel hands it the dead one's number, so the
    # stale link leads to a live pty that is nobody's simulator
    other = os.openpty()
    second = _start(link, ctl)
    for fd in other:
        os.close(fd)
    try:
        assert _answers(ctl).startswith("ok")
        assert os.path.exists(link)                       # the new link leads to a live pty
    finally:
        second.terminate()
        _, err = second.communicate(timeout=10)
    assert second.returncode == 0, err
    assert not os.path.lexists(link) and not ctl.exists()


def test_a_running_simulator_s_paths_are_not_taken(tmp_path):
    link, ctl = tmp_path / "ttyDXL", tmp_path / "ctl"
    first = _start(link, ctl)
    try:
        out = subprocess.run([sys.executable, "-m", "firmware_sim", "--ids", "1",
                              "--link", str(link), "--control", str(ctl)], cwd=ROOT,
                             capture_output=True, text=True, timeout=20)
        assert out.returncode != 0
        assert str(link) in out.stderr
        assert _answers(ctl).startswith("ok")           # the first one still serves
    finally:
        first.terminate()
        first.communicate(timeout=10)


def test_a_path_that_is_not_a_socket_is_left_alone(tmp_path):
    path = tmp_path / "notes.txt"
    path.write_text("mine")
    take_over_stale_socket(str(path))
    assert path.read_text() == "mine"
