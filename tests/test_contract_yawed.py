"""The plan request contract for an arm with a base yaw (issue 18 §1): waypoint rows of four
numbers (SI) with errors naming row and number, the schema specialised per arm, payload_kg,
and one waypoint meaning "from the start" (issue 17 §2)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import robodcn
from robodcn import contract, kinematics
from robodcn.errors import InputError
from robodcn.messages import describe
from robodcn.planner import PlanRequest, StartState

OMX = robodcn.load_arm("configs/omx.toml")
ARM3 = robodcn.load_arm("configs/arm3r.toml")
HOME = list(OMX.home)
G = [0.20, 0.10, 0.15, -0.5]


def test_four_number_rows_parse_in_si() -> None:
    req = contract.parse_request({"waypoints": [HOME, G]}, OMX)
    assert req.waypoints == (tuple(HOME), tuple(G))
    assert req.waypoints_array.shape == (2, 4)


@pytest.mark.parametrize(("row", "field", "words"), [
    ([0.2, 0.1, 0.15], "waypoints[1]", "[x, y, z, pitch]"),
    ([0.2, 0.1, 0.15, 0.0, 0.0], "waypoints[1]", "[x, y, z, pitch]"),
    ([0.2, 0.1, 0.15, True], "waypoints[1][3]", "must be a number"),
    ([0.2, 0.1, 1e9, 0.0], "waypoints[1][2]", "m, got"),
    ([0.2, 0.1, 0.15, 1e9], "waypoints[1][3]", "rad, got"),
    ({"x": 0.2}, "waypoints[1]", "an object"),
])
def test_a_bad_row_is_named_by_row_and_number(row, field: str, words: str) -> None:
    with pytest.raises(InputError) as info:
        contract.parse_request({"waypoints": [HOME, row]}, OMX)
    assert info.value.field == field and words in str(info.value)
    # the CLI names the option that gave the waypoint
    assert describe(info.value, "cli", ["--from", "--to"]).startswith("--to ")


def test_a_planar_row_count_is_unchanged() -> None:
    with pytest.raises(InputError) as info:
        contract.parse_request({"waypoints": [HOME, G]}, ARM3)
    assert info.value.field == "waypoints[0]" and "[x, y, θ]" in str(info.value)


def test_schema_specialised_per_arm() -> None:
    yawed = contract.request_schema(OMX)["properties"]
    row = yawed["waypoints"]["items"]
    assert row["minItems"] == row["maxItems"] == 4 and len(row["prefixItems"]) == 4
    assert "[x, y, z, pitch]" in yawed["waypoints"]["description"]
    assert yawed["start_joints"]["minItems"] == yawed["start_joints"]["maxItems"] == 4
    assert [p["maximum"] for p in yawed["start_joints"]["prefixItems"]] == \
        [j.max_angle for j in OMX.joints]
    planar = contract.request_schema(ARM3)["properties"]["waypoints"]["items"]
    assert planar["minItems"] == planar["maxItems"] == 3 and len(planar["prefixItems"]) == 3
    assert contract.request_schema()["properties"]["waypoints"]["items"]["maxItems"] == 4


def test_payload_kg_defaults_to_the_arms_and_is_checked() -> None:
    assert contract.DEFAULTS.payload_kg is None
    req = contract.parse_request({"waypoints": [HOME, G]}, OMX)
    assert req.payload_kg == OMX.payload_kg
    req = contract.parse_request({"waypoints": [HOME, G], "payload_kg": 0.4}, OMX)
    assert req.payload_kg == 0.4
    assert PlanRequest.from_dict(req.to_dict()).payload_kg == 0.4
    for bad in (-0.1, True, "1", 1e9):
        with pytest.raises(InputError) as info:
            contract.parse_request({"waypoints": [HOME, G], "payload_kg": bad}, OMX)
        assert info.value.field == "payload_kg"
    schema = contract.request_schema(OMX)["properties"]["payload_kg"]
    assert schema["minimum"] == 0.0 and schema["default"] == OMX.payload_kg
    assert "kg" in schema["description"]


def test_one_waypoint_needs_a_start() -> None:
    with pytest.raises(InputError) as info:
        contract.parse_request({"waypoints": [G]}, OMX)
    assert info.value.field == "waypoints" and "start_joints" in str(info.value)
    q = kinematics.ik_yawed(OMX.chain, np.array([HOME]))[0]
    req = contract.parse_request({"waypoints": [G], "start_joints": q.tolist()}, OMX)
    assert req.segments == 1 and len(req.waypoints) == 1
    # a move body gives no start: the service fills in the present joints
    with pytest.raises(InputError):
        contract.parse_request({"waypoints": [G]}, OMX, omit=contract.MOVE_OMIT)
    req = contract.parse_request({"waypoints": [G]}, OMX, omit=contract.MOVE_OMIT,
                                 start_joints=q)
    assert req.start_joints == tuple(q)
    state = PlanRequest(arm=OMX, waypoints=[G], start_state=StartState(q))
    assert state.segments == 1
    # a bad value elsewhere is named first: the count is a cross-field rule, checked last
    with pytest.raises(InputError) as info:
        contract.parse_request({"waypoints": [G], "rate_hz": 0}, OMX)
    assert info.value.field == "rate_hz"


def test_one_waypoint_plans_from_the_start_on_a_planar_arm() -> None:
    q = kinematics.ik(ARM3.links, np.array([ARM3.home]))[0]
    goal = [ARM3.home[0] - 0.05, ARM3.home[1] + 0.05, ARM3.home[2] + 0.3]
    for profile in ("optimal", "quintic"):
        t = robodcn.plan(ARM3, [goal], start_joints=q, profile=profile)
        assert t.approach_samples == 0
        assert np.abs(t.poses[0] - ARM3.home).max() < 1e-12
        assert np.abs(t.poses[-1] - goal).max() < 1e-9
    with pytest.raises(InputError) as info:
        robodcn.plan(ARM3, [goal])
    assert info.value.field == "waypoints"


def test_a_2link_yawed_row_may_leave_pitch_out() -> None:
    # the contract's rule for a pitch-free chain, on a copy of the omx with two links
    data = OMX.to_dict()
    data["arm"]["links"] = data["arm"]["links"][:2]
    data["joints"] = data["joints"][:3]
    data["arm"]["home"] = {"x": 0.15, "y": 0.0, "z": 0.2}
    data.pop("dynamics", None)
    arm = robodcn.config.arm_from_dict(data, source="<test>")
    req = contract.parse_request({"waypoints": [[0.15, 0.0, 0.2], [0.1, 0.1, 0.2, 0.3]]}, arm)
    assert req.waypoints[0] == (0.15, 0.0, 0.2, 0.0)
    assert contract.request_schema(arm)["properties"]["waypoints"]["items"]["minItems"] == 3
    assert math.isclose(req.waypoints[1][3], 0.3)
