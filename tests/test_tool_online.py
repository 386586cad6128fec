"""Tool limits in flight (issue 30): the online laws of a move with ``tool_speed`` keep it —
a retarget (from the moving state), a speed change and a resume — and ``robodcn jog`` keeps
the tool at the reduced speed of hands-on work, 250 mm/s, unless told otherwise.

Virtual time on the simulated arm (tests/online_helpers.py): the commanded samples
(``Execution.sent``) are measured by the finite differences of their FK at the stream rate.
"""

from __future__ import annotations

import io
import math
import time

import numpy as np
import pytest
from conftest import ARM3R
from online_helpers import RATE, _check_limits, _move, _run_at, _run_steps, _sent, arm_at_start

from robodcn import kinematics
from robodcn.cli.jog_cmd import Jogger
from robodcn.simulated import simulated_arm

pytest_plugins = ["omx_helpers"]     # fixtures: held_omx

#: float noise of the finite differences at 1 kHz (m/s)
NOISE = 1e-6


@pytest.fixture
def sa():
    with arm_at_start() as s:
        yield s


def tool_speed(joints: np.ndarray, rate: float = RATE) -> np.ndarray:
    """The tool point's speed between the commanded samples (m/s)."""
    p = kinematics.fk(ARM3R.links, joints)[:, :2]
    return np.linalg.norm(np.diff(p, axis=0), axis=1) * rate


def test_a_retarget_keeps_the_moves_tool_speed(sa) -> None:
    traj = _move(sa, method="seplerp", tool_speed=0.1)
    report, ex, wire = _run_at(sa, traj, len(traj.t) // 3,
                               lambda ex: ex.retarget([None, (0.22, -0.05, 0.3)]))
    assert report.stop_reason == "completed", report.headline
    _, joints, _ = _sent(ex, wire)
    _check_limits(joints)
    speed = tool_speed(joints)
    assert speed.max() <= 0.1 + NOISE
    first = ex.switches[0][1]
    assert speed[first:].max() >= 0.09  # the new path runs at the limit, not below it


def test_a_retarget_told_another_tool_speed_keeps_that_one(sa) -> None:
    traj = _move(sa, method="seplerp", tool_speed=0.15)
    report, ex, wire = _run_at(sa, traj, len(traj.t) // 3,
                               lambda ex: ex.retarget([None, (0.22, -0.05, 0.3)],
                                                      tool_speed=0.05))
    assert report.stop_reason == "completed", report.headline
    _, joints, _ = _sent(ex, wire)
    speed = tool_speed(joints)
    first = ex.switches[0][1]
    assert speed[:first].max() <= 0.15 + NOISE
    # braking from 0.15 to 0.05 takes a moment: the law after it keeps 0.05
    tail = speed[first + int(0.5 * RATE):]
    assert tail.size and tail.max() <= 0.05 + NOISE


def test_a_speed_change_and_a_resume_keep_the_tool_limit(sa) -> None:
    traj = _move(sa, method="seplerp", tool_speed=0.1)
    n = len(traj.t)
    report, ex, wire = _run_steps(sa, traj, [(n // 5, lambda ex: ex.set_speed(0.5)),
                                             (n // 3, lambda ex: ex.set_speed(1.0))])
    assert report.stop_reason == "completed", report.headline
    _, joints, _ = _sent(ex, wire)
    assert tool_speed(joints).max() <= 0.1 + NOISE


class _Kept(Jogger):
    """A Jogger that keeps every execution it started (to read what it sent)."""

    def __init__(self, *args, **kw) -> None:
        super().__init__(*args, **kw)
        self.executions: list = []

    def go(self) -> None:
        before = self.execution
        super().go()
        if self.execution is not None and self.execution is not before:
            self.executions.append(self.execution)


@pytest.mark.parametrize("given", [None, 0.1])
def test_jog_keeps_the_reduced_speed_of_hands_on_work(given) -> None:
    from robodcn.contract import hands_on_speed

    limit = hands_on_speed(ARM3R) if given is None else given
    assert hands_on_speed(ARM3R) == 0.25
    with simulated_arm(ARM3R, timing="fast") as sim:
        jog = _Kept(ARM3R, sim.bus, step=0.05, step_rad=math.radians(5), method="sclerp",
                    rate_hz=200.0, out=io.StringIO(), tool_speed=limit)
        for key in ("right", "up", "left", "down"):  # each in flight of the one before
            jog.key(key)
            time.sleep(0.15)
        jog.finish()
    assert jog.executions
    for ex in jog.executions:
        assert ex.trajectory.request.tool_speed == limit
        index, _, joints = ex.sent()
        assert index.size > 10
        steps = np.diff(index)
        speed = tool_speed(joints, 200.0)[steps == 1]  # consecutive samples only
        assert speed.max() <= limit + NOISE


def test_jog_refuses_a_tool_speed_above_the_arms_ceiling(monkeypatch, capsys,
                                                        tmp_path) -> None:
    from pathlib import Path

    from workflow_helpers import ARM3R as ARM3R_PATH
    from workflow_helpers import run_cli

    from robodcn.config import load_arm
    from robodcn.contract import hands_on_speed

    path = tmp_path / "arm.toml"
    path.write_text(Path(ARM3R_PATH).read_text() + "\n[tool]\nmax_speed = 0.2\n")
    assert hands_on_speed(load_arm(path)) == 0.2  # the arm's own ceiling is lower
    assert run_cli(monkeypatch, ["jog", "--arm", str(path), "--sim",
                                 "--tool-speed", "0.3"]) == 2
    assert "--tool-speed 0.3 m/s is above the arm's [tool] max_speed" in capsys.readouterr().err


@pytest.mark.parametrize("given", [None, "0.1"])
def test_teach_lowers_the_arm_at_the_hands_on_speed(held_omx, monkeypatch, tmp_path,
                                                    given) -> None:
    """teach without --float on the omx (under gravity) lowers it to its rest pose before
    torque goes off: a motion beside the hand that will move the arm, at ≤ 250 mm/s."""
    from omx_helpers import OMX
    from workflow_helpers import run_cli

    from robodcn.workflow import release

    lowered = []
    execute = release.execute

    def recorded(trajectory, *args, **kw):
        lowered.append(trajectory)
        return execute(trajectory, *args, **kw)

    monkeypatch.setattr(release, "execute", recorded)
    argv = ["teach", "--arm", "omx", "--device", held_omx.port_path, "--out",
            str(tmp_path / "x.toml"), "--yes"] + ([] if given is None else
                                                  ["--tool-speed", given])
    run_cli(monkeypatch, argv, ["q"])     # nothing recorded: exit 2, after the lowering
    limit = 0.25 if given is None else float(given)
    assert len(lowered) == 1 and lowered[0].request.tool_speed == limit
    p = lowered[0].poses[:, :3]
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) * lowered[0].rate_hz
    assert speed.max() <= limit + NOISE
    # and it reached the rest pose it was lowered to
    rest = np.asarray(OMX.rest)
    assert np.allclose(lowered[0].poses[-1, :3], rest[:3], atol=1e-6)
