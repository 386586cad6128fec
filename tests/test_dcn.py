"""DCN algebra: one test (at least) for every row of design.md §2, checked against
independent formulas (3×3 matrices, complex arithmetic, dual quaternions)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from strategies import angle, coordinate, poses

from robodcn import dcn, dualquat, se2
from robodcn.errors import DegenerateError, InputError

TOL = 1e-12


def same_motion(p, q, tol=TOL):
    """p and q encode the same rigid motion (p = ±q)."""
    p, q = np.asarray(p), np.asarray(q)
    return min(np.abs(p - q).max(), np.abs(p + q).max()) < tol


# -- group laws and the product --------------------------------------------------------------

@given(poses(), poses(), poses())
def test_product_is_associative(a, b, c):
    p, q, r = dcn.from_pose(a), dcn.from_pose(b), dcn.from_pose(c)
    assert np.allclose(dcn.mul(dcn.mul(p, q), r), dcn.mul(p, dcn.mul(q, r)), atol=1e-12)


@given(poses())
def test_identity_and_inverse(a):
    p = dcn.from_pose(a)
    one = dcn.identity()
    assert np.allclose(dcn.mul(p, one), p, atol=TOL)
    assert np.allclose(dcn.mul(one, p), p, atol=TOL)
    assert np.allclose(dcn.mul(p, dcn.inv(p)), one, atol=TOL)
    assert np.allclose(dcn.mul(dcn.inv(p), p), one, atol=TOL)


@given(poses(), poses())
def test_product_matches_matrices(a, b):
    """φ(p·q) = φ(p)·φ(q): the DCN product is composition of 3×3 rigid motions."""
    p, q = dcn.from_pose(a), dcn.from_pose(b)
    assert np.allclose(dcn.to_matrix(dcn.mul(p, q)), dcn.to_matrix(p) @ dcn.to_matrix(q),
                       atol=1e-12)
    # ... and the matrices are the usual ones built from the poses.
    assert np.allclose(dcn.to_matrix(p), se2.from_pose(a), atol=1e-12)


@given(poses(), poses())
def test_product_formula_in_complex_arithmetic(a, b):
    p, q = dcn.from_pose(a), dcn.from_pose(b)
    p0, p1 = p[0] + 1j * p[1], p[2] + 1j * p[3]
    q0, q1 = q[0] + 1j * q[1], q[2] + 1j * q[3]
    expected = [p0 * q0, p1 * np.conj(q0) + p0 * q1]
    got = dcn.mul(p, q)
    assert np.allclose([got[0] + 1j * got[1], got[2] + 1j * got[3]], expected, atol=1e-12)


@given(poses(), poses())
def test_involution_is_an_anti_automorphism(a, b):
    p, q = dcn.from_pose(a), dcn.from_pose(b)
    assert np.allclose(dcn.conj(dcn.conj(p)), p)
    assert np.allclose(dcn.conj(dcn.mul(p, q)), dcn.mul(dcn.conj(q), dcn.conj(p)), atol=1e-12)


@given(poses(), poses())
def test_norm_is_multiplicative_and_one_on_poses(a, b):
    p, q = dcn.from_pose(a), dcn.from_pose(b)
    assert dcn.norm(p) == pytest.approx(1.0, abs=1e-15)
    assert dcn.norm(dcn.mul(2.0 * p, 3.0 * q)) == pytest.approx(6.0, rel=1e-14)


# -- action, poses, matrices, rotation about a point ----------------------------------------

@given(poses(), st.tuples(coordinate, coordinate))
def test_action_matches_matrix(a, v):
    p = dcn.from_pose(a)
    m = se2.from_pose(a)
    expected = m[:2, :2] @ np.asarray(v) + m[:2, 2]
    assert np.allclose(dcn.act(p, v), expected, atol=1e-12)
    assert np.allclose(dcn.act(-p, v), expected, atol=1e-12)  # p and −p: same motion


@given(poses(), poses(), st.tuples(coordinate, coordinate))
def test_composition_order_applies_right_factor_first(a, b, v):
    p, q = dcn.from_pose(a), dcn.from_pose(b)
    assert np.allclose(dcn.act(dcn.mul(p, q), v), dcn.act(p, dcn.act(q, v)), atol=1e-11)


@given(poses(n=4))
def test_pose_round_trip_is_vectorised(a):
    back = dcn.to_pose(dcn.from_pose(a))
    assert back.shape == (4, 3)
    assert np.allclose(back[:, :2], a[:, :2], atol=1e-12)
    assert np.allclose(np.exp(1j * back[:, 2]), np.exp(1j * a[:, 2]), atol=1e-12)
    assert np.all((back[:, 2] > -np.pi) & (back[:, 2] <= np.pi))


@given(poses())
def test_matrix_round_trip(a):
    p = dcn.from_pose(a)
    assert same_motion(dcn.from_matrix(dcn.to_matrix(p)), p)


@given(st.tuples(coordinate, coordinate), angle, st.tuples(coordinate, coordinate))
def test_rotation_about_a_point_fixes_it_and_rotates_others(c, theta, v):
    r = dcn.rotation_about(c, theta)
    assert np.allclose(dcn.act(r, c), c, atol=1e-12)
    moved = dcn.act(r, v)
    turned = np.exp(1j * theta) * complex(*(np.asarray(v) - c))
    expected = np.asarray(c) + np.array([turned.real, turned.imag])
    assert np.allclose(moved, expected, atol=1e-11)


# -- exp and log ------------------------------------------------------------------------------

@given(poses())
def test_exp_of_log_is_identity(a):
    p = dcn.from_pose(a)
    assert np.allclose(dcn.exp(dcn.log(p)), p, atol=1e-12)


@pytest.mark.parametrize("theta", [0.0, 1e-12, -3e-9, 1e-5, 0.3, np.pi / 2 - 1e-9,
                                   -np.pi / 2 + 1e-12, np.pi / 2, 3.0, -3.1])
def test_log_of_exp_is_identity_near_special_angles(theta):
    x = np.array([0.0, theta, 0.37, -1.2])  # θi + x1ε
    assert np.allclose(dcn.log(dcn.exp(x)), x, atol=1e-12)
    p = dcn.exp(x)
    assert np.allclose(dcn.exp(dcn.log(p)), p, atol=1e-12)


def test_exp_small_angle_series_is_continuous():
    x1 = 0.8 - 0.3j
    below = dcn.exp([0.0, 0.99e-4, x1.real, x1.imag])
    above = dcn.exp([0.0, 1.01e-4, x1.real, x1.imag])
    assert np.abs(below - above).max() < 3e-4  # no jump at the series switch
    exact = np.sin(0.99e-4) / 0.99e-4 * x1
    assert below[2] + 1j * below[3] == pytest.approx(exact, abs=1e-15)


def test_exp_is_the_matrix_exponential_of_the_twist():
    """exp(θi + x1ε) acts like the SE(2) exponential of the matching twist."""
    theta, x1 = 0.7, 0.4 + 0.25j
    p = dcn.exp([0.0, theta, x1.real, x1.imag])
    # The one-parameter group t ↦ exp(t·x) moves the origin with velocity 2·x1 at t = 0
    # (translation 2·p0·p1) while turning at 2θ: the twist (2·x1, 2θ).
    twist = np.array([2 * x1.real, 2 * x1.imag, 2 * theta])
    assert np.allclose(dcn.to_matrix(p), se2.exp(twist), atol=1e-12)


def test_log_at_a_full_half_turn_with_translation_is_degenerate():
    with pytest.raises(DegenerateError):
        dcn.log([-1.0, 0.0, 0.3, 0.0])
    assert np.allclose(dcn.log([-1.0, 0.0, 0.0, 0.0]), [0.0, np.pi, 0.0, 0.0])


# -- SLERP ------------------------------------------------------------------------------------

@given(poses(), poses())
def test_slerp_hits_both_ends(a, b):
    p, q = dcn.from_pose(a), dcn.from_pose(b)
    assert same_motion(dcn.slerp(p, q, 0.0), p)
    assert same_motion(dcn.slerp(p, q, 1.0), q, tol=1e-11)


@given(poses(), poses(), st.lists(st.floats(-0.5, 1.5), min_size=1, max_size=8))
def test_slerp_equals_dual_quaternion_sclerp_under_the_embedding(a, b, ts):
    p, q = dcn.from_pose(a), dcn.from_pose(b)
    t = np.asarray(ts)
    for turn in dcn.TURNS:
        got = dcn.to_dualquat(dcn.slerp(p, q, t, turn=turn))
        want = dualquat.sclerp(dcn.to_dualquat(p), dcn.to_dualquat(q), t, turn=turn)
        # Turning the long way to nearly a whole turn, sin(tφ)/sin(φ) has condition number
        # 1/|sin φ|: rounding in φ is amplified by it in both algebras alike.
        d = dcn.align(dcn.mul(q, dcn.inv(p)), turn)
        half = abs(np.arctan2(d[1], d[0]))
        condition = 1.0 if half <= np.pi / 2 else 1.0 / max(np.sin(half), 1e-300)
        assert np.abs(got - want).max() < 1e-12 * condition * max(1.0, np.abs(want).max())


def test_slerp_turn_rule_at_a_half_turn():
    p = dcn.from_pose([0.0, 0.0, 0.5])
    q = dcn.from_pose([1.0, 0.0, 0.5 + np.pi])
    half = dcn.to_pose(dcn.slerp(p, q, 0.5, turn="shortest"))
    assert half[2] == pytest.approx(0.5 + np.pi / 2)  # exact half turn: counter-clockwise
    assert dcn.to_pose(dcn.slerp(p, q, 0.5, turn="ccw"))[2] == pytest.approx(0.5 + np.pi / 2)
    assert dcn.to_pose(dcn.slerp(p, q, 0.5, turn="cw"))[2] == pytest.approx(0.5 - np.pi / 2)


def test_slerp_long_way_round():
    p = dcn.from_pose([0.0, 0.0, 0.0])
    q = dcn.from_pose([0.0, 0.0, 0.5])
    mid_ccw = dcn.to_pose(dcn.slerp(p, q, 0.5, turn="ccw"))[2]
    mid_cw = dcn.to_pose(dcn.slerp(p, q, 0.5, turn="cw"))[2]
    assert mid_ccw == pytest.approx(0.25)
    assert mid_cw == pytest.approx(dcn.wrap_angle(0.5 * (0.5 - 2 * np.pi)))


# -- DLB --------------------------------------------------------------------------------------

@settings(max_examples=50)
@given(poses(n=4), poses(), st.lists(st.floats(0.1, 2.0), min_size=4, max_size=4))
def test_dlb_is_bi_invariant(a, b, w):
    ps = dcn.from_pose(a)
    p0 = dcn.from_pose(b)
    try:
        blended = dcn.dlb(ps, w)
    except DegenerateError:
        return
    assert same_motion(dcn.mul(p0, blended), dcn.dlb(dcn.mul(p0, ps), w), tol=1e-10)
    assert same_motion(dcn.mul(blended, p0), dcn.dlb(dcn.mul(ps, p0), w), tol=1e-10)


@given(poses(n=3))
def test_dlb_ignores_signs_and_returns_a_unit(a):
    ps = dcn.from_pose(a)
    flipped = ps * np.array([1.0, -1.0, 1.0])[:, None]
    w = [0.5, 0.3, 0.2]
    try:
        blended = dcn.dlb(ps, w)
    except DegenerateError:
        return
    assert same_motion(dcn.dlb(flipped, w), blended)
    assert dcn.norm(blended) == pytest.approx(1.0)


def test_dlb_with_a_single_weight_is_that_motion():
    ps = dcn.from_pose([[0.1, 0.2, 0.3], [1.0, -1.0, 2.0]])
    assert same_motion(dcn.dlb(ps, [0.0, 3.0]), ps[1])


def test_dlb_zero_denominator_raises():
    ps = dcn.from_pose([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    with pytest.raises(DegenerateError, match="weights"):
        dcn.dlb(ps, [1.0, -1.0])


# -- embedding into dual quaternions ---------------------------------------------------------

@given(poses(), poses(), st.tuples(coordinate, coordinate))
def test_embedding_commutes_with_products_and_actions(a, b, v):
    p, q = dcn.from_pose(a), dcn.from_pose(b)
    zp, zq = dcn.to_dualquat(p), dcn.to_dualquat(q)
    assert np.allclose(dcn.to_dualquat(dcn.mul(p, q)), dualquat.mul(zp, zq), atol=1e-12)
    moved = dualquat.transform(zp, [v[0], v[1], 0.0])
    assert np.allclose(moved[:2], dcn.act(p, v), atol=1e-11)
    assert moved[2] == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(dcn.from_dualquat(zp), p)


# -- bad input --------------------------------------------------------------------------------

@pytest.mark.parametrize("call, field", [
    (lambda: dcn.from_pose([0.0, np.nan, 0.0]), "pose"),
    (lambda: dcn.from_pose([0.0, 1.0]), "pose"),
    (lambda: dcn.mul(dcn.identity(), dcn.inv([2.0, 0.0, 0.0, 0.0])), "p"),
    (lambda: dcn.slerp(dcn.identity(), dcn.identity(), 0.5, turn="left"), "turn"),
    (lambda: dcn.slerp(dcn.identity(), [1.0, 1e-4, 0.0, 0.0], 0.5), "q"),
    (lambda: dcn.slerp(dcn.identity(), dcn.identity(), np.inf), "t"),
    (lambda: dcn.act(dcn.identity(), [1.0, 2.0, 3.0]), "v"),
    (lambda: dcn.dlb(dcn.from_pose([[0, 0, 0]]), [1.0, 2.0]), "weights"),
    (lambda: dcn.from_matrix(np.eye(2)), "m"),
    (lambda: dcn.from_matrix(np.diag([1.0, 2.0, 1.0])), "m"),
    (lambda: dcn.from_dualquat([1.0, 0.5, 0, 0, 0, 0, 0, 0]), "dq"),
    (lambda: dcn.from_pose("north"), "pose"),
])
def test_bad_input_raises_naming_the_argument(call, field):
    with pytest.raises(InputError) as info:
        call()
    assert info.value.field == field
    assert field in str(info.value)


def test_nearly_unit_input_is_renormalised():
    p = np.array([1.0 + 5e-10, 0.0, 0.2, 0.1])
    assert dcn.norm(dcn.inv(p)) == pytest.approx(1.0, abs=1e-15)
