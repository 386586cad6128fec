"""``robodcn jog`` (issue 10 §2): keys → retargets, against firmware_sim over a pty through
the real dynamixel-sdk; and the command itself on a pseudo-terminal."""

from __future__ import annotations

import io
import math
import os
import pty
import select
import subprocess
import sys
import time

import numpy as np
from conftest import ARM3R

from robodcn import kinematics, servo_units
from robodcn.cli.jog_cmd import Jogger
from robodcn.simulated import simulated_arm


def _pose(sa) -> np.ndarray:
    ticks = [sa.sim.servo(i).present_position for i in ARM3R.servo_ids]
    q = servo_units.ticks_to_radians(np.array([ticks]), ARM3R.servos)
    return kinematics.fk(ARM3R.links, q)[0]


class Script:
    """A key source: each key after its delay (s), then None; 'q' at the end."""

    def __init__(self, keys):
        self.keys = list(keys)
        self.next_at = time.monotonic()

    def __call__(self, timeout):
        if not self.keys:
            time.sleep(timeout)
            return None
        delay, key = self.keys[0]
        if time.monotonic() < self.next_at + delay:
            time.sleep(timeout)
            return None
        self.keys.pop(0)
        self.next_at = time.monotonic()
        return key


def test_key_presses_retarget_in_flight_and_end_at_the_stepped_pose():
    with simulated_arm(ARM3R, timing="fast") as sa:
        start = _pose(sa)
        out = io.StringIO()
        jog = Jogger(ARM3R, sa.bus, step=0.01, step_rad=math.radians(5), method="sclerp",
                     rate_hz=200.0, out=out)
        # presses in quick succession: they come while the previous step still moves
        script = Script([(0.0, "right"), (0.0, "right"), (0.0, "up"), (0.0, "a"),
                         (0.0, "x"), (2.0, "q")])
        jog.run(script)
        end = _pose(sa)
        want = start + np.array([0.02, 0.01, math.radians(5)])
        assert np.allclose(end[:2], want[:2], atol=2e-3), (end, want)
        assert abs(kinematics.wrap(end[2] - want[2])) < 5e-3
        text = out.getvalue()
        assert "←/→ x" in text and "tracking" in text and "target x=" in text
        # retargeted in flight (not a stop and a new move per key)
        assert jog.retargets >= 1 and len(jog.reports) + jog.retargets == 4
        assert all(r.outcome in ("done", "degraded") for r in jog.reports)


def test_an_unreachable_step_is_refused_and_the_target_stays():
    with simulated_arm(ARM3R, timing="fast") as sa:
        jog = Jogger(ARM3R, sa.bus, step=5.0, step_rad=0.1, method="sclerp", rate_hz=100.0,
                     out=io.StringIO())
        before = jog.target.copy()
        jog.key("right")
        assert np.array_equal(jog.target, before)
        assert "reach" in jog.message or "workspace" in jog.message, jog.message
        jog.key("q")
        jog.finish()


