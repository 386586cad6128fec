"""KenLERP β per segment (issue 12 §2): the planner, the contract (schema, HTTP), the CLI's
``--beta B,B`` and waypoints files with a ``beta`` per waypoint, end to end. Expected
geometry comes from :func:`robodcn.interpolate` and single-segment plans, never from a run."""

from __future__ import annotations

import json
import math
import warnings
from typing import Any

import numpy as np
import pytest
from conftest import ARM3R
from http_helpers import ARM, call, error_of, run_move
from workflow_helpers import ARM3R as ARM3R_PATH
from workflow_helpers import NO_DEVICE, run_cli

from robodcn import contract
from robodcn.errors import BetaIgnoredWarning, InputError
from robodcn.interpolate import interpolate
from robodcn.planner import PlanRequest, StartState, Trajectory, plan

pytest_plugins = ["http_helpers"]     # fixtures: arm_server, planner_server

#: Three poses whose segments both turn θ (so s is recoverable from θ along each).
WAYPOINTS = [(0.25, 0.10, 0.0), (0.20, 0.20, math.radians(45)),
             (0.12, 0.24, math.radians(100))]
BETAS = (0.2, 1.5)


def _segment_rows(traj: Trajectory, j: int) -> tuple[np.ndarray, np.ndarray]:
    """The samples of a plan on segment j and their path parameter s (θ is linear in s on
    every method and monotonic over WAYPOINTS, so segment j's θ range picks its samples)."""
    a, b = traj.request.waypoints[j], traj.request.waypoints[j + 1]
    s = (traj.poses[:, 2] - a[2]) / (b[2] - a[2])
    on = (s >= 0.0) & (s <= 1.0)
    return traj.poses[on], s[on]


@pytest.mark.parametrize("profile", ["optimal", "quintic"])
def test_each_segment_is_interpolated_with_its_own_beta(profile: str) -> None:
    traj = plan(ARM3R, WAYPOINTS, method="kenlerp", beta=list(BETAS), profile=profile)
    assert traj.request.beta == BETAS
    for j, beta in enumerate(BETAS):
        poses, s = _segment_rows(traj, j)
        assert len(s) > 10 and s.min() == pytest.approx(0.0, abs=1e-9)
        want = interpolate(WAYPOINTS[j], WAYPOINTS[j + 1], s, method="kenlerp", beta=beta)
        np.testing.assert_allclose(poses, want, atol=1e-9)
        # ... the geometry of a single-segment plan with that β
        single = plan(ARM3R, WAYPOINTS[j:j + 2], method="kenlerp", beta=beta, profile=profile)
        s1 = (single.poses[:, 2] - WAYPOINTS[j][2]) / (WAYPOINTS[j + 1][2] - WAYPOINTS[j][2])
        np.testing.assert_allclose(single.poses, interpolate(
            WAYPOINTS[j], WAYPOINTS[j + 1], s1, method="kenlerp", beta=beta), atol=1e-9)
        # and not the other segment's β: the two curves differ visibly
        other = interpolate(WAYPOINTS[j], WAYPOINTS[j + 1], s, method="kenlerp",
                            beta=BETAS[1 - j])
        assert np.abs(poses[:, :2] - other[:, :2]).max() > 1e-3


def test_path_segments_carry_their_beta_blended_and_from_a_moving_start() -> None:
    from robodcn.planner.path import blended_path, segments_of
    from robodcn.planner.pieces import segments_from_start

    req = PlanRequest(ARM3R, WAYPOINTS, method="kenlerp", beta=BETAS)
    assert [seg.beta for seg in segments_of(req)] == list(BETAS)
    s = np.linspace(0.0, 1.0, 9)
    for j, seg in enumerate(segments_of(req)):
        np.testing.assert_allclose(seg.poses(s), interpolate(
            WAYPOINTS[j], WAYPOINTS[j + 1], s, method="kenlerp", beta=BETAS[j]), atol=1e-12)
    path = blended_path(req, segments_of(req), None)
    assert [seg.beta for seg in path.segments] == list(BETAS)
    np.testing.assert_allclose(path(path.knots), WAYPOINTS, atol=1e-9)  # through every via
    blended = plan(ARM3R, WAYPOINTS, method="kenlerp", beta=BETAS, blend=True)
    assert blended.request.beta == BETAS
    # A moving start far from waypoints[0] prepends a segment: it takes segment 0's β.
    q0 = np.radians([-20.0, 40.0, 0.0])
    moving = PlanRequest(ARM3R, WAYPOINTS, method="kenlerp", beta=BETAS,
                         start_state=StartState(tuple(q0)))
    assert [seg.beta for seg in segments_from_start(moving)] == [BETAS[0], *BETAS]


def test_one_float_is_unchanged() -> None:
    req = PlanRequest(ARM3R, WAYPOINTS, method="kenlerp", beta=0.5)
    assert req.beta == 0.5 and isinstance(req.beta, float)
    assert req.to_dict()["beta"] == 0.5
    assert [req.segment_beta(j) for j in range(req.segments)] == [0.5, 0.5]
    np.testing.assert_array_equal(plan(ARM3R, WAYPOINTS, method="kenlerp", beta=[0.5, 0.5]).poses,
                                  plan(ARM3R, WAYPOINTS, method="kenlerp", beta=0.5).poses)


