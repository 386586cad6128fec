"""The gripper as the surfaces show it: its width and whether it holds an object in the
state (HTTP, ``robodcn pose``), and a width typed in metres named as such."""

from __future__ import annotations

from http_helpers import call, serving_arm

from robodcn import cli
from robodcn.config import load_arm
from robodcn.workflow import resolve_arm


def test_a_width_typed_in_metres_is_echoed_and_converted(capsys) -> None:
    code = cli.main(["gripper", "0.04", "--arm", "omx", "--sim"])
    err = capsys.readouterr().err
    assert code == 2
    assert "WIDTH_MM 0.04 mm is outside the gripper's stroke" in err
    assert "in metres that is 40 mm: type 40" in err


def test_get_state_has_the_jaw_width_on_an_arm_with_a_gripper() -> None:
    omx = load_arm(resolve_arm("omx").source)
    with serving_arm(omx) as (server, _):
        status, _, state = call(server, "GET", "/v1/state")
        assert status == 200, state
        assert state["holding"] is False
        low, high = sorted((omx.gripper.closed_width, omx.gripper.open_width))
        assert low - 1e-3 <= state["gripper_width_m"] <= high + 1e-3
    with serving_arm() as (server, _):               # arm3r: no gripper
        _, _, state = call(server, "GET", "/v1/state")
        assert state["gripper_width_m"] is None and state["holding"] is None
