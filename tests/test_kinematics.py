"""Planar 2R/3R kinematics: FK∘IK round trips, branches, Jacobian, workspace, path continuity."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robodcn import kinematics as K
from robodcn.errors import InputError, UnreachableError

ARMS = {"3r": (0.20, 0.15, 0.05), "2r": (0.15, 0.12)}


def random_joints(rng: np.random.Generator, n: int, k: int) -> np.ndarray:
    q = rng.uniform(-math.pi, math.pi, (n, k))
    # keep away from the singular straight/folded elbow, where the branches coincide
    q[:, 1] = np.sign(q[:, 1]) * np.clip(np.abs(q[:, 1]), 1e-3, math.pi - 1e-3)
    return q


@pytest.mark.parametrize("name", ARMS)
@pytest.mark.parametrize("elbow", K.ELBOWS)
@given(seed=st.integers(0, 2**32 - 1))
@settings(max_examples=25)
def test_fk_of_ik_is_identity(name: str, elbow: str, seed: int) -> None:
    links = ARMS[name]
    rng = np.random.default_rng(seed)
    poses = K.fk(links, random_joints(rng, 200, len(links)))
    q = K.ik(links, poses, elbow)
    back = K.fk(links, q)
    np.testing.assert_allclose(back[:, :2], poses[:, :2], atol=1e-12)
    if len(links) == 3:
        assert np.abs(K.wrap(back[:, 2] - poses[:, 2])).max() < 1e-12
    assert (q[:, 1] <= 0).all() if elbow == "up" else (q[:, 1] >= 0).all()
    assert (np.abs(q) <= math.pi + 1e-12).all()


@pytest.mark.parametrize("name", ARMS)
def test_ik_recovers_the_joints_on_their_branch(name: str) -> None:
    links = ARMS[name]
    q = random_joints(np.random.default_rng(7), 500, len(links))
    poses = K.fk(links, q)
    up, down, ok = K.ik_branches(links, poses)
    assert ok.all()
    mine = np.where((q[:, 1] < 0)[:, None], up, down)
    assert np.abs(K.wrap(mine - q)).max() < 1e-9


def test_jacobian_matches_finite_differences() -> None:
    rng = np.random.default_rng(3)
    for links in ARMS.values():
        q = random_joints(rng, 20, len(links))
        jac = K.jacobian(links, q)
        h = 1e-6
        for j in range(len(links)):
            dq = np.zeros(len(links))
            dq[j] = h
            numeric = (K.fk(links, q + dq) - K.fk(links, q - dq)) / (2 * h)
            np.testing.assert_allclose(jac[:, :, j], numeric, atol=1e-8)


def test_manipulability_is_the_jacobian_determinant() -> None:
    q = random_joints(np.random.default_rng(4), 50, 3)
    links = ARMS["3r"]
    np.testing.assert_allclose(K.manipulability(links, q),
                               np.abs(np.linalg.det(K.jacobian(links, q))), atol=1e-12)
    q2 = q[:, :2]
    np.testing.assert_allclose(K.manipulability(ARMS["2r"], q2),
                               np.abs(np.linalg.det(K.jacobian(ARMS["2r"], q2)[:, :2, :])),
                               atol=1e-12)
    straight = np.array([[0.3, 0.0, 0.1], [0.3, 1e-5, 0.1], [0.3, 0.5, 0.1]])
    np.testing.assert_array_equal(K.near_singular(links, straight), [True, True, False])


def test_workspace_edges() -> None:
    links = ARMS["3r"]
    inner, outer = K.workspace(links)
    assert (inner, outer) == pytest.approx((0.05, 0.35))
    # tool pointing along +x: the wrist sits l3 behind the tool point
    x = np.array([outer + 0.05 - 1e-6, outer + 0.05 + 1e-6, inner + 0.05 - 1e-6, 0.2])
    poses = np.column_stack([x, np.zeros(4), np.zeros(4)])
    np.testing.assert_array_equal(K.reachable(links, poses), [True, False, False, True])
    with pytest.raises(UnreachableError) as info:
        K.ik(links, poses)
    assert info.value.sample == 1
    assert "0.3500" in str(info.value)  # names the reach


def naive_branch_path(up: np.ndarray, down: np.ndarray, first_down: bool) -> np.ndarray:
    """Reference: a per-sample loop choosing the branch nearest the previous choice."""
    out = np.empty(len(up), dtype=bool)
    out[0] = first_down
    prev = down[0] if first_down else up[0]
    for i in range(1, len(up)):
        du = np.sum(K.wrap(up[i] - prev) ** 2)
        dd = np.sum(K.wrap(down[i] - prev) ** 2)
        # ties keep the current branch, as the vectorised version does; so does leaving a
        # singular sample (both branches one), where nearness cannot choose
        singular = np.sum(K.wrap(up[i - 1] - down[i - 1]) ** 2) <= K.SINGULAR_TOLERANCE ** 2
        out[i] = out[i - 1] if singular else (dd <= du) if out[i - 1] else (dd < du)
        prev = down[i] if out[i] else up[i]
    return out


@given(seed=st.integers(0, 2**32 - 1), first=st.booleans(), scale=st.sampled_from([0.05, 0.5, 3]))
@settings(max_examples=60)
def test_vectorised_branch_choice_matches_a_loop(seed: int, first: bool, scale: float) -> None:
    rng = np.random.default_rng(seed)
    up = np.cumsum(rng.normal(0, scale, (80, 3)), axis=0)
    down = up + rng.normal(0, scale, (80, 3)) * rng.integers(0, 2, (80, 1))
    np.testing.assert_array_equal(K.choose_branches(up, down, first),
                                  naive_branch_path(up, down, first))


@pytest.mark.parametrize("gap", [1e-3, 1e-5, 0.0])
def test_path_near_the_straight_arm_keeps_its_branch(gap: float) -> None:
    """The wrist sweeps out to within ``gap`` of full reach and back: no jump, and no branch
    flip while the arm never straightens (gap > 0). Through the exact singularity (gap = 0)
    crossing to the other branch is the smooth continuation, so only continuity is required."""
    links = ARMS["3r"]
    outer = links[0] + links[1]
    s = np.linspace(0.0, 1.0, 2001)
    radius = outer - gap - 0.1 * (2 * s - 1) ** 2
    phi = 0.3 + 0.4 * s
    theta = 0.2 * s
    poses = np.column_stack([radius * np.cos(phi) + links[2] * np.cos(theta),
                             radius * np.sin(phi) + links[2] * np.sin(theta), theta])
    for elbow in K.ELBOWS:
        q = K.ik_path(links, poses, elbow=elbow)
        sign = -1 if elbow == "up" else 1
        if gap > 0:
            assert (sign * q[:, 1] >= 0).all()  # stayed on the requested branch
        else:
            assert sign * q[0, 1] > 0
        np.testing.assert_allclose(K.fk(links, q), poses, atol=1e-12)
        steps = np.abs(np.diff(q, axis=0)).max()
        # q2 ~ √(2·gap-ish) near full reach: steps stay far below a branch switch (2|q2|≈0.5)
        assert steps < 0.05
        up, down, _ = K.ik_branches(links, poses)
        np.testing.assert_array_equal(K.choose_branches(up, down, elbow == "down"),
                                      naive_branch_path(up, down, elbow == "down"))


@given(seed=st.integers(0, 2**32 - 1), near=st.sampled_from([None, 0.0, math.pi, 1e-7]),
       scale=st.sampled_from([0.01, 0.3, 3.0]), with_reference=st.booleans())
@settings(max_examples=80, deadline=None)
def test_ik_path_is_the_nearest_branch_rule(seed: int, near: float | None, scale: float,
                                            with_reference: bool) -> None:
    """ik_path solves one branch unless the path nears a singularity (kinematics doc): it
    equals the both-branch nearest-branch rule, unwrapped, on random joint lines — also
    ones that start at, or within 1e-7 rad of, a stretched or folded elbow."""
    rng = np.random.default_rng(seed)
    for name, links in ARMS.items():
        k = len(links)
        q0 = rng.uniform(-math.pi, math.pi, k)
        if near is not None:
            q0[1] = near
        q1 = q0 + rng.normal(0.0, scale, k)
        s = np.linspace(0.0, 1.0, int(rng.integers(2, 200)))[:, None]
        poses = K.fk(links, q0 + s * (q1 - q0))
        reference = q0 + rng.normal(0.0, 0.1, k) if with_reference else None
        for elbow in K.ELBOWS:
            q = K.ik_path(links, poses, reference=reference, elbow=elbow)
            up, down, _ = K.ik_branches(links, poses)
            if reference is None:
                first = elbow == "down"
            else:
                d_up = np.sum(K.wrap(up[0] - reference) ** 2)
                d_dn = np.sum(K.wrap(down[0] - reference) ** 2)
                first = bool(d_dn < d_up) if abs(d_dn - d_up) > K.SINGULAR_TOLERANCE ** 2 \
                    else elbow == "down"
            on_down = naive_branch_path(up, down, first)
            chosen = np.where(on_down[:, None], down, up)
            expected = np.unwrap(chosen, axis=0)
            target = np.zeros(k) if reference is None else reference
            expected += 2 * math.pi * np.round((target - expected[0]) / (2 * math.pi))
            np.testing.assert_allclose(q, expected, atol=1e-9, err_msg=f"{name} {elbow}")


@given(seed=st.integers(0, 2**32 - 1), near=st.sampled_from([None, 0.0, 1e-7]),
       with_reference=st.booleans(), unreachable=st.booleans())
@settings(max_examples=60, deadline=None)
def test_stacked_paths_solve_as_each_alone(seed: int, near: float | None,
                                           with_reference: bool, unreachable: bool) -> None:
    """ik_paths_unchecked gives every stacked path exactly (bit for bit) what
    ik_path_unchecked gives it alone: paths of one start sampled at different counts (the
    search's use), and unrelated paths, near singularities and out of reach too."""
    rng = np.random.default_rng(seed)
    for links in ARMS.values():
        k = len(links)
        q0 = rng.uniform(-math.pi, math.pi, k)
        if near is not None:
            q0[1] = near
        q1 = q0 + rng.normal(0.0, 0.5, k)
        counts = [int(c) for c in rng.integers(2, 60, 3)]
        paths = [K.fk(links, q0 + np.linspace(0.0, 1.0, c)[:, None] * (q1 - q0))
                 for c in counts]
        if rng.random() < 0.3:  # an unrelated path among them
            paths[1] = K.fk(links, rng.uniform(-math.pi, math.pi, (counts[1], k)))
        if unreachable:
            paths[2][rng.integers(0, counts[2])] += [1.0, 0.0, 0.0]
        reference = q0 + rng.normal(0.0, 0.1, k) if with_reference else None
        limits = [(-3.0, 3.0)] * k
        for elbow in K.ELBOWS:
            together = K.ik_paths_unchecked(links, np.concatenate(paths), counts, reference,
                                            elbow, limits)
            for path, (q, bad) in zip(paths, together, strict=True):
                q_alone, bad_alone = K.ik_path_unchecked(links, path, reference, elbow, limits)
                assert bad == bad_alone
                if q_alone is None:
                    assert q is None
                else:
                    np.testing.assert_array_equal(q, q_alone)


def test_path_is_unwrapped_around_the_base() -> None:
    """Two full turns of the tool about the base: joints grow continuously past ±π."""
    links = ARMS["3r"]
    phi = np.linspace(0.0, 4 * math.pi, 4001)
    poses = np.column_stack([0.28 * np.cos(phi), 0.28 * np.sin(phi), phi])
    q = K.ik_path(links, poses)
    assert np.abs(np.diff(q, axis=0)).max() < 0.01
    assert q[-1, 0] - q[0, 0] == pytest.approx(4 * math.pi)
    np.testing.assert_allclose(K.fk(links, q)[:, :2], poses[:, :2], atol=1e-12)


def test_first_sample_follows_the_reference() -> None:
    links = ARMS["3r"]
    poses = K.fk(links, np.array([[0.4, 1.0, -0.5], [0.45, 0.9, -0.4]]))
    up, down, _ = K.ik_branches(links, poses)
    # a reference near the down branch, two turns away, picks that branch and that turn
    q = K.ik_path(links, poses, reference=down[0] + 4 * math.pi + 0.01, elbow="up")
    np.testing.assert_allclose(q[0], down[0] + 4 * math.pi, atol=1e-12)
    # without one: the elbow preference, shifted towards the middle of the limits
    q = K.ik_path(links, poses, elbow="up", limits=[(5.0, 7.0), (-1, 1), (-1, 1)])
    np.testing.assert_allclose(q[0], up[0] + [2 * math.pi, 0, 0], atol=1e-12)
    with pytest.raises(InputError):
        K.ik_path(links, poses, reference=[0.0, 0.0])


def test_two_link_arm_ignores_theta() -> None:
    links = ARMS["2r"]
    poses = np.array([[0.2, 0.05, 0.0], [0.2, 0.05, 2.0]])
    q = K.ik(links, poses)
    np.testing.assert_array_equal(q[0], q[1])


def test_bad_shapes_are_named() -> None:
    with pytest.raises(InputError) as info:
        K.fk(ARMS["3r"], np.zeros((4, 2)))
    assert info.value.field == "q"
    with pytest.raises(InputError) as info:
        K.ik(ARMS["3r"], np.zeros((4, 2)))
    assert info.value.field == "poses"
    with pytest.raises(InputError) as info:
        K.ik((0.1, -0.2), np.zeros((1, 3)))
    assert info.value.field == "links"


def test_orientation_at_and_near_the_half_turn() -> None:
    """θ = ±π puts tan(θ/2) (used for the wrist point) at its pole; IK must not care."""
    links = ARMS["3r"]
    theta = np.array([math.pi, -math.pi, math.pi - 1e-12, math.pi + 1e-12, 3 * math.pi,
                      -101 * math.pi, math.nextafter(math.pi, 4.0)])
    poses = np.column_stack([np.full(theta.size, 0.2), np.full(theta.size, 0.1), theta])
    for elbow in K.ELBOWS:
        back = K.fk(links, K.ik(links, poses, elbow))
        np.testing.assert_allclose(back[:, :2], poses[:, :2], atol=1e-13)
        assert np.abs(K.wrap(back[:, 2] - theta)).max() < 1e-12
