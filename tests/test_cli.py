"""The robodcn command line, end to end in subprocesses (plan here; sim, move and serve in
test_cli_servos.py)."""

from __future__ import annotations

import json
import logging
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robodcn
from robodcn import cli
from robodcn.cli import parse_pose
from robodcn.cli.exit_codes import EXIT_CODES, Exit
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
    (("plan", "--to", "0.12,0.24,60", "--rate", "5000"), 2, "--rate"),
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


# -- in-process: main(argv) with captured output -----------------------------------------------

def main(capsys, *args: str) -> tuple[int, str, str]:
    """``robodcn.cli.main(args)`` → (exit code, stdout, stderr); usage errors included."""
    try:
        code = cli.main(list(args))
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


PLAN = ("plan", "--arm", str(ARM3R), "--to", "0.12,0.24,60")


@pytest.mark.parametrize("make_bad, needle", [
    (lambda tmp: tmp / "missing" / "plan.json", "no such directory"),
    (lambda tmp: tmp, "is a directory"),
])
def test_bad_out_path_is_a_usage_error_before_planning(capsys, tmp_path, make_bad, needle):
    # --to out of reach: were the plan made first, this would be exit code 3.
    code, out, err = main(capsys, "plan", "--arm", str(ARM3R), "--to", "0.5,0.5,0", "--out",
                          str(make_bad(tmp_path)))
    assert code == 2, err
    assert needle in err and "--out" in err and len(err.strip().splitlines()) == 1
    assert out == ""


