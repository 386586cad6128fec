"""Yawed-arm kinematics on the OpenMANIPULATOR-X: published geometry, ROBOTIS's signs, round
trips on both branches, the plane helpers and the refusals (axis, over the top, reach)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from robodcn import kinematics
from robodcn.config import load_arm
from robodcn.errors import InputError, UnreachableError

OMX = Path(__file__).resolve().parent.parent / "configs" / "omx.toml"
ARM = load_arm(OMX)
CHAIN = ARM.chain
LIMITS = np.array([(j.min_angle, j.max_angle) for j in ARM.joints])
#: q_elbow ≥ α2 − α1 is the "up" branch (module notes of kinematics._yawed).
ELBOW_SPLIT = float(CHAIN.offsets[1])


def joints_in(lo: np.ndarray, hi: np.ndarray, n: int):
    return hnp.arrays(np.float64, (n, 4), elements=st.floats(0.0, 1.0)).map(
        lambda u: lo + u * (hi - lo))


def test_fk_at_zero_is_the_published_tool_point() -> None:
    pose = kinematics.fk_yawed(CHAIN, np.zeros((1, 4)))[0]
    np.testing.assert_allclose(pose, [0.274, 0.0, 0.2045, 0.0], atol=1e-12)
    # the wrist joint at zero (omx.md table): the first two links alone
    wrist = kinematics.Chain(CHAIN.links[:2], CHAIN.shoulder_height)
    np.testing.assert_allclose(kinematics.plane_fk(wrist, np.zeros((1, 2)))[0, :2],
                               [0.148, 0.2045], atol=1e-12)
    assert CHAIN.lengths[0] == pytest.approx(0.1302, abs=1e-4)
    assert math.degrees(math.pi / 2 - CHAIN.angles[0]) == pytest.approx(10.62, abs=0.01)


def test_robotis_signs() -> None:
    q = np.zeros((4, 4))
    q[1, 0] = math.pi / 2          # yaw +90°: CCW from above, the tool swings to +y
    q[2, 1] = 0.1                  # shoulder +: forward and down
    q[3, 3] = 0.3                  # wrist +: the tool tips down
    zero, yaw, shoulder, wrist = kinematics.fk_yawed(CHAIN, q)
    np.testing.assert_allclose(yaw[:2], [0.0, 0.274], atol=1e-12)
    assert shoulder[2] < zero[2] and shoulder[3] < 0.0
    assert wrist[3] == pytest.approx(-0.3) and wrist[2] < zero[2]


def test_home_is_robotis_init_pose() -> None:
    q = kinematics.ik_yawed(CHAIN, [ARM.home], ARM.elbow)[0]
    np.testing.assert_allclose(q, [0.0, -1.05, 0.35, 0.70], atol=1e-3)
    assert q[2] >= ELBOW_SPLIT  # the natural OM-X branch is "up"


@settings(max_examples=60, deadline=None)
@given(joints_in(LIMITS[:, 0], LIMITS[:, 1], 8))
def test_ik_of_fk_is_identity_on_the_chosen_branch(q: np.ndarray) -> None:
    poses = kinematics.fk_yawed(CHAIN, q)
    r = kinematics.plane_fk(CHAIN, q[:, 1:])[:, 0]   # signed: < 0 leans back over the top
    keep = (r > 1e-3) & (np.abs(poses[:, 3]) < math.pi / 2 - 1e-6)
    keep &= np.abs(q[:, 2] - ELBOW_SPLIT) > 1e-3      # away from the stretched singularity
    q, poses = q[keep], poses[keep]
    branch = np.where(q[:, 2] >= ELBOW_SPLIT, "up", "down")
    for elbow in ("up", "down"):
        mine = branch == elbow
        if mine.any():
            back = kinematics.ik_yawed(CHAIN, poses[mine], elbow)
            np.testing.assert_allclose(kinematics.wrap(back - q[mine]), 0.0, atol=1e-7)


def test_a_pose_leaned_back_over_the_top_is_refused() -> None:
    q = np.array([[0.3, -1.5, -0.5, 0.0]])           # within limits, tool behind the axis
    assert kinematics.plane_fk(CHAIN, q[:, 1:])[0, 0] < 0.0
    pose = kinematics.fk_yawed(CHAIN, q)
    assert abs(pose[0, 3]) > math.pi / 2             # the tool points back over the base
    with pytest.raises(UnreachableError, match="over the top"):
        kinematics.ik_yawed(CHAIN, pose)


@settings(max_examples=60, deadline=None)
@given(hnp.arrays(np.float64, (16, 4), elements=st.floats(-1.0, 1.0)))
def test_fk_of_ik_is_identity_on_reachable_poses(u: np.ndarray) -> None:
    poses = u * np.array([0.4, 0.4, 0.4, math.pi / 2]) + np.array([0.0, 0.0, 0.1, 0.0])
    ok = kinematics.reachable_yawed(CHAIN, poses)
    up, down, ok2 = kinematics.ik_yawed_branches(CHAIN, poses)
    np.testing.assert_array_equal(ok, ok2)
    assert np.isnan(up[~ok]).all() and not np.isnan(up[ok]).any()
    for q in (up[ok], down[ok]):
        back = kinematics.fk_yawed(CHAIN, q)
        np.testing.assert_allclose(back[:, :3], poses[ok, :3], atol=1e-9)
        np.testing.assert_allclose(kinematics.wrap(back[:, 3] - poses[ok, 3]), 0.0, atol=1e-9)


def test_plane_helpers_round_trip_and_the_path_yaw_is_continuous() -> None:
    poses = np.array([[0.2, 0.1, 0.1, 0.3], [-0.1, -0.2, 0.2, -0.5], [0.0, 0.15, 0.0, 0.0]])
    plane = kinematics.to_plane(poses)
    np.testing.assert_allclose(plane[:, 1], np.hypot(poses[:, 0], poses[:, 1]))
    np.testing.assert_allclose(kinematics.from_plane(plane), poses, atol=1e-15)
    # a path crossing yaw = ±π behind the base: the yaw joint turns on, it does not jump
    yaw = np.linspace(math.radians(170), math.radians(190), 21)
    path = kinematics.from_plane(np.column_stack(
        [yaw, np.full(21, 0.2), np.full(21, 0.15), np.zeros(21)]))
    q = kinematics.ik_yawed_path(CHAIN, path, reference=np.array([2.9, -0.5, 0.5, 0.0]))
    np.testing.assert_allclose(q[:, 0], yaw, atol=1e-12)
    np.testing.assert_allclose(kinematics.fk_yawed(CHAIN, q), path, atol=1e-12)
    unwrapped = kinematics.unwrap_yaw(kinematics.wrap(yaw), reference=-2 * math.pi + 3.0)
    np.testing.assert_allclose(unwrapped, yaw - 2 * math.pi, atol=1e-12)


def test_path_ik_keeps_the_branch_of_the_reference() -> None:
    path = np.column_stack([np.linspace(0.15, 0.25, 11), np.zeros(11), np.full(11, 0.15),
                            np.zeros(11)])
    up = kinematics.ik_yawed_path(CHAIN, path, elbow="up")
    down = kinematics.ik_yawed_path(CHAIN, path, reference=kinematics.ik_yawed(
        CHAIN, path[:1], "down")[0])
    # up: the elbow turned by q2 − (α2 − α1) ∈ [0, π] from the straight chain; down: ∈ [−π, 0]
    assert (kinematics.wrap(up[:, 2] - ELBOW_SPLIT) > 0).all()
    assert (kinematics.wrap(down[:, 2] - ELBOW_SPLIT) < 0).all()
    np.testing.assert_allclose(kinematics.ik_yawed(CHAIN, path, "up"), up, atol=1e-12)
    q, bad = kinematics.try_ik_yawed_path(CHAIN, np.vstack([path, [[0.5, 0, 0.1, 0]]]))
    assert q is None and bad == 11


@pytest.mark.parametrize(("pose", "phrase"), [
    ((0.0, 0.0, 0.3, 0.0), "on the yaw axis"),
    ((0.1, 0.05, 0.3, math.radians(120.0)), "over the top"),
    ((0.1, 0.0, 0.3, math.radians(-95.0)), "over the top"),
    ((0.5, 0.0, 0.3, 0.0), "out of reach"),
])
def test_refusals_name_the_pose_and_why(pose: tuple[float, ...], phrase: str) -> None:
    poses = np.array([[0.2, 0.0, 0.15, 0.0], pose])
    with pytest.raises(UnreachableError) as info:
        kinematics.ik_yawed(CHAIN, poses)
    err = info.value
    assert err.sample == 1 and err.pose == list(pose) and phrase in str(err)
    assert f"x={pose[0]:.4f} m" in str(err) and "pitch=" in str(err)
    assert not kinematics.reachable_yawed(CHAIN, poses)[1]
    assert kinematics.why_unreachable(CHAIN, pose) is not None
    assert kinematics.why_unreachable(CHAIN, poses[0]) is None


def test_straight_down_is_not_over_the_top() -> None:
    pose = np.array([[0.2, 0.0, 0.05, -math.pi / 2]])
    np.testing.assert_allclose(kinematics.fk_yawed(CHAIN, kinematics.ik_yawed(CHAIN, pose)),
                               pose, atol=1e-12)


def test_bad_shapes_and_chains_are_input_errors() -> None:
    with pytest.raises(InputError):
        kinematics.fk_yawed(CHAIN, np.zeros((1, 3)))
    with pytest.raises(InputError):
        kinematics.ik_yawed(CHAIN, np.zeros((1, 3)))
    with pytest.raises(InputError):
        kinematics.Chain(((0.0, 0.0), (0.1, 0.0)), 0.05)
    with pytest.raises(InputError):
        kinematics.Chain(((0.1, 0.0),), 0.05)


def test_two_link_yawed_chain_reaches_positions() -> None:
    chain = kinematics.Chain(((0.0, 0.15), (0.12, 0.0)), 0.05)
    pose = np.array([[0.1, 0.1, 0.2, 1.0]])        # pitch ignored by the IK
    q = kinematics.ik_yawed(chain, pose)
    np.testing.assert_allclose(kinematics.fk_yawed(chain, q)[:, :3], pose[:, :3], atol=1e-12)
