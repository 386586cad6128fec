"""A hands-on command on a bus that lacks one of the arm's servos names it by its joint, and
a PING looking for a free id is not a warning."""

from __future__ import annotations

import pytest

from firmware_sim.bus import SimBus
from robodcn import cli
from robodcn.cli.exit_codes import Exit


@pytest.fixture
def two_servos():
    with SimBus([1, 2], timing="fast") as sim:
        yield sim


@pytest.mark.parametrize("argv", [["torque", "off", "--joint", "wrist"],
                                  ["reboot", "--joint", "wrist"]])
def test_a_silent_servo_is_named_by_its_joint(two_servos, capsys, argv) -> None:
    before = [two_servos.servo(i).torque_enabled for i in (1, 2)]
    code = cli.main([*argv, "--device", two_servos.port_path])
    err = capsys.readouterr().err
    assert code == Exit.FAULT                                  # a bus error (README's table)
    assert "joint 'wrist' (servo 3) does not answer" in err, err
    assert "give your arm file with --arm" in err
    assert "TxRxResult" not in err and "WARNING" not in err, err
    assert [two_servos.servo(i).torque_enabled for i in (1, 2)] == before  # nothing written
    assert not any(two_servos.goal_history(i) for i in (1, 2))


def test_set_id_s_free_id_check_logs_no_warning(two_servos, capsys) -> None:
    assert cli.main(["servo", "set-id", "1", "4", "--device", two_servos.port_path,
                     "--yes"]) == 0
    err = capsys.readouterr()
    assert "is now id 4" in err.out
    assert "WARNING" not in err.err and "ping failed" not in err.err, err.err