def test_per_segment_beta_round_trips_through_json() -> None:
    traj = plan(ARM3R, WAYPOINTS, method="kenlerp", beta=BETAS, duration=2.0)
    data = json.loads(traj.to_json())
    assert data["request"]["beta"] == list(BETAS)
    again = Trajectory.from_json(traj.to_json(), ARM3R)
    assert again.request == traj.request and again.request.beta == BETAS
    assert PlanRequest.from_dict(traj.request.to_dict()) == traj.request


@pytest.mark.parametrize(("beta", "field", "needle"), [
    ([0.5], "beta", "one entry per segment (2), got 1"),
    ([0.5, 1.0, 2.0], "beta", "one entry per segment (2), got 3"),
    ([], "beta", "one entry per segment (2), got 0"),
    ([0.5, -1.0], "beta[1]", "within 0..10, got -1"),
    ([11.0, 0.5], "beta[0]", "within 0..10, got 11"),
    ([0.5, math.nan], "beta[1]", "finite"),
    ([0.5, "x"], "beta[1]", "must be a number, got 'x'"),
    ([True, 0.5], "beta[0]", "must be a number"),
    (np.array([0.5]), "beta", "one entry per segment"),
])
def test_bad_per_segment_beta_is_named(beta: Any, field: str, needle: str) -> None:
    with pytest.raises(InputError) as info:
        plan(ARM3R, WAYPOINTS, method="kenlerp", beta=beta)
    assert info.value.field == field and needle in str(info.value), info.value
    assert str(info.value).startswith(field)


def test_ignored_beta_warns_about_those_segments_only() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", BetaIgnoredWarning)
        plan(ARM3R, WAYPOINTS, method=["sclerp", "kenlerp"], beta=[1.0, 0.4])
        plan(ARM3R, WAYPOINTS, method=["sclerp", "kenlerp"], beta=0.4)  # one β: it is read
    with pytest.warns(BetaIgnoredWarning) as record:
        plan(ARM3R, WAYPOINTS, method=["sclerp", "kenlerp"], beta=[0.4, 0.7])
    (w,) = [r.message for r in record]
    assert w.field == "beta" and w.segments == (0,)
    assert "segment 0 (β = 0.4, method sclerp)" in str(w) and "segment 1" not in str(w)
    with pytest.warns(BetaIgnoredWarning) as record:
        plan(ARM3R, WAYPOINTS, method="dlb", beta=[0.4, 2.0])
    assert record[0].message.segments == (0, 1)


# -- the contract and HTTP ------------------------------------------------------------------------

def test_schema_takes_a_number_or_one_per_segment() -> None:
    schema = contract.request_schema(ARM)["properties"]["beta"]
    one, many = schema["oneOf"]
    assert one == {"type": "number", "minimum": 0.0, "maximum": 10.0}
    assert many["type"] == "array" and many["items"] == one and many["minItems"] == 1
    assert schema["default"] == 1.0 and "per segment" in schema["description"]
    req = contract.parse_request({"waypoints": [list(w) for w in WAYPOINTS],
                                  "method": "kenlerp", "beta": [0.2, 1.5]}, ARM)
    assert req.beta == BETAS


def test_http_plans_a_beta_per_segment(planner_server) -> None:
    body = {"waypoints": [list(w) for w in WAYPOINTS], "method": "kenlerp", "beta": list(BETAS),
            "rate_hz": 100}
    status, _, data = call(planner_server, "POST", "/v1/trajectories", body)
    assert status == 200, data
    got = Trajectory.from_json(json.dumps(data), ARM)
    want = plan(ARM, WAYPOINTS, method="kenlerp", beta=BETAS, rate_hz=100)
    np.testing.assert_array_equal(got.poses, want.poses)
    assert data["request"]["beta"] == list(BETAS)


@pytest.mark.parametrize(("beta", "field"), [([0.2], "beta"), ([0.2, 1.5, 1.0], "beta"),
                                             ([0.2, 12], "beta[1]"), ([0.2, "x"], "beta[1]"),
                                             ([0.2, None], "beta[1]"), ({"a": 1}, "beta")])
def test_http_refuses_a_bad_beta_list_with_422(planner_server, beta: Any, field: str) -> None:
    body = {"waypoints": [list(w) for w in WAYPOINTS], "method": "kenlerp", "beta": beta}
    status, _, data = call(planner_server, "POST", "/v1/trajectories", body)
    err = error_of(data)
    assert status == 422 and err["field"] == field, err
    assert "beta" in err["message"]


