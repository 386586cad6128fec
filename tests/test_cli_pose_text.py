"""What a user types for a pose: the arm's poses by name, angles beyond a turn, typos of --to."""

from __future__ import annotations

import json
import math

import pytest

from robodcn import cli
from robodcn.workflow import resolve_arm

ARMS = ("arm3r", "omx")


def _plan_json(capsys, *argv: str) -> tuple[dict, str]:
    assert cli.main(["plan", *argv, "--format", "json", "-q"]) == 0
    out = capsys.readouterr()
    return json.loads(out.out), out.err


@pytest.mark.parametrize("name", ARMS)
def test_to_home_ends_at_the_arm_files_home_pose(capsys, name: str) -> None:
    arm = resolve_arm(name)
    plan, _ = _plan_json(capsys, "--arm", name, "--from", _typed(arm, arm.home, 0.01),
                         "--to", "home")
    assert plan["poses"][-1] == pytest.approx(list(arm.home), abs=1e-9)


def _typed(arm, pose, nudge: float) -> str:
    """``pose`` as the user types it (degrees), its first coordinate moved by ``nudge`` m."""
    values = [pose[0] + nudge, *pose[1:-1], math.degrees(pose[-1])]
    return ",".join(f"{v:.9g}" for v in values)


def test_a_named_pose_the_arm_lacks_says_so(capsys) -> None:
    arm = resolve_arm("arm3r")
    assert arm.rest is None
    assert cli.main(["plan", "--arm", "arm3r", "--to", "rest"]) != 0
    err = capsys.readouterr().err
    assert "--to rest" in err and "[arm.rest]" in err


def test_a_word_that_is_no_pose_lists_the_names(capsys) -> None:
    assert cli.main(["plan", "--arm", "arm3r", "--to", "hme"]) != 0
    assert "home, rest" in capsys.readouterr().err


def test_an_angle_beyond_a_turn_warns_with_the_angle_taken(capsys) -> None:
    _, err = _plan_json(capsys, "--arm", "arm3r", "--to", "0.12,0.24,420")
    assert "warning: --to: the angle 420°, beyond a full turn" in err and "of 60°" in err
    _, err = _plan_json(capsys, "--arm", "arm3r", "--to", "0.12,0.24,7", "--radians")
    assert "7 rad is 401.07°" in err and "drop --radians" in err
    _, err = _plan_json(capsys, "--arm", "arm3r", "--to", "0.12,0.24,270")
    assert "warning" not in err                         # within a turn: a legitimate -90°


def test_a_typo_of_a_required_option_is_named_with_its_fix(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        cli.main(["plan", "--arm", "arm3r", "--too", "0.12,0.24,60"])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert "unrecognized arguments: --too; did you mean --to?" in err, err


def test_an_angle_out_of_range_is_said_in_degrees(capsys) -> None:
    assert cli.main(["plan", "--arm", "arm3r", "--to", "0.2,0.1,1e6"]) != 0
    err = capsys.readouterr().err
    assert "--to must be within -57295.8°..57295.8°, got 1000000.0°" in err, err
    assert "rad" not in err and "warning" not in err


def test_start_joints_outside_a_joint_s_limits_in_degrees_one_quote() -> None:
    from robodcn.contract.checks import check_start_joints
    from robodcn.errors import InputError
    from robodcn.messages import describe

    arm = resolve_arm("omx")
    elbow = arm.joints[2]
    joints = [0.0, 0.0, elbow.max_angle + math.radians(3.0), 0.0]
    with pytest.raises(InputError) as exc:
        check_start_joints(joints, arm)
    cli_text = describe(exc.value, units="cli")
    assert cli_text == (f"start_joints[2] = {math.degrees(joints[2]):.1f}° is outside the limits "
                        f"of joint {elbow.name!r}, {math.degrees(elbow.min_angle):.1f}°.."
                        f"{math.degrees(elbow.max_angle):.1f}°")
    assert "''" not in cli_text
    assert "rad" in describe(exc.value, units="si")


def test_no_negative_zero_degrees() -> None:
    from robodcn.messages import quantity

    assert quantity(-1e-4, "rad", "cli") == "0.0°"
    assert quantity(-0.02, "rad", "cli") == "-1.1°"


def test_options_are_never_abbreviated(capsys) -> None:
    """--to is a prefix of --tool-speed: a prefix is a guess on a command that moves an arm."""
    with pytest.raises(SystemExit):
        cli.main(["plan", "--arm", "arm3r", "--to", "0.12,0.24,60", "--rat", "50"])
    err = capsys.readouterr().err
    assert "unrecognized arguments: --rat 50; did you mean --rate?" in err, err
