"""The request contract: the schema and the parser agree, errors name the JSON field."""

from __future__ import annotations

import json
import math
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robodcn import contract, load_arm
from robodcn.errors import InputError, TooLargeError, Violation
from robodcn.planner import PlanRequest

ARM = load_arm("configs/arm3r.toml")
ARM2 = load_arm("configs/arm2r.toml")
HOME = list(ARM.home)


def body(**kw: Any) -> dict[str, Any]:
    return {"waypoints": [HOME, [0.2, 0.1, 0.3]], **kw}


@pytest.mark.parametrize(("patch", "field", "cls"), [
    ({"duration": 1e308}, "duration", InputError),
    ({"duration": 900_000.0, "rate_hz": 1000}, "duration", TooLargeError),
    ({"beta": int("1" + "0" * 400)}, "beta", InputError),
    ({"beta": True}, "beta", InputError),
    ({"beta": -0.5}, "beta", InputError),
    ({"rate_hz": math.inf}, "rate_hz", InputError),
    ({"start_joints": [1e308, 0.0, 0.0]}, "start_joints[0]", InputError),
    ({"start_joints": [0.0, 3.0, 0.0]}, "start_joints[1]", InputError),
    ({"start_joints": [0.0, True, 0.0]}, "start_joints[1]", InputError),
    ({"waypoints": [HOME, [0.2, "x", 0.0]]}, "waypoints[1][1]", InputError),
    ({"waypoints": [HOME, [0.2, 0.1, 0.0], [0.2, 0.1]]}, "waypoints[2]", InputError),
    ({"waypoints": [HOME] * (contract.MAX_WAYPOINTS + 1)}, "waypoints", TooLargeError),
    ({"elbow": "sideways"}, "elbow", InputError),
    ({"method": ["sclerp", "lerp"], "waypoints": [HOME, HOME, HOME]}, "method[1]", InputError),
    ({"colour": "red"}, "colour", InputError),
])
def test_bad_bodies_name_the_json_field(patch: dict[str, Any], field: str, cls: type) -> None:
    with pytest.raises(cls) as info:
        contract.parse_request(body(**patch), ARM)
    assert info.value.field == field, info.value
    assert "[" not in info.value.message.split(" ", 1)[1][:1]  # no Python list repr first
    assert len(info.value.message) < 200


def test_move_bodies_omit_start_joints() -> None:
    with pytest.raises(InputError) as info:
        contract.parse_request(body(start_joints=[0.0, 0.0, 0.0]), ARM,
                               omit=contract.MOVE_OMIT)
    assert info.value.field == "start_joints"
    assert "start_joints" not in contract.request_schema(omit=contract.MOVE_OMIT)["properties"]


def test_defaults_and_new_fields() -> None:
    req = contract.parse_request(body(elbow="down"), ARM)
    assert req.rate_hz == ARM.bus.rate_hz and req.elbow == "down" and req.branch == "down"
    assert contract.parse_request(body(), ARM).elbow is None


def test_cli_choices_come_from_the_schema() -> None:
    assert contract.cli_choices("method") == ("sclerp", "kenlerp", "seplerp", "dlb")
    assert contract.cli_choices("turn") == ("shortest", "ccw", "cw")
    assert contract.cli_choices("profile") == ("optimal", "linear", "quintic", "trapezoid")
    assert contract.field("profile").default == "optimal"
    assert contract.cli_choices("elbow") == ("up", "down")
    assert contract.field("rate_hz").cli_option == "--rate"
    assert contract.cli_option("waypoints[2]") == "--from/--via/--to"


def test_request_schema_is_json_and_names_every_field() -> None:
    schema = contract.request_schema(ARM)
    json.dumps(schema)
    assert set(schema["properties"]) == {f.name for f in contract.FIELDS}
    assert schema["additionalProperties"] is False and schema["required"] == ["waypoints"]
    assert schema["properties"]["rate_hz"]["default"] == ARM.bus.rate_hz
    assert schema["properties"]["start_joints"]["maxItems"] == ARM.dof


def test_schema_of_a_result_dataclass() -> None:
    schema = contract.schema_of(Violation)
    props = schema["properties"]
    assert props["quantity"]["enum"] == ["reach", "position", "velocity", "acceleration",
                                         "jerk", "ticks", "torque", "tool_speed",
                                         "tool_angular_speed", "tool_acceleration", "keepout"]
    # x, y, θ, or a yawed arm's x, y, z, pitch
    assert props["pose"]["items"] == {"type": "number"}
    assert (props["pose"]["minItems"], props["pose"]["maxItems"]) == (3, 4)
    assert props["joint"]["type"] == ["string", "null"]
    assert "description" in props["sample"]
    assert set(schema["required"]) == {"sample", "t", "pose", "quantity", "value", "limit",
                                       "unit"}


def test_from_dict_round_trip_delegates_to_the_parser() -> None:
    req = PlanRequest(ARM, [HOME, [0.2, 0.1, 0.3]], elbow="up", duration=2.0)
    assert PlanRequest.from_dict(req.to_dict()) == req


