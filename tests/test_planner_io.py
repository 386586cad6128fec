"""Trajectory JSON and CSV round trips and their shape checks."""

from __future__ import annotations

import csv
import io
import json
from typing import Any

import numpy as np
import pytest
from planner_helpers import (
    ARM2R,
    ARM3R,
    WAYPOINTS_2R,
    WAYPOINTS_3R,
)

from robodcn.errors import (
    InputError,
)
from robodcn.planner import Trajectory, plan, plan_request

# -- serialisation ------------------------------------------------------------------------------

def test_json_round_trip() -> None:
    traj = plan(ARM3R, WAYPOINTS_3R, method=["sclerp", "dlb"], blend=True, rate_hz=50,
                start_joints=[0.0, -1.0, 0.5])
    text = traj.to_json()
    data = json.loads(text)
    assert {"t", "poses", "joints", "ticks", "joint_names", "servo_ids", "rate_hz",
            "method"} <= set(data)
    back = Trajectory.from_json(text)
    for name in ("t", "poses", "joints", "ticks"):
        np.testing.assert_array_equal(getattr(back, name), getattr(traj, name))
    assert back.ticks.dtype == np.int64
    assert (back.joint_names, back.servo_ids, back.rate_hz, back.method) == (
        traj.joint_names, traj.servo_ids, traj.rate_hz, traj.method)
    assert back.request == traj.request
    with_arm = Trajectory.from_json(text, arm=ARM3R)
    assert with_arm.request.arm is ARM3R
    # the rebuilt request plans the same trajectory
    np.testing.assert_array_equal(plan_request(back.request).joints, traj.joints)


@pytest.mark.parametrize(("edit", "field"), [
    (lambda d: d.pop("ticks"), "ticks"),
    (lambda d: d.__setitem__("poses", [p[:2] for p in d["poses"]]), "poses"),
    (lambda d: d.__setitem__("joints", d["joints"][:-1]), "joints"),
    (lambda d: d.__setitem__("t", [x * 2 for x in d["t"]]), "t"),
    (lambda d: d.__setitem__("servo_ids", [1]), "servo_ids"),
    (lambda d: d.__setitem__("rate_hz", 0), "rate_hz"),
])
def test_from_json_checks_shapes(edit: Any, field: str) -> None:
    data = json.loads(plan(ARM3R, WAYPOINTS_3R[:2], rate_hz=50).to_json())
    data["request"] = None
    edit(data)
    with pytest.raises(InputError) as info:
        Trajectory.from_json(json.dumps(data))
    assert info.value.field == field


def test_csv_matches_the_arrays() -> None:
    traj = plan(ARM2R, WAYPOINTS_2R, rate_hz=50)
    rows = list(csv.reader(io.StringIO(traj.to_csv())))
    assert rows[0] == ["t_s", "x_m", "y_m", "theta_rad", "q_shoulder_rad", "q_elbow_rad",
                       "tick_1", "tick_2"]
    body = np.array(rows[1:], dtype=float)
    np.testing.assert_array_equal(body[:, 0], traj.t)
    np.testing.assert_array_equal(body[:, 1:4], traj.poses)
    np.testing.assert_array_equal(body[:, 4:6], traj.joints)
    np.testing.assert_array_equal(body[:, 6:], traj.ticks)
