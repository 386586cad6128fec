"""Keep-out zones (issue 26 §3): the arm file's ``[workspace]`` (a floor plane, a cylinder
about the yaw axis for the base, boxes), parsed with errors naming file and key, and every
planned sample checked against them like the joint limits — the tool point, every joint
centre and points along the links. The positions the checks report are compared with an
independent computation: the side-view points of :func:`robodcn.plots.plane_points`
(another formula for the same chain) turned by the yaw."""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from conftest import ARM3R, CONFIGS
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from robodcn import kinematics
from robodcn.config import SERVO_SPECS, Arm, arm_from_dict, base_radius_of, load_arm
from robodcn.errors import ConfigError, KeepOutError, PlanError
from robodcn.messages import describe
from robodcn.planner import plan
from robodcn.plots import plane_points
from robodcn.workflow.check import workspace_samples

OMX = load_arm(CONFIGS / "omx.toml")
OMX_DATA = tomllib.loads((CONFIGS / "omx.toml").read_text())
ARM3R_DATA = tomllib.loads((CONFIGS / "arm3r.toml").read_text())
DEG = math.pi / 180.0
#: Where along each link the checks test points (module of the checks: LINK_FRACTIONS).
FRACTIONS = (0.25, 0.5, 0.75)


def omx_with(**workspace) -> Arm:
    """The packaged omx with its ``[workspace]`` table replaced by ``workspace``."""
    data = copy.deepcopy(OMX_DATA)
    data["workspace"] = workspace
    return arm_from_dict(data, source="omx-test.toml")


def no_zones(arm: Arm) -> Arm:
    data = arm.to_dict()
    data["workspace"] = {"floor_z": False, "base_radius": False} if arm.yawed else {}
    return arm_from_dict(data, source=arm.source)