# -- schema ↔ parser: bodies drawn from the schema --------------------------------------------

def from_schema(schema: dict[str, Any]) -> st.SearchStrategy[Any]:
    """Values valid per ``schema`` (the subset of JSON Schema the contract uses)."""
    if "oneOf" in schema:
        return st.one_of([from_schema(s) for s in schema["oneOf"]])
    types = schema.get("type")
    if isinstance(types, list):
        return st.one_of([from_schema({**schema, "type": t}) for t in types])
    if "enum" in schema:
        return st.sampled_from([v for v in schema["enum"]
                                if types is None or v is not None or types == "null"])
    if types == "null":
        return st.none()
    if types == "boolean":
        return st.booleans()
    if types == "string":
        return st.text(max_size=5)
    if types == "number":
        lo = schema.get("minimum", schema.get("exclusiveMinimum", -1e6))
        hi = schema.get("maximum", 1e6)
        return st.floats(lo, hi, exclude_min="exclusiveMinimum" in schema, allow_nan=False)
    if types == "array":
        prefix = schema.get("prefixItems")
        lo, hi = schema.get("minItems", 0), min(schema.get("maxItems", 4), 4)
        if prefix:
            rest = schema.get("items")
            def build(n: int) -> st.SearchStrategy[list[Any]]:
                parts = [from_schema(prefix[i]) if i < len(prefix) else from_schema(rest)
                         for i in range(n)]
                return st.tuples(*parts).map(list)
            return st.integers(lo, hi).flatmap(build)
        return st.lists(from_schema(schema.get("items", {})), min_size=lo, max_size=hi)
    if types == "object":
        props = schema["properties"]
        required = set(schema.get("required", ()))
        return st.fixed_dictionaries(
            {k: from_schema(v) for k, v in props.items() if k in required},
            optional={k: from_schema(v) for k, v in props.items() if k not in required})
    raise AssertionError(schema)


def bodies(arm: Any) -> st.SearchStrategy[dict[str, Any]]:
    props = contract.request_schema(arm)["properties"]
    optional = {k: from_schema(v) for k, v in props.items() if k != "waypoints"}
    return st.fixed_dictionaries({"waypoints": from_schema(props["waypoints"])},
                                 optional=optional)


# Rules the schema cannot state (documented in the contract module and its schema text).
CROSS_FIELD = {"method", "turn", "beta", "duration", "start_state"}


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_bodies_valid_per_schema_parse(data: st.DataObject) -> None:
    arm = data.draw(st.sampled_from([ARM, ARM2]))
    b = data.draw(bodies(arm))
    # one waypoint needs a start (start_joints or start_state): a cross-field rule too
    lone = len(b["waypoints"]) == 1 and b.get("start_joints") is None \
        and b.get("start_state") is None
    try:
        req = contract.parse_request(b, arm)
    except InputError as exc:
        assert exc.field.split("[")[0] in CROSS_FIELD or (lone and exc.field == "waypoints"), \
            (b, exc)
        return
    assert not lone
    assert req.segments == max(1, len(b["waypoints"]) - 1)


@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_one_bad_value_is_named(data: st.DataObject) -> None:
    b = {k: v for k, v in data.draw(bodies(ARM)).items() if k not in CROSS_FIELD}
    name = data.draw(st.sampled_from(["beta", "rate_hz", "blend", "profile", "elbow",
                                      "start_joints", "duration"]))
    bad = data.draw(st.sampled_from([True, "x", [], {}, -1e300, 1e300, 10**400]))
    if name == "blend" and isinstance(bad, bool):
        bad = 1
    b[name] = bad
    with pytest.raises(InputError) as info:
        contract.parse_request(b, ARM)
    assert info.value.field.split("[")[0] == name, (b, info.value)


def test_trajectory_schema_from_its_definition() -> None:
    from robodcn.planner import Trajectory, plan

    schema = contract.schema_of(Trajectory)
    traj = plan(ARM, [HOME, [0.2, 0.1, 0.3]])
    data = json.loads(traj.to_json())
    assert set(data) == set(schema["properties"])
    assert set(schema["required"]) <= set(data)
    assert schema["properties"]["ticks"]["items"]["items"] == {"type": "integer"}
    assert schema["properties"]["method"]["anyOf"][0] == {"type": "string"}
    assert all("description" in p for p in schema["properties"].values())


def test_deep_or_huge_values_give_short_messages() -> None:
    deep: Any = 0.0
    for _ in range(400):
        deep = [deep]
    for bad in ({"waypoints": [HOME, deep]}, {"waypoints": [HOME, [0.1, 0.2, {"a": 1}]]},
                {"beta": [1.0] * 10_000}, {"start_joints": deep}):
        with pytest.raises(InputError) as info:
            contract.parse_request({**body(), **bad}, ARM)
        assert len(info.value.message) < 200
