"""A rate so low that the goals step tens of degrees warns, once, naming the rate to use."""

from __future__ import annotations

import math

import numpy as np

from robodcn import cli
from robodcn.stream.rate import MAX_QUIET_STEP, check_steps


def test_check_steps_names_the_joint_the_sample_and_the_rate_that_would_do() -> None:
    q = np.zeros((4, 3))
    q[2, 1] = math.radians(20.0)                   # the elbow steps 20° into sample 2
    warning = check_steps(q, 10.0, ("shoulder", "elbow", "wrist"))
    assert warning is not None
    assert (warning.joint, warning.sample) == ("elbow", 2)
    assert warning.step_rad == math.radians(20.0)
    assert warning.suggested_rate_hz == 40           # 10 Hz × 20° / 5°
    assert "raise the rate to at least 40 Hz" in warning.message
    q[2, 1] = MAX_QUIET_STEP
    assert check_steps(q, 10.0, ("shoulder", "elbow", "wrist")) is None


def test_sim_at_one_hertz_warns_once(capsys) -> None:
    code = cli.main(["sim", "--arm", "arm3r", "--to", "0.12,0.24,60", "--rate", "1"])
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if "goals step up to" in line]
    assert len(lines) == 1, err
    assert lines[0].startswith("robodcn: warning: at 1 Hz the goals step up to")
    assert code in (0, 5)                            # it ran: a warning, not a refusal


def test_the_default_rate_does_not_warn(capsys) -> None:
    cli.main(["sim", "--arm", "arm3r", "--to", "0.12,0.24,60"])
    assert "goals step up to" not in capsys.readouterr().err
