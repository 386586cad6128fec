"""Messages in the user's terms: degrees and options on the CLI, SI and JSON fields over HTTP,
worded from the data of the error or violation."""

from __future__ import annotations

import dataclasses
import math
import warnings

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robodcn import contract, load_arm, messages, plan
from robodcn.errors import (
    BetaIgnoredWarning,
    InputError,
    PlanError,
    Violation,
)

ARM = load_arm("configs/arm3r.toml")
WPS = [[0.25, 0.10, 0.0], [0.15, 0.20, 1.0], [0.0, 0.28, 1.5]]
NAMES = ["--from", "--via #1", "--to"]


def velocity_violation(**kw: object) -> Violation:
    base = dict(sample=12, t=0.12, pose=(0.2, 0.1, math.radians(30)), quantity="velocity",
                value=math.radians(200), limit=math.radians(170), unit="rad/s",
                joint="shoulder", joint_index=0, segment=(1, 2), field="duration")
    base.update(kw)
    return Violation(**base)  # type: ignore[arg-type]


def test_violation_in_cli_units_names_options_and_degrees() -> None:
    text = messages.describe(velocity_violation(), "cli", waypoint_names=NAMES)
    assert "200 deg/s" in text and "170 deg/s" in text and "--duration" in text
    assert "θ=30.0°" in text and "segment --via #1 → --to" in text
    assert "rad" not in text


def test_violation_in_si_names_json_fields() -> None:
    text = messages.describe(velocity_violation(), "si")
    assert "3.491 rad/s" in text and "2.967 rad/s" in text and "lengthen duration" in text
    assert "segment waypoint 1 → 2" in text and "θ=0.5236 rad" in text


def test_position_violation_says_whether_the_other_branch_passes() -> None:
    v = velocity_violation(quantity="position", value=math.radians(175),
                           limit=math.radians(170), unit="rad", other_branch_ok=True,
                           field="waypoints")
    cli = messages.describe(v, "cli")
    assert "175.0°" in cli and "170.0°" in cli and "other elbow branch would pass" in cli
    assert "--elbow" in cli
    v = dataclasses.replace(v, other_branch_ok=False)
    assert "fails too" in messages.describe(v, "si")


def test_input_errors_name_the_option_on_the_cli() -> None:
    with pytest.raises(InputError) as info:
        plan(ARM, WPS, rate_hz=5000)
    assert messages.describe(info.value, "cli").startswith("--rate must be within 1..1000 Hz")
    assert messages.describe(info.value, "si").startswith("rate_hz must be within")
    with pytest.raises(InputError) as info:
        plan(ARM, WPS, method="cubic")
    text = messages.describe(info.value, "cli")
    assert text.startswith("--method must be one of sclerp, kenlerp, seplerp, dlb")
    assert "[" not in text and "'" not in text.split("got")[0]


def test_waypoint_input_errors_name_the_option_given() -> None:
    with pytest.raises(InputError) as info:
        contract.parse_request({"waypoints": [WPS[0], [0.2, math.inf, 0.0]]}, ARM)
    assert info.value.field == "waypoints[1][1]"
    assert messages.describe(info.value, "cli", waypoint_names=["--from", "--to"]
                             ).startswith("--to ")


def test_planner_errors_carry_violations_worded_both_ways() -> None:
    with pytest.raises(PlanError) as info:
        plan(ARM, WPS, duration=0.2)
    err = info.value
    cli = messages.describe(err, "cli", waypoint_names=NAMES)
    si = messages.describe(err, "si")
    assert err.violation is not None and str(err) == si
    assert "deg/s" in cli and "--duration" in cli and "rad/s" in si and "rad/s" not in cli
    assert "segment --from → --via #1" in cli
    assert err.to_dict()["violation"]["quantity"] == err.violation.quantity


def test_beta_warning_names_the_option() -> None:
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        plan(ARM, WPS, method="dlb", beta=0.3)
    w = [r.message for r in record if isinstance(r.message, BetaIgnoredWarning)]
    assert len(w) == 1 and w[0].field == "beta"
    assert messages.describe(w[0], "cli").startswith("--beta = 0.3 has no effect")


@settings(max_examples=200, deadline=None)
@given(limit=st.floats(1e-3, 1e3), gap=st.floats(1e-11, 1e-2),
       units=st.sampled_from(["cli", "si"]), unit=st.sampled_from(["N*m", "rad/s"]))
def test_a_value_and_its_limit_never_read_alike(limit, gap, units, unit):
    """Issue 27 §2: "needs 2.8 N·m, limit 2.8 N·m" told nothing; the digits follow the gap."""
    value = limit * (1.0 + gap)
    a, b = messages.quantity_pair(value, limit, unit, units)
    assert a != b
    factor = 180.0 / math.pi if units == "cli" and unit == "rad/s" else 1.0
    x, y = (float(t.split()[0]) for t in (a, b))
    assert x > y
    if messages.quantity(value, unit, units) == messages.quantity(limit, unit, units):
        # the digits added: the limit reads within the gap of itself
        assert abs(y - limit * factor) <= abs(value - limit) * factor


def test_a_torque_and_its_limit_read_with_the_same_digits():
    """"needs 2.807 N·m, limit 2.8 N·m" read as if the limit were rounder than the value."""
    assert messages.quantity_pair(2.807, 2.8, "N*m", "cli") == ("2.807 N·m", "2.800 N·m")
    assert messages.quantity_pair(2.8, 2.8, "N*m", "si") == ("2.800 N·m", "2.800 N·m")
    # other units keep their own digits unless value and limit would read alike
    assert messages.quantity_pair(5.77, 2.97, "rad/s", "cli") == ("330.6 deg/s", "170.2 deg/s")
