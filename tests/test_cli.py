"""The robodcn command line, end to end in subprocesses (plan here; sim, move and serve in
test_cli_servos.py)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robodcn
from robodcn.cli import parse_pose
from robodcn.errors import InputError
from robodcn.planner import Trajectory

ROOT = Path(__file__).resolve().parent.parent
ARM3R = ROOT / "configs" / "arm3r.toml"
ARM2R = ROOT / "configs" / "arm2r.toml"


def run(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "robodcn", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=ROOT)


def test_plan_json_is_the_planners_trajectory():
    out = run("plan", "--arm", str(ARM3R), "--from", "0.25,0.10,0", "--via", "0.12,0.24,60",
              "--to", "-0.10,0.22,120", "--method", "kenlerp", "--beta", "0.5", "--format",
              "json")
    assert out.returncode == 0, out.stderr
    got = Trajectory.from_json(out.stdout)
    arm = robodcn.load_arm(ARM3R)
    want = robodcn.plan(arm, [[0.25, 0.10, 0.0], [0.12, 0.24, math.radians(60)],
                              [-0.10, 0.22, math.radians(120)]], method="kenlerp", beta=0.5)
    assert np.array_equal(got.ticks, want.ticks)
    assert np.allclose(got.poses, want.poses) and np.allclose(got.t, want.t)
    assert json.loads(out.stdout)["method"] == "kenlerp"


def test_plan_table_and_csv_have_one_row_per_sample(tmp_path):
    args = ("plan", "--arm", str(ARM2R), "--to", "0.2,0.1,0", "--rate", "50")
    table = run(*args)
    csv = run(*args, "--format", "csv", "--out", str(tmp_path / "plan.csv"))
    assert table.returncode == 0 and csv.returncode == 0, table.stderr + csv.stderr
    rows = [line for line in table.stdout.splitlines() if not line.startswith("#")]
    n = len((tmp_path / "plan.csv").read_text().strip().splitlines()) - 1  # header
    assert len(rows) - 1 == n > 1
    assert "wrote" in csv.stderr and csv.stdout == ""


def test_plan_radians_equals_degrees():
    deg = run("plan", "--arm", str(ARM3R), "--to", "0.12,0.24,60", "--format", "json")
    rad = run("plan", "--arm", str(ARM3R), "--to", f"0.12,0.24,{math.pi / 3!r}", "--radians",
              "--format", "json")
    assert deg.returncode == rad.returncode == 0
    assert json.loads(deg.stdout)["ticks"] == json.loads(rad.stdout)["ticks"]


def test_negative_coordinates_are_values_not_options():
    out = run("plan", "--arm", str(ARM3R), "--to", "-0.10,0.22,120", "--format", "json")
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["poses"][-1][0] == pytest.approx(-0.10)


@pytest.mark.parametrize("args, code, needle", [
    (("plan", "--to", "0.5,0.5,0"), 3, "--to"),                         # out of reach
    (("plan", "--to", "0.12,0.24,60", "--duration", "0.05"), 3, "lengthen"),
    (("plan", "--to", "0.12,0.24"), 2, "--to"),                         # not a pose
    (("plan", "--to", "0.12,0.24,60", "--method", "spline"), 2, "method"),
    (("plan", "--to", "0.12,0.24,60", "--duration", "soon"), 2, "--duration"),
    (("plan", "--to", "0.12,0.24,60", "--rate", "5000"), 2, "rate_hz"),
    (("plan",), 2, "--to"),                                              # argparse usage
    (("sim", "--to", "0.12,0.24,60", "--tracking-limit", "-1"), 2, "--tracking-limit"),
    (("sim", "--to", "0.12,0.24,60", "--feedback-every", "x"), 2, "--feedback-every"),
    (("plan", "--to", "0.12,0.24,60", "--arm", "nowhere.toml"), 2, "nowhere.toml"),
])
def test_exit_codes_and_messages(args, code, needle):
    out = run(*args[:1], "--arm", str(ARM3R), *args[1:]) if "--arm" not in args else run(*args)
    assert out.returncode == code, out.stderr
    assert needle in out.stderr
    assert "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) <= 3 or (code == 2 and "usage" in out.stderr)


def test_parse_pose():
    assert parse_pose("1,2,90", "--to") == pytest.approx((1.0, 2.0, math.pi / 2))
    assert parse_pose("1, 2, 0.5", "--to", radians=True) == (1.0, 2.0, 0.5)
    for bad in ("1,2", "1,2,3,4", "a,b,c", "1,nan,0", "1,inf,0"):
        with pytest.raises(InputError) as info:
            parse_pose(bad, "--via #2")
        assert info.value.field == "via #2"


def test_version_and_help():
    out = run("--version")
    assert out.returncode == 0 and robodcn.__version__ in out.stdout
    for command in ("plan", "move", "sim", "serve", "scan"):
        helped = run(command, "--help")
        assert helped.returncode == 0 and "usage: robodcn " + command in helped.stdout