def test_unwritable_out_path_is_a_usage_error(capsys, tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        # root may write anywhere it has permission bits for; /proc/sys is mounted read-only.
        target = locked if not os.access(locked, os.W_OK) else Path("/proc/sys")
        assert not os.access(target, os.W_OK)
        code, _, err = main(capsys, *PLAN, "--out", str(target / "plan.json"))
    finally:
        locked.chmod(0o700)
    assert code == 2 and "not writable" in err and "--out" in err


def test_plan_into_a_closed_pipe_exits_quietly():
    proc = subprocess.Popen([sys.executable, "-m", "robodcn", *PLAN, "--rate", "1000",
                             "--duration", "5", "-q"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, cwd=ROOT)
    proc.stdout.read(100)  # like `| head -c 100`: read a little, then go away
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 0, err
    assert "Traceback" not in err and "BrokenPipe" not in err and err == ""


@pytest.mark.parametrize("flags, level", [((), logging.WARNING), (("-v",), logging.INFO),
                                          (("-vv",), logging.DEBUG),
                                          (("--log-level", "error"), logging.ERROR),
                                          (("-v", "--log-level", "CRITICAL"), logging.CRITICAL)])
def test_log_level_options_configure_logging(capsys, flags, level):
    code, _, _ = main(capsys, *PLAN, "-q", "--format", "json", *flags)
    assert code == 0
    logger = logging.getLogger("robodcn")
    assert logger.level == level
    logging.getLogger("robodcn.bus").warning("seen at %s", "WARNING")
    logging.getLogger("robodcn.bus").debug("seen at %s", "DEBUG")
    err = capsys.readouterr().err
    assert ("seen at WARNING" in err) == (level <= logging.WARNING)
    assert ("seen at DEBUG" in err) == (level <= logging.DEBUG)


def test_every_command_takes_the_logging_options():
    parser = cli.build_parser()
    commands = parser._subparsers._group_actions[0].choices
    for name, command in commands.items():
        options = {o for action in command._actions for o in action.option_strings}
        assert {"-v", "--verbose", "--log-level"} <= options, name


@pytest.mark.parametrize("args, needles, absent", [
    (("--rate", "5000"), ["--rate", "1..1000 Hz"], ["rate_hz"]),
    (("--method", "sclerp,dlb"), ["--method", "one per segment"], ["["]),
    (("--method", "spline"), ["--method", "'spline'", "sclerp, kenlerp"], ["[", "('"]),
    (("--turn", "left"), ["--turn", "shortest, ccw, cw"], ["["]),
    (("--via", "0.2,0.2", "--via", "0.6,0.0,0"), ["--via 1"], ["waypoints[1] is"]),
    (("--duration", "nan"), ["--duration"], []),
    (("--duration", "1e308"), ["--duration", "samples"], ["Overflow"]),
    (("--beta", "inf"), ["--beta"], []),
])
def test_messages_name_the_option_as_typed(capsys, args, needles, absent):
    code, _, err = main(capsys, *PLAN, *args)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1
    for needle in needles:
        assert needle in err
    for needle in absent:
        assert needle not in err


def test_waypoint_errors_name_the_via_option(capsys):
    code, _, err = main(capsys, *PLAN, "--via", "0.2,0.2,0", "--via", "0.6,0.0,0")
    assert code == 3 and "--via 2" in err and "out of reach" in err


def test_limit_errors_speak_degrees_per_second(capsys):
    code, _, err = main(capsys, *PLAN, "--duration", "0.05")
    assert code == 3, err
    assert "deg/s" in err and "rad/s" not in err and "--duration" in err


def test_beta_with_a_method_that_ignores_it_warns(capsys):
    code, _, err = main(capsys, *PLAN, "--beta", "0.5", "-q", "--format", "json")
    assert code == 0
    line, = err.strip().splitlines()  # the planner's BetaIgnoredWarning, once
    assert line.startswith("robodcn: warning: --beta") and "has no effect" in line
    assert "----" not in line
    code, _, err = main(capsys, *PLAN, "--beta", "0.5", "--method", "kenlerp", "-q",
                        "--format", "json")
    assert code == 0 and "warning" not in err


def test_position_only_arm_takes_x_y(capsys):
    code, out, err = main(capsys, "plan", "--arm", str(ARM2R), "--to", "0.2,0.1", "-q",
                          "--format", "json")
    assert code == 0, err
    assert json.loads(out)["poses"][-1][:2] == pytest.approx([0.2, 0.1])
    code, _, err = main(capsys, "plan", "--arm", str(ARM3R), "--to", "0.2,0.1", "-q")
    assert code == 2 and "--to must be a pose x,y,θ" in err


def test_elbow_is_passed_to_the_planner_when_given(capsys, monkeypatch):
    import robodcn.planner as planner

    seen: list[dict] = []
    real = planner.plan

    def plan(arm, waypoints, *, elbow=None, **kwargs):
        seen.append({"elbow": elbow, **kwargs})
        return real(arm, waypoints, **kwargs)

    monkeypatch.setattr(planner, "plan", plan)
    assert main(capsys, *PLAN, "--elbow", "down", "-q")[0] == 0
    assert main(capsys, *PLAN, "-q")[0] == 0
    assert [s["elbow"] for s in seen] == ["down", None]
    code, _, err = main(capsys, *PLAN, "--elbow", "sideways")
    assert code == 2 and "--elbow" in err


def test_planner_errors_are_described_by_robodcn_messages(capsys, monkeypatch):
    from robodcn import messages

    calls = []

    def describe(err, units="si", waypoint_names=None, field_names=None):
        calls.append(waypoint_names)
        return f"described in {units} units: {type(err).__name__}"

    monkeypatch.setattr(messages, "describe", describe)
    code, _, err = main(capsys, "plan", "--arm", str(ARM3R), "--via", "0.2,0.1,0", "--to",
                        "0.5,0.5,0")
    assert code == 3
    assert "described in cli units: UnreachableError" in err and "--to" in err
    assert calls == [["--from", "--via 1", "--to"]]   # the options, not waypoints[i]


def test_plan_prints_a_summary_first_unless_quiet(capsys):
    arm = robodcn.load_arm(ARM3R)
    code, out, err = main(capsys, *PLAN)
    assert code == 0 and out.startswith("# ")  # the table, on stdout
    lines = err.strip().splitlines()
    traj = robodcn.plan(arm, [arm.home, [0.12, 0.24, math.radians(60)]],
                        rate_hz=arm.bus.rate_hz)
    assert lines[0].startswith(f"plan: {traj.duration:.3f} s, {len(traj.t)} samples")
    for joint in arm.joints:
        row = next(line for line in lines if line.split()[0] == joint.name)
        assert "deg/s of" in row and "deg/s² of" in row and "%" in row
        assert f"{math.degrees(joint.max_velocity):.1f}" in row
    # No joint beyond its limit, and the auto timing drives at least one close to it.
    percents = [int(p) for p in re.findall(r"\(\s*(\d+)%\)", err)]
    assert percents and max(percents) <= 100 and max(percents) >= 50
    assert main(capsys, *PLAN, "--quiet")[2] == ""


def test_exit_code_table_is_the_documented_one():
    assert {int(c) for c in Exit} == set(EXIT_CODES) == {0, 1, 2, 3, 4, 5, 6, 130}


def test_every_run_outcome_has_its_exit_code():
    from types import SimpleNamespace

    from robodcn.cli.exit_codes import EXIT_BY_OUTCOME, exit_for_report
    from robodcn.stream import OUTCOMES

    assert set(EXIT_BY_OUTCOME) == set(OUTCOMES)
    assert exit_for_report(SimpleNamespace(outcome="collision")) == Exit.FAULT == 4
    assert "collision" in EXIT_CODES[Exit.FAULT]


def test_long_messages_are_cut_in_the_middle_keeping_what_is_wrong(capsys, tmp_path):
    big = "{" + ", ".join(f"k{i} = {i}" for i in range(200)) + "}"
    arm = tmp_path / "big.toml"
    arm.write_text(ARM3R.read_text().replace("[arm]\n", f"[arm]\nbogus = {big}\n", 1))
    code, _, err = main(capsys, "plan", "--arm", str(arm), "--to", "0.12,0.24,60")
    assert code == 2
    line, = err.strip().splitlines()
    assert len(line) <= len("robodcn: ") + 400
    assert "arm.bogus" in line
    assert line.endswith("unknown key (allowed: base_yaw, elbow, home, links, name, plane, "
                         "rest, shoulder_height)")


def test_errors_map_onto_the_table_never_1():
    from robodcn import errors
    from robodcn.cli.exit_codes import exit_for_error

    class ListenError(errors.RobodcnError):  # like the HTTP server's cannot-listen error
        exit_code = 6

    assert exit_for_error(ListenError("busy")) == Exit.CANNOT_SERVE == 6
    assert exit_for_error(errors.RobodcnError("unclassified")) == Exit.FAULT
    assert exit_for_error(errors.StoppedError("x")) == 130
    assert exit_for_error(errors.ConfigError("x", file="a.toml")) == 2


def test_serve_logs_at_info_by_default(capsys, monkeypatch):
    import importlib

    def serve(arm, **kwargs):
        logging.getLogger("robodcn.http").info("GET /healthz 200")
        logging.getLogger("robodcn.http").debug("detail")

    monkeypatch.setattr(importlib.import_module("robodcn.http"), "serve", serve)
    assert main(capsys, "serve", "--arm", str(ARM3R), "--sim", "--port", "0")[2] == \
        "robodcn: INFO: robodcn.http: GET /healthz 200\n"
    assert main(capsys, "serve", "--arm", str(ARM3R), "--sim", "--log-level", "warning")[2] == ""


def test_profile_choices_and_default_are_the_contracts():
    """--profile offers what the planner takes, the default its default (optimal)."""
    from robodcn import contract

    parser = cli.build_parser()
    for command in ("plan", "sim", "move"):
        args = parser.parse_args([command, "--to", "0.12,0.24,60"])
        assert args.profile == contract.field("profile").default == "optimal"
        for profile in contract.cli_choices("profile"):
            assert parser.parse_args([command, "--to", "0.12,0.24,60", "--profile",
                                      profile]).profile == profile


def test_a_tracking_stop_is_worded_in_degrees(capsys: pytest.CaptureFixture[str]) -> None:
    """The physics sim without compensation lags ~7° on a fast move: a 0.5° --tracking-limit
    stops it (exit 4), and the CLI words the stop in the config's degrees, not radians."""
    from robodcn import cli

    rc = cli.main(["sim", "--to", "0.12,0.24,60", "--compensation", "off",
                   "--tracking-limit", "0.5"])
    err = capsys.readouterr()
    text = err.out + err.err
    assert rc == 4, text
    line = next(ln for ln in text.splitlines() if "tracking error" in ln and "limit" in ln)
    assert "°" in line and "limit 0.50°" in line and " rad" not in line, line


# -- one argument vocabulary (issue 16) and the CLI items of issue 17 §4 -----------------------

def test_run_profile_takes_the_contracts_profiles_with_plans_default():
    from robodcn import contract

    parser = cli.build_parser()
    sub = parser._subparsers._group_actions[0].choices
    profile = {c: next(a for a in sub[c]._actions if "--profile" in a.option_strings)
               for c in ("plan", "run")}
    assert tuple(profile["run"].choices) == tuple(profile["plan"].choices) \
        == contract.cli_choices("profile")
    assert "optimal" in profile["run"].choices
    assert profile["plan"].default == contract.field("profile").default == "optimal"
    assert "optimal" in profile["run"].help     # run: the file's [plan], else plan's default
    assert parser.parse_args(["run", "x.toml", "--profile", "optimal"]).profile == "optimal"


def test_scan_takes_arm_and_config_is_a_deprecated_alias(capsys):
    parser = cli.build_parser()
    assert parser.parse_args(["scan", "--arm", "arm2r"]).arm == "arm2r"
    assert "deprecated" not in capsys.readouterr().err
    assert parser.parse_args(["scan", "--config", "arm2r"]).arm == "arm2r"
    err = capsys.readouterr().err
    assert "--config is deprecated, use --arm" in err and err.startswith("robodcn: warning:")
    # the arm's [bus] port is the device: a missing one is a bus fault naming it
    out = run("scan", "--arm", str(ARM3R), "--ids", "1")
    assert out.returncode == 4 and "/dev/ttyUSB0" in out.stderr, out.stderr
    out = run("scan", "--config", str(ARM3R), "--ids", "1")
    assert out.returncode == 4 and "deprecated, use --arm" in out.stderr, out.stderr


@pytest.mark.parametrize("argv, command, suggestion", [
    (["plan", "--to", "0.12,0.24,60", "--metod", "dlb"], "robodcn plan", "--method"),
    (["plan", "--to", "0.12,0.24,60", "--durration=2"], "robodcn plan", "--duration"),
    (["servo", "info", "--jsn"], "robodcn servo info", "--json"),
    (["scan", "--device", "/dev/null", "--al-bauds"], "robodcn scan", "--all-bauds"),
])
def test_a_typod_option_gets_did_you_mean_and_its_commands_usage(capsys, argv, command,
                                                                 suggestion):
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert exc.value.code == 2 and len(lines) == 1, err
    assert lines[0].startswith(f"{command}: unrecognized arguments"), err
    assert f"did you mean {suggestion}?" in err and f"see '{command} --help'" in err, err
    with pytest.raises(SystemExit):
        cli.main(["plan", "--to", "0.12,0.24,60", "--zzzzzz"])
    err = capsys.readouterr().err
    assert "did you mean" not in err and "see 'robodcn plan --help'" in err


def test_plan_csv_headers_carry_units(tmp_path):
    out = run("plan", "--arm", str(ARM3R), "--to", "0.12,0.24,60", "--rate", "50",
              "--format", "csv", "-q")
    assert out.returncode == 0, out.stderr
    rows = [line.split(",") for line in out.stdout.strip().splitlines()]
    assert rows[0] == ["t_s", "x_m", "y_m", "theta_rad", "q_shoulder_rad", "q_elbow_rad",
                       "q_wrist_rad", "tick_1", "tick_2", "tick_3"]
    traj = robodcn.plan(robodcn.load_arm(ARM3R), [[0.25, 0.10, 0.0],
                                                  [0.12, 0.24, math.radians(60)]], rate_hz=50)
    body = np.array(rows[1:], dtype=float)
    assert np.array_equal(body[:, 0], traj.t) and np.array_equal(body[:, 1:4], traj.poses)
    assert np.array_equal(body[:, 4:7], traj.joints) and np.array_equal(body[:, 7:], traj.ticks)