class _Terminal:
    """A robodcn command on a pseudo-terminal: what it printed so far, keys typed into it."""

    def __init__(self, *args: str) -> None:
        self.master, slave = pty.openpty()
        self.proc = subprocess.Popen([sys.executable, "-m", "robodcn", *args], stdin=slave,
                                     stdout=slave, stderr=slave, close_fds=True)
        os.close(slave)
        self.seen = b""

    def read_for(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            ready, _, _ = select.select([self.master], [], [], 0.05)
            if ready:
                try:
                    self.seen += os.read(self.master, 65536)
                except OSError:
                    return

    def wait_for(self, text: bytes, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while text not in self.seen and time.monotonic() < deadline:
            self.read_for(0.2)
        assert text in self.seen, self.seen

    def type(self, keys: bytes) -> None:
        os.write(self.master, keys)

    def close(self) -> str:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        os.close(self.master)
        return self.seen.decode("utf-8", "replace")


def test_jog_command_on_a_pseudo_terminal():
    """The real command: keys through a pty (arrow escape sequences), q quits, exit 0."""
    term = _Terminal("jog", "--sim", "--timing", "fast", "--rate", "100")
    try:
        term.read_for(0.1)
        term.wait_for(b"keys:")
        term.type(b"\x1b[C")  # right arrow
        term.read_for(1.5)
        term.type(b"q")
        term.read_for(1.0)
        assert term.proc.wait(30) == 0, term.seen
    finally:
        text = term.close()
    assert "target x=" in text and "commanded" in text


def test_sim_on_a_terminal_shows_the_keys_and_pauses_and_resumes():
    """``robodcn sim`` on a pty: the keys line, space pauses and resumes, it ends."""
    term = _Terminal("sim", "--to", "0.12,0.24,60", "--duration", "2", "--timing", "fast")
    try:
        term.wait_for(b"keys:")
        term.read_for(0.3)
        term.type(b" ")
        term.read_for(0.8)
        term.type(b" ")
        code = None
        deadline = time.monotonic() + 30
        while code is None and time.monotonic() < deadline:
            term.read_for(0.2)
            code = term.proc.poll()
        assert code in (0, 5), term.seen
    finally:
        text = term.close()
    assert "paused" in text and "resumed" in text, text
    assert "space pause/resume" in text


def test_ctrl_c_exits_130_with_a_closing_summary(capsys):
    """Ctrl-C (the key in raw mode) ends jog like sim and move: exit 130, and a summary."""
    from robodcn.cli import build_parser
    from robodcn.cli.jog_cmd import run_jog

    args = build_parser().parse_args(["jog", "--sim", "--timing", "fast", "--rate", "100",
                                      "--arm", str(ARM3R.source)])
    code = run_jog(args, Script([(0.0, "right"), (0.5, "\x03")]))
    err = capsys.readouterr().err
    assert code == 130, err
    summary = err.strip().splitlines()[-1]
    assert summary.startswith("jog: 1 move(s), 0 retarget(s)") and "ended at x=+0.2" in summary
    assert summary.endswith("stopped by Ctrl-C"), summary
    code = run_jog(args, Script([(0.0, "q")]))            # q: a plain end, exit 0
    summary = capsys.readouterr().err.strip().splitlines()[-1]
    assert code == 0 and summary.startswith("jog: 0 move(s)") and "Ctrl-C" not in summary


def test_a_yawed_arm_jogs_x_y_z_and_pitch():
    from conftest import CONFIGS

    from robodcn.cli.jog_cmd import YAWED_JOG_KEYS, jog_keys
    from robodcn.config import load_arm

    omx = load_arm(CONFIGS / "omx.toml")
    assert jog_keys(omx) == YAWED_JOG_KEYS and set(jog_keys(ARM3R)) == {
        "right", "left", "up", "down", "a", "d"}
    with simulated_arm(omx, timing="fast") as sa:
        def pose():
            ticks = [sa.sim.servo(i).present_position for i in omx.servo_ids]
            q = servo_units.ticks_to_radians(np.array([ticks]), omx.servos)
            return kinematics.fk_yawed(omx.chain, q)[0]

        start = pose()
        out = io.StringIO()
        jog = Jogger(omx, sa.bus, step=0.01, step_rad=math.radians(5), method="sclerp",
                     rate_hz=100.0, out=out)
        script = Script([(0.0, "right"), (0.0, "up"), (0.0, "s"), (0.0, "s"), (0.0, "d"),
                         (2.5, "q")])
        jog.run(script)
        end = pose()
        want = start + np.array([0.01, 0.01, -0.02, -math.radians(5)])
        assert np.allclose(end[:3], want[:3], atol=3e-3), (end, want)
        assert abs(end[3] - want[3]) < math.radians(1.0)
        text = out.getvalue()
        assert "w/s z" in text and "a/d pitch" in text and "z=" in text and "pitch=" in text
        assert "ended at x=" in jog.summary() and "pitch=" in jog.summary()
        assert all(r.outcome in ("done", "degraded") for r in jog.reports)