def side_points(arm: Arm, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Independently of the checks: (points (m, 3) base frame, whether each is the
    shoulder or along the first link) of a yawed arm at joints q: plane_points' shoulder,
    joints and tool turned by the yaw, and FRACTIONS of each link between them."""
    rz = plane_points(arm, q)[1:]            # shoulder, elbow, wrist, tool (r, z)
    ends = [(r * math.cos(q[0]), r * math.sin(q[0]), z) for r, z in rz]
    pts, first = list(ends), [True] + [False] * (len(ends) - 1)
    for i in range(len(ends) - 1):
        for f in FRACTIONS:
            pts.append(tuple(a + f * (b - a) for a, b in zip(ends[i], ends[i + 1], strict=True)))
            first.append(i == 0)
    return np.array(pts), np.array(first)


def point_depths(arm: Arm, q: np.ndarray) -> dict[str, np.ndarray]:
    """Per zone the depth (m) of each tested point of the omx at q (floor: −z; base:
    min(R − ρ, H − z), −inf for the shoulder and the first link; boxes: the nearest face)."""
    pts, first = side_points(arm, q)
    ws = arm.workspace
    out = {}
    if ws.floor is not None:
        out["floor"] = ws.floor - pts[:, 2]
    if ws.base_radius is not None:
        rho = np.hypot(pts[:, 0], pts[:, 1])
        d = np.minimum(ws.base_radius - rho, ws.base_height - pts[:, 2])
        out["base"] = np.where(first, -np.inf, d)
    for b in ws.boxes:
        lo, hi = np.array(b.low), np.array(b.high)
        out[b.name] = np.minimum(pts - lo, hi - pts).min(axis=1)
    return out


def deepest(arm: Arm, q: np.ndarray) -> dict[str, float]:
    """Per zone the largest depth (m) of any tested point of the omx at q."""
    return {zone: float(np.max(d)) for zone, d in point_depths(arm, q).items()}


def keeps_out(arm: Arm, joints: np.ndarray) -> bool:
    """Whether the motion ``joints`` never enters a zone: every point outside every zone at
    every sample, but a point inside at the first sample, which may stay while its depth
    never grows (the rule for an arm that starts inside: it may leave)."""
    per = [point_depths(arm, q) for q in joints]
    for zone in per[0]:
        d = np.array([p[zone] for p in per])             # (n, points)
        for col in d.T:
            if col[0] > 1e-9:
                rose = np.flatnonzero(np.diff(col) > 1e-9)
                col = col[rose[0] + 1:] if rose.size else col[:0]
            if (col > 1e-9).any():
                return False
    return True


# -- the [workspace] table ----------------------------------------------------------------------

def test_the_omx_has_a_floor_and_a_base_by_default_and_its_file_writes_them_out() -> None:
    data = copy.deepcopy(OMX_DATA)
    del data["workspace"]
    default = arm_from_dict(data, source="no-table.toml").workspace
    assert default.zones == ("floor", "base")
    assert default.floor == 0.0 and default.up == 2
    assert default.base_height == OMX.shoulder_height
    # the XM430's 28.5 × 46.5 mm footprint, its horn axis 11.25 mm from one end
    assert default.base_radius == pytest.approx(math.hypot(0.0465 - 0.01125, 0.01425))
    assert default.base_radius == pytest.approx(base_radius_of(SERVO_SPECS["xm430-w350"]))
    assert 0.03 < default.base_radius < 0.04            # the 3 cm target is inside
    assert OMX.workspace.zones == default.zones
    assert OMX.workspace.base_radius == pytest.approx(default.base_radius, abs=1e-4)
    packaged = Path(__file__).resolve().parent.parent / "robodcn/config/data/omx.toml"
    assert packaged.read_text() == (CONFIGS / "omx.toml").read_text()


def test_planar_arms_have_no_zones_unless_they_declare_boxes() -> None:
    assert ARM3R.workspace.empty and ARM3R.workspace.zones == ()
    data = copy.deepcopy(ARM3R_DATA)
    data["workspace"] = {"keep_out": [{"name": "fixture", "min": [0.1, -0.3],
                                       "max": [0.2, -0.2]}]}
    arm = arm_from_dict(data, source="arm.toml")
    assert arm.workspace.zones == ("fixture",)
    box = arm.workspace.boxes[0]
    assert box.low[:2] == (0.1, -0.3) and box.high[:2] == (0.2, -0.2)
    assert math.isinf(box.low[2]) and math.isinf(box.high[2])
    assert arm_from_dict(arm.to_dict(), source="again").workspace == arm.workspace


def test_the_zones_round_trip_and_can_be_switched_off() -> None:
    arm = omx_with(floor_z=-0.01, base_radius=0.03, base_height=0.05,
                   keep_out=[{"name": "camera", "min": [0.15, 0.1, 0.0],
                              "max": [0.25, 0.2, 0.12]}])
    ws = arm.workspace
    assert ws.zones == ("floor", "base", "camera") and ws.floor == -0.01
    assert ws.boxes[0].low == (0.15, 0.1, 0.0) and ws.boxes[0].high == (0.25, 0.2, 0.12)
    assert arm_from_dict(arm.to_dict(), source="again").workspace == ws
    off = omx_with(floor_z=False, base_radius=False)
    assert off.workspace.empty
    assert arm_from_dict(off.to_dict(), source="again").workspace.empty


@pytest.mark.parametrize("arm_data, table, key, words", [
    (OMX_DATA, {"floor_z": "low"}, "workspace.floor_z", "must be a number"),
    (OMX_DATA, {"base_radius": -0.01}, "workspace.base_radius", "within 0..10 m"),
    (OMX_DATA, {"base_height": -1.0}, "workspace.base_height", "within 0..10 m"),
    (OMX_DATA, {"ceiling": 1.0}, "workspace.ceiling", "unknown key"),
    (OMX_DATA, {"keep_out": {"min": [0, 0, 0]}}, "workspace.keep_out", "array of tables"),
    (OMX_DATA, {"keep_out": [{"min": [0.1, 0.1], "max": [0.2, 0.2, 0.2]}]},
     "workspace.keep_out[0].min", "list of 3 numbers"),
    (OMX_DATA, {"keep_out": [{"min": [0.1, 0.1, 0.1], "max": [0.2, 0.05, 0.2]}]},
     "workspace.keep_out[0].max", "exceed min's (y"),
    (OMX_DATA, {"keep_out": [{"min": [0.1, 0.1, 0.1]}]}, "workspace.keep_out[0].max",
     "missing key"),
    (OMX_DATA, {"keep_out": [{"name": "floor", "min": [0.1, 0.1, 0.1],
                              "max": [0.2, 0.2, 0.2]}]}, "workspace.keep_out[0].name",
     "name the floor and the base"),
    (OMX_DATA, {"keep_out": [{"name": "a", "min": [0.3, 0.3, 0.3], "max": [0.4, 0.4, 0.4]},
                             {"name": "a", "min": [0.3, -0.4, 0.3],
                              "max": [0.4, -0.3, 0.4]}]},
     "workspace.keep_out[1].name", "duplicate zone name"),
    (ARM3R_DATA, {"floor_y": 0.0}, "workspace.floor_y", "no floor"),
    (ARM3R_DATA, {"base_radius": 0.03}, "workspace.base_radius", "unknown key"),
    (ARM3R_DATA, {"keep_out": [{"min": [0.1, 0.1, 0.0], "max": [0.2, 0.2, 0.1]}]},
     "workspace.keep_out[0].min", "list of 2 numbers"),
])
def test_config_errors_name_the_file_and_key(arm_data, table, key, words) -> None:
    data = copy.deepcopy(arm_data)
    data["workspace"] = table
    with pytest.raises(ConfigError) as info:
        arm_from_dict(data, source="my-arm.toml")
    assert info.value.key == key and info.value.file == "my-arm.toml"
    assert str(info.value).startswith("my-arm.toml: ") and f"key '{key}'" in str(info.value)
    assert words in str(info.value)


def test_a_zone_that_swallows_the_home_pose_is_a_config_error() -> None:
    # the omx's home tool point (0.1218, 0, 0.2409)
    with pytest.raises(ConfigError) as info:
        omx_with(keep_out=[{"name": "shelf", "min": [0.1, -0.05, 0.2],
                            "max": [0.2, 0.05, 0.3]}])
    assert info.value.key == "workspace" and "home pose" in str(info.value)
    assert "'shelf'" in str(info.value) and "mm inside" in str(info.value)
    with pytest.raises(ConfigError, match="floor"):
        omx_with(floor_z=0.25)                       # the tool at home is below it


def test_a_vertical_planar_arm_may_have_a_floor_along_y() -> None:
    data = copy.deepcopy(ARM3R_DATA)
    data["arm"]["plane"] = "vertical"
    data["workspace"] = {"floor_y": -0.05}
    arm = arm_from_dict(data, source="wall.toml")
    assert arm.workspace.zones == ("floor",) and arm.workspace.up == 1
    # straight down from the shoulder: the tool at y = −0.35, 0.30 m below the floor
    with pytest.raises(KeepOutError) as info:
        plan(arm, [arm.home, (0.0, -0.35, -math.pi / 2)])
    assert info.value.zone == "floor" and info.value.depth == pytest.approx(0.30)


# -- plans refused, with the data -------------------------------------------------------------

def test_a_target_below_the_plate_is_refused_naming_the_waypoint_zone_and_depth() -> None:
    with pytest.raises(KeepOutError) as info:
        plan(OMX, [OMX.home, (0.2, 0.0, -0.1, -90 * DEG)])
    err = info.value
    assert err.exit_code == 3 and err.http_status == 422 and err.code == "keep_out"
    assert err.field == "waypoints[1]" and err.waypoint == 1
    assert (err.point, err.zone) == ("tool", "floor")
    assert err.depth == pytest.approx(0.1) and err.position == pytest.approx([0.2, 0, -0.1])
    assert err.to_dict()["keepout"]["depth_m"] == pytest.approx(0.1)
    text = describe(err, "cli", ["--from", "--to"])
    assert "100.0 mm inside the arm's keep-out zone 'floor'" in text and text.endswith("(--to)")


def test_a_target_inside_the_base_servo_is_refused() -> None:
    with pytest.raises(KeepOutError) as info:
        plan(OMX, [OMX.home, (0.03, 0.0, 0.03, -90 * DEG)])
    err = info.value
    assert (err.point, err.zone) == ("tool", "base")
    assert err.depth == pytest.approx(OMX.workspace.base_radius - 0.03)
    assert "8.0 mm inside the arm's keep-out zone 'base'" in describe(err, "cli")


def _refused_sample(arm: Arm, waypoints, **kw) -> tuple[KeepOutError, np.ndarray]:
    """The KeepOutError of planning ``waypoints`` on ``arm``, and the joints of the same
    request planned without zones (the same samples: zones play no part in the timing)."""
    with pytest.raises(KeepOutError) as info:
        plan(arm, waypoints, **kw)
    return info.value, plan(no_zones(arm), waypoints, **kw).joints


def _same_data(arm: Arm, err: KeepOutError, joints: np.ndarray) -> None:
    """The violation's sample is the first whose points enter a zone (computed
    independently), its depth that point's, its position that point's."""
    v = err.violation
    assert v is not None and v.quantity == "keepout" and v.unit == "m" and v.limit == 0.0
    for i in range(v.sample):
        assert max(deepest(arm, joints[i]).values()) <= 1e-9, i
    assert deepest(arm, joints[v.sample])[v.zone] == pytest.approx(v.value, abs=1e-9)
    pts, _ = side_points(arm, joints[v.sample])
    assert np.min(np.linalg.norm(pts - np.array(v.position), axis=1)) < 1e-9
    assert v.t == pytest.approx(v.sample / arm.bus.rate_hz)
    assert (err.zone, err.point, err.depth) == (v.zone, v.point, v.value)


def test_the_floor_refuses_a_joint_centre_under_the_table_with_the_tool_above_it() -> None:
    # the tool 5 mm above the plate pointing 10° up: the wrist lies 1.7 cm below it
    goal = (0.27, 0.0, 0.005, 10 * DEG)
    err, joints = _refused_sample(OMX, [OMX.home, goal])
    _same_data(OMX, err, joints)
    v = err.violation
    assert v.zone == "floor" and v.point == "wrist" and v.joint == "wrist"
    assert v.joint_index == 3
    text = describe(err, "cli")
    assert "the 'wrist' joint" in text and "inside the arm's keep-out zone 'floor'" in text


def test_the_base_refuses_a_link_through_the_base_servo() -> None:
    # tool 5 cm out, 1 cm up, pitch −70°: the wrist–tool link passes within the base's
    # 38 mm of the yaw axis below its top, its ends (tool, wrist) outside the cylinder
    goal = (0.05, 0.0, 0.01, -70 * DEG)
    err, joints = _refused_sample(OMX, [OMX.home, goal])
    _same_data(OMX, err, joints)
    assert err.violation.zone == "base" and err.violation.point == "wrist–tool link"
    assert err.violation.joint is None


def test_a_box_refuses_the_path_between_two_clear_waypoints() -> None:
    arm = omx_with(keep_out=[{"name": "pillar", "min": [0.19, -0.02, 0.0],
                              "max": [0.26, 0.02, 0.2]}])
    start, goal = (0.2, -0.1, 0.1, 0.0), (0.2, 0.1, 0.1, 0.0)
    err, joints = _refused_sample(arm, [start, goal])
    _same_data(arm, err, joints)
    v = err.violation
    assert v.zone == "pillar" and v.segment == (0, 1) and v.waypoint is None
    assert v.field == "waypoints"
    assert "keep-out zone 'pillar'" in describe(err, "si")


def test_the_approach_from_the_present_joints_keeps_out_too() -> None:
    # the arm leaning forward, wrist bent back: the joint-space approach to the first
    # waypoint swings the tool through the plate
    start = [1.174, 0.61, 1.374, -1.614]
    assert max(deepest(OMX, np.array(start)).values()) <= 0.0
    waypoints = [(0.2, 0.0, 0.05, -60 * DEG), (0.2, 0.05, 0.1, -30 * DEG)]
    err, joints = _refused_sample(OMX, waypoints, start_joints=start)
    _same_data(OMX, err, joints)
    assert err.violation.segment is None and err.violation.field == "start_joints"


def test_other_limits_still_come_first_when_earlier() -> None:
    # a fixed duration far too short: a velocity limit at sample 1, long before the floor
    with pytest.raises(PlanError) as info:
        plan(OMX, [OMX.home, (0.25, 0.0, 0.01, 20 * DEG)], profile="quintic",
             duration=0.05)
    assert info.value.code == "velocity_limit"


# -- what is shown as reachable -----------------------------------------------------------------

def test_check_config_plot_shows_only_points_clear_of_the_zones(tmp_path) -> None:
    points = workspace_samples(OMX, per_joint=25)
    unfiltered = kinematics.plane_fk(OMX.chain, np.stack(np.meshgrid(
        *[np.linspace(j.min_angle, j.max_angle, 25) for j in OMX.chain_joints],
        indexing="ij"), axis=-1).reshape(-1, 3))
    assert (unfiltered[:, 1] < -0.15).any()        # the joint limits alone reach far below
    assert len(points) < len(unfiltered)
    assert points[:, 1].min() >= -1e-9             # the tool never below the plate
    rho, z = np.abs(points[:, 0]), points[:, 1]
    assert not ((rho < OMX.workspace.base_radius) & (z < OMX.workspace.base_height)).any()
    from robodcn.plots import plot_workspace
    out = tmp_path / "ws.png"
    plot_workspace(str(out), OMX, points)
    assert out.stat().st_size > 10_000


# -- every accepted plan keeps out --------------------------------------------------------------

#: Joints (rad) whose tool poses make the waypoints: reachable by construction, from high
#: above the plate to through it and into the base.
joints = st.tuples(st.floats(-math.pi, math.pi), st.floats(-1.2, 1.4), st.floats(-1.2, 1.3),
                   st.floats(-1.6, 1.9))
PILLAR = {"name": "pillar", "min": [0.1, -0.05, 0.0], "max": [0.16, 0.05, 0.08]}


@settings(max_examples=150, suppress_health_check=[HealthCheck.too_slow,
                                                   HealthCheck.filter_too_much])
@given(a=joints, b=joints, box=st.booleans())
def test_every_sample_of_an_accepted_plan_is_outside_every_zone(a, b, box) -> None:
    """An accepted plan never enters a zone: from a clear start every sample is outside
    every zone; from a start inside one (where the arm fell) it only leaves."""
    arm = omx_with(keep_out=[PILLAR]) if box else OMX
    wp = kinematics.fk_yawed(OMX.chain, np.array([a, b])).tolist()
    try:
        traj = plan(arm, wp, profile="quintic")
    except PlanError:
        assume(False)
        return
    assert keeps_out(arm, traj.joints)
    if max(deepest(arm, traj.joints[0]).values()) <= 1e-9:     # a start clear of the zones
        for q in traj.joints:
            assert max(deepest(arm, q).values()) <= 1e-9


# -- samples the planner did not sample: a retarget's after its switch --------------------------

def test_check_joints_names_the_first_sample_inside_with_the_users_pose() -> None:
    from robodcn.planner.keepout import check_joints

    below = kinematics.ik_yawed(OMX.chain, np.array([[0.2, 0.0, -0.05, -90 * DEG]]),
                                OMX.elbow)[0]
    home = kinematics.ik_yawed(OMX.chain, np.array([OMX.home]), OMX.elbow)[0]
    joints = home + np.linspace(0.0, 1.0, 101)[:, None] * (below - home)
    check_joints(OMX, joints[:10], 100.0)                    # the first samples are clear
    with pytest.raises(KeepOutError) as info:
        check_joints(OMX, joints, 100.0)
    v = info.value.violation
    assert v is not None and v.quantity == "keepout" and v.field == "waypoints"
    assert v.t == pytest.approx(v.sample / 100.0)
    for i in range(v.sample):
        assert max(deepest(OMX, joints[i]).values()) <= 1e-9
    assert deepest(OMX, joints[v.sample])[v.zone] == pytest.approx(v.value, abs=1e-9)
    assert np.allclose(v.pose, kinematics.fk_yawed(OMX.chain, joints[v.sample][None])[0])


# -- an arm that starts inside a zone may leave it ----------------------------------------------

#: The omx fallen through the plate (the simulator has no table): the tool 14.9 cm under it.
FALLEN = [0.0, 1.2, 0.3, 0.0]


def test_a_plan_from_inside_a_zone_may_leave_it_but_not_go_deeper() -> None:
    assert deepest(OMX, np.array(FALLEN))["floor"] > 0.14
    up = plan(OMX, [(0.2, 0.0, 0.15, 0.0)], start_joints=FALLEN)      # out and up: fine
    assert keeps_out(OMX, up.joints) and max(deepest(OMX, up.joints[-1]).values()) <= 0
    with pytest.raises(KeepOutError) as info:                         # deeper: refused
        plan(OMX, [(0.2, 0.0, -0.17, -90 * DEG)], start_joints=FALLEN)
    assert info.value.zone == "floor"
    # out, then back in through another way: refused where it re-enters
    with pytest.raises(KeepOutError) as info:
        plan(OMX, [(0.2, 0.0, 0.15, 0.0), (0.25, 0.0, -0.02, -90 * DEG)],
             start_joints=FALLEN)
    assert info.value.zone == "floor" and info.value.field == "waypoints[1]"


def test_a_single_pose_inside_a_zone_is_refused_whatever_the_start() -> None:
    from robodcn.planner.keepout import check_pose

    with pytest.raises(KeepOutError) as info:
        check_pose(OMX, FALLEN)
    assert info.value.zone == "floor" and "no plan may go there" in info.value.message


def test_the_leaving_rule_on_joint_motions() -> None:
    from robodcn.config import first_intrusion

    fallen = np.array(FALLEN)
    deeper = np.array([0.0, 1.4, 0.3, 0.0])            # the shoulder further forward: lower
    up = kinematics.ik_yawed(OMX.chain, np.array([[0.2, 0.0, 0.15, 0.0]]), OMX.elbow)[0]
    s = np.linspace(0.0, 1.0, 50)[:, None]
    out = fallen + s * (up - fallen)
    assert keeps_out(OMX, out) and first_intrusion(OMX, out) is None
    down = fallen + s * (deeper - fallen)
    hit = first_intrusion(OMX, down)
    assert not keeps_out(OMX, down) and hit is not None and hit.sample == 1
    assert hit.zone == "floor" and hit.depth > deepest(OMX, fallen)["floor"]
    back = np.vstack([out, out[::-1]])                  # out, then the same way back in
    hit = first_intrusion(OMX, back)
    assert not keeps_out(OMX, back) and hit is not None
    assert hit.sample > 50 and max(deepest(OMX, back[hit.sample - 1]).values()) <= 1e-9
    assert first_intrusion(OMX, fallen[None], motion=False).zone == "floor"