def test_http_move_takes_a_beta_per_segment(arm_server) -> None:
    server, _ = arm_server
    body = {"waypoints": [list(ARM.home), [0.2, 0.12, 0.3], [0.18, 0.12, 0.6]],
            "method": "kenlerp", "beta": [0.2, 1.5], "duration": 0.8, "rate_hz": 100}
    status, _, bad = call(server, "POST", "/v1/moves", {**body, "beta": [0.2]})
    assert status == 422 and error_of(bad)["field"] == "beta"
    done = run_move(server, body)
    status, _, planned = call(server, "GET", f"/v1/moves/{done['id']}/trajectory")
    assert status == 200 and planned["request"]["beta"] == [0.2, 1.5]


# -- the CLI and waypoints files ------------------------------------------------------------------

def cli(monkeypatch, argv: list[str]) -> int | str | None:
    """run_cli, with argparse's usage error (SystemExit) as its exit code."""
    try:
        return run_cli(monkeypatch, argv)
    except SystemExit as exc:
        return exc.code


PLAN = ("plan", "--arm", ARM3R_PATH, "--from", "0.25,0.1,0", "--via", "0.2,0.2,45", "--to",
        "0.12,0.24,100", "--method", "kenlerp", "-q", "--format", "json")


def test_cli_beta_takes_one_value_per_segment(monkeypatch, capsys) -> None:
    assert run_cli(monkeypatch, [*PLAN, "--beta", "0.2,1.5"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["request"]["beta"] == [0.2, 1.5]
    want = plan(ARM3R, WAYPOINTS, method="kenlerp", beta=BETAS, rate_hz=ARM3R.bus.rate_hz)
    np.testing.assert_allclose(data["poses"], want.poses, atol=1e-12)
    assert run_cli(monkeypatch, [*PLAN, "--beta", "0.5"]) == 0
    assert json.loads(capsys.readouterr().out)["request"]["beta"] == 0.5


@pytest.mark.parametrize(("value", "needle"), [
    ("0.2,1.5,1", "--beta takes one value or one per segment (2 here"),
    ("0.2,11", "--beta must be within 0..10, got 11"),
    ("0.2,x", "argument --beta: must be a finite number or a comma list"),
    ("0.2,", "argument --beta"),
    ("0.2,inf", "argument --beta"),
])
def test_cli_bad_beta_list_is_a_usage_error(monkeypatch, capsys, value: str,
                                             needle: str) -> None:
    assert cli(monkeypatch, [*PLAN, "--beta", value]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and needle in err, err


POSES = ('[plan]\nmethod = "kenlerp"\nbeta = 0.2\n\n'
         "[[waypoints]]\nx = 0.25\ny = 0.1\ntheta_deg = 0\n\n"
         "[[waypoints]]\nx = 0.2\ny = 0.2\ntheta_deg = 45\n\n"
         "[[waypoints]]\nx = 0.12\ny = 0.24\ntheta_deg = 100\nbeta = 1.5\n")


def test_run_plans_a_waypoints_file_with_its_per_segment_beta(monkeypatch, tmp_path,
                                                              capsys) -> None:
    import robodcn.present

    path = tmp_path / "poses.toml"
    path.write_text(POSES)
    planned: list[Trajectory] = []
    real = robodcn.present.plan_from_present

    def spy(*args: Any, **kwargs: Any) -> Trajectory:
        planned.append(real(*args, **kwargs))
        return planned[-1]

    monkeypatch.setattr(robodcn.present, "plan_from_present", spy)
    code = run_cli(monkeypatch, ["run", str(path), "--arm", ARM3R_PATH, "--sim", "--json",
                                 "--rate", "100"])
    report = json.loads(capsys.readouterr().out)
    assert code == {"done": 0, "degraded": 5}.get(report["outcome"]), report["headline"]
    (traj,) = planned
    assert traj.request.beta == BETAS and traj.request.method == "kenlerp"
    # --beta overrides the file's, one value or one per segment
    for value, want in (("0.7", 0.7), ("0.3,0.9", (0.3, 0.9))):
        from robodcn.cli import build_parser
        from robodcn.cli.run_cmd import load_run_file

        args = build_parser().parse_args(["run", str(path), "--beta", value])
        kind, fields = load_run_file(args, ARM3R)
        assert kind == "waypoints" and fields["beta"] == want


def test_run_refuses_a_bad_beta_before_the_bus(monkeypatch, tmp_path, capsys) -> None:
    path = tmp_path / "poses.toml"
    path.write_text(POSES)
    for argv, needle in ((["--beta", "0.2,1.5,1"], "--beta lists 3 values for the 2 segments"),
                         (["--beta", "0.2,x"], "argument --beta")):
        code = cli(monkeypatch, ["run", str(path), "--arm", ARM3R_PATH, "--device", NO_DEVICE,
                                 *argv])
        err = capsys.readouterr().err
        assert code == 2 and needle in err, err
    path.write_text(POSES.replace("beta = 1.5", "beta = 12"))
    code = run_cli(monkeypatch, ["run", str(path), "--arm", ARM3R_PATH, "--device", NO_DEVICE])
    err = capsys.readouterr().err
    assert code == 2 and "waypoints[2].beta" in err and "12" in err, err
