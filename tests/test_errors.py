"""The error hierarchy: classes, codes, statuses, and the Violation data they carry."""

from __future__ import annotations

import json

from robodcn import contract, errors
from robodcn.errors import (
    VIOLATION_ERRORS,
    JerkLimitError,
    JointLimitError,
    PlanError,
    Violation,
)


def test_every_quantity_has_its_plan_error() -> None:
    assert set(VIOLATION_ERRORS) == set(errors.QUANTITY_UNITS)
    assert all(issubclass(cls, PlanError) for cls in VIOLATION_ERRORS.values())
    assert JerkLimitError.code == "jerk_limit" and JerkLimitError.exit_code == 3


def test_plan_error_takes_its_data_from_the_violation() -> None:
    v = Violation(sample=3, t=0.03, pose=(0.1, 0.2, 0.3), quantity="position", value=3.1,
                  limit=2.9, unit="rad", joint="elbow", joint_index=1, segment=(0, 1),
                  waypoint=None, other_branch_ok=False, field="waypoints")
    err = JointLimitError("x", violation=v)
    assert (err.sample, err.t, err.pose, err.joint, err.field) == (3, 0.03, [0.1, 0.2, 0.3],
                                                                   "elbow", "waypoints")
    body = err.to_dict()
    assert body["violation"]["segment"] == [0, 1] and json.dumps(body)
    assert err.http_status == 422


def test_violation_schema_matches_its_json() -> None:
    schema = contract.schema_of(Violation)
    v = Violation(sample=0, t=0.0, pose=(0.0, 0.0, 0.0), quantity="reach", value=1.0,
                  limit=0.35, unit="m")
    assert set(v.to_dict()) == set(schema["properties"])


def test_warnings_are_ours_and_carry_data() -> None:
    w = errors.BranchSwitchWarning("switch", samples=(4,))
    assert isinstance(w, errors.RobodcnWarning) and isinstance(w, UserWarning)
    assert w.samples == (4,) and w.field == "waypoints"
    assert issubclass(errors.BetaIgnoredWarning, errors.RobodcnWarning)
