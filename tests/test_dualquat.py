"""Dual quaternions: group laws, conjugates, exp/log/power/Cayley against the matrix
exponential of se(3), and the interpolators (design.md §3)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from robodcn import dualquat as dq
from robodcn.errors import DegenerateError, InputError

vec3 = hnp.arrays(np.float64, 3, elements=st.floats(-3.0, 3.0))
vec4 = hnp.arrays(np.float64, 4, elements=st.floats(-1.0, 1.0)).filter(
    lambda q: np.linalg.norm(q) > 0.1)


@st.composite
def motions(draw):
    q = draw(vec4)
    return dq.from_rt(q / np.linalg.norm(q), draw(vec3))


def rotation_matrix(q):
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def homogeneous(z):
    q, t = dq.to_rt(z)
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rotation_matrix(q), t
    return m


def expm(a):
    """Matrix exponential by scaling and squaring a Taylor series (independent of dq)."""
    norm = np.abs(a).sum(axis=1).max()
    k = max(0, int(np.ceil(np.log2(max(norm, 1e-300)))) + 1)
    b = a / 2.0 ** k
    term, out = np.eye(len(a)), np.eye(len(a))
    for n in range(1, 30):
        term = term @ b / n
        out = out + term
    for _ in range(k):
        out = out @ out
    return out


def twist_matrix(omega, v):
    w = np.array([[0, -omega[2], omega[1]], [omega[2], 0, -omega[0]], [-omega[1], omega[0], 0]])
    m = np.zeros((4, 4))
    m[:3, :3], m[:3, 3] = w, v
    return m


def same_motion(a, b, tol=1e-11):
    return min(np.abs(a - b).max(), np.abs(a + b).max()) < tol


# -- group laws and conjugates ----------------------------------------------------------------

@given(motions(), motions(), motions())
def test_group_laws(a, b, c):
    assert np.allclose(dq.mul(dq.mul(a, b), c), dq.mul(a, dq.mul(b, c)), atol=1e-12)
    assert np.allclose(dq.mul(a, dq.inv(a)), dq.identity(), atol=1e-12)
    assert np.allclose(dq.mul(dq.identity(), a), a)


@given(motions(), motions())
def test_product_is_composition_of_homogeneous_matrices(a, b):
    assert np.allclose(homogeneous(dq.mul(a, b)), homogeneous(a) @ homogeneous(b), atol=1e-11)


@given(hnp.arrays(np.float64, 8, elements=st.floats(-2, 2)),
       hnp.arrays(np.float64, 8, elements=st.floats(-2, 2)))
def test_the_three_conjugates(a, b):
    ab = dq.mul(a, b)
    # quaternion and combined conjugates reverse products; the dual conjugate keeps the order
    assert np.allclose(dq.conj(ab, "quaternion"),
                       dq.mul(dq.conj(b, "quaternion"), dq.conj(a, "quaternion")), atol=1e-10)
    assert np.allclose(dq.conj(ab, "combined"),
                       dq.mul(dq.conj(b, "combined"), dq.conj(a, "combined")), atol=1e-10)
    assert np.allclose(dq.conj(ab, "dual"), dq.mul(dq.conj(a, "dual"), dq.conj(b, "dual")),
                       atol=1e-10)
    assert np.allclose(dq.conj(dq.conj(a, "quaternion"), "dual"), dq.conj(a, "combined"))


@given(motions(), vec3)
def test_point_sandwich_is_rotate_then_translate(z, v):
    q, t = dq.to_rt(z)
    assert np.allclose(dq.transform(z, v), rotation_matrix(q) @ v + t, atol=1e-11)


@given(vec4, vec3)
def test_from_rt_round_trip_uses_half_t_q(q, t):
    q = q / np.linalg.norm(q)
    z = dq.from_rt(q, t)
    back_q, back_t = dq.to_rt(z)
    assert np.allclose(back_q, q) and np.allclose(back_t, t, atol=1e-12)
    assert np.allclose(z[4:], 0.5 * dq.qmul(np.r_[0.0, t], q))
    assert np.allclose(dq.norm(z), [1.0, 0.0], atol=1e-12)


def test_norm_is_a_dual_number():
    z = dq.from_rt([0.6, 0.0, 0.8, 0.0], [1.0, 2.0, 3.0])
    scaled = 2.0 * z + np.r_[np.zeros(4), 0.5 * z[:4]]  # (2 + 0.5ε)·z
    assert np.allclose(dq.norm(scaled), [2.0, 0.5])


# -- exp, log, power, Cayley ------------------------------------------------------------------

@settings(max_examples=60)
@given(hnp.arrays(np.float64, 3, elements=st.floats(-2.0, 2.0)), vec3)
def test_exp_matches_matrix_exponential_of_se3_twist(omega, v):
    z = dq.exp(0.5 * np.r_[0.0, omega, 0.0, v])
    assert np.allclose(homogeneous(z), expm(twist_matrix(omega, v)), atol=1e-10)


@settings(max_examples=60)
@given(hnp.arrays(np.float64, 3, elements=st.floats(-2.0, 2.0)), vec3)
def test_log_recovers_the_twist(omega, v):
    x = 0.5 * np.r_[0.0, omega, 0.0, v]
    assert np.allclose(dq.log(dq.exp(x)), x, atol=1e-10)


@given(motions())
def test_exp_of_log_is_identity(z):
    # Next to a full turn (q_r → −1) the perpendicular dual part of log grows like
    # π/|a1|: ill-conditioned, so there the same motion −z is used (as ScLERP does).
    if z[0] < -1.0 + 1e-6:
        z = -z
    assert np.allclose(dq.exp(dq.log(z)), z, atol=1e-11)


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-9, 1e-6, 1e-3, np.pi / 2, np.pi - 1e-6])
def test_exp_log_near_the_a1_equals_zero_cases(angle):
    axis = np.array([0.2, -0.5, 0.84])
    axis /= np.linalg.norm(axis)
    x = np.r_[0.0, 0.5 * angle * axis, 0.0, 0.3, -0.2, 0.7]
    assert np.allclose(dq.log(dq.exp(x)), x, atol=1e-10)
    omega, v = angle * axis, 2 * x[5:]
    assert np.allclose(homogeneous(dq.exp(x)), expm(twist_matrix(omega, v)), atol=1e-10)


def test_log_of_a_full_turn_follows_the_papers_choice():
    z = np.r_[-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    assert np.allclose(dq.exp(dq.log(z)), z, atol=1e-12)


@given(motions(), st.floats(-2.0, 2.0))
def test_power_matches_exp_of_scaled_log_and_integer_powers(z, alpha):
    z = np.where(z[0] < 0, -z, z)  # principal branch: A ∉ (−∞, 0]
    if z[0] < 1e-6:
        return
    assert np.allclose(dq.power(z, alpha), dq.exp(alpha * dq.log(z)), atol=1e-9)
    assert np.allclose(dq.power(z, 2.0), dq.mul(z, z), atol=1e-10)
    assert np.allclose(dq.power(z, -1.0), dq.inv(z), atol=1e-10)
    assert np.allclose(dq.power(z, 0.0), dq.identity(), atol=1e-12)


@given(hnp.arrays(np.float64, 3, elements=st.floats(-1.5, 1.5)), vec3, st.floats(-2, 2))
def test_power_agrees_with_matrix_exponential(omega, v, alpha):
    z = dq.exp(0.5 * np.r_[0.0, omega, 0.0, v])
    assert np.allclose(homogeneous(dq.power(z, alpha)),
                       expm(alpha * twist_matrix(omega, v)), atol=1e-9)


@given(hnp.arrays(np.float64, 8, elements=st.floats(-2, 2)))
def test_cayley_matches_its_definition(z):
    a = z[:4]
    one = np.r_[1.0, 0.0, 0.0, 0.0]
    if np.linalg.norm(one - a) < 1e-3:
        return
    # (1 + ζ)·(1 − ζ)⁻¹ with the dual inverse (A + εB)⁻¹ = A⁻¹ − εA⁻¹BA⁻¹ (Cor. 7, eq. 19)
    d = np.r_[one, np.zeros(4)] - z
    d_inv_r = dq.qinv(d[:4])
    d_inv = np.r_[d_inv_r, -dq.qmul(dq.qmul(d_inv_r, d[4:]), d_inv_r)]
    expected = dq.mul(np.r_[one, np.zeros(4)] + z, d_inv)
    assert np.allclose(dq.cayley(z), expected, atol=1e-8 * max(1, np.abs(expected).max()))


# -- interpolation ---------------------------------------------------------------------------

@given(motions(), motions())
def test_sclerp_hits_both_ends_and_is_a_one_parameter_screw(a, b):
    assert same_motion(dq.sclerp(a, b, 0.0), a)
    assert same_motion(dq.sclerp(a, b, 1.0), b, tol=1e-10)
    t = np.array([0.2, 0.5, 0.7])
    steps = dq.sclerp(a, b, t)
    # equal parameter steps are equal relative motions: z(0.7) = z(0.5)·z(0.2)⁻¹... in
    # the body frame: z(t) = a·r^t, so a⁻¹z(0.7) = (a⁻¹z(0.5))·(a⁻¹z(0.2))
    rel = [dq.mul(dq.inv(a), s) for s in steps]
    assert same_motion(rel[2], dq.mul(rel[1], rel[0]), tol=1e-9)


@settings(max_examples=50)
@given(motions(), motions(), motions(), st.floats(0.1, 0.9))
def test_dlb_is_left_invariant(a, b, c, t):
    zs = np.stack([a, b])
    w = np.array([1 - t, t])
    try:
        blended = dq.dlb(zs, w)
    except DegenerateError:
        return
    assert same_motion(dq.mul(c, blended), dq.dlb(dq.mul(c, zs), w), tol=1e-9)


@given(motions(), motions(), st.floats(0.0, 1.0))
def test_seplerp_moves_the_translation_on_a_line(a, b, t):
    _, ta = dq.to_rt(a)
    _, tb = dq.to_rt(b)
    _, tt = dq.to_rt(dq.seplerp(a, b, t))
    assert np.allclose(tt, ta + t * (tb - ta), atol=1e-11)


@given(motions(), motions(), st.floats(-0.2, 1.2))
def test_kenlerp_bias_endpoints_and_amplification(a, b, t):
    assert same_motion(dq.kenlerp(a, b, t, 0.0), dq.seplerp(a, b, t), tol=1e-10)
    assert same_motion(dq.kenlerp(a, b, t, 1.0), dq.sclerp(a, b, t), tol=1e-10)
    _, v_sc = dq.to_rt(dq.sclerp(a, b, t))
    _, v_sep = dq.to_rt(dq.seplerp(a, b, t))
    _, v2 = dq.to_rt(dq.kenlerp(a, b, t, 2.0))
    assert np.allclose(v2, 2 * v_sc - v_sep, atol=1e-10)  # β = 2 doubles the screw's bend


def test_sclerp_turn_about_z():
    a = dq.from_rt([1.0, 0, 0, 0], [0, 0, 0])
    b = dq.from_rt([np.cos(0.25), 0, 0, np.sin(0.25)], [1.0, 0, 0])  # +0.5 rad about z
    q_ccw, _ = dq.to_rt(dq.sclerp(a, b, 0.5, turn="ccw"))
    q_cw, _ = dq.to_rt(dq.sclerp(a, b, 0.5, turn="cw"))
    assert 2 * np.arctan2(q_ccw[3], q_ccw[0]) == pytest.approx(0.25)
    assert 2 * np.arctan2(q_cw[3], q_cw[0]) == pytest.approx(0.25 - np.pi)


# -- bad input -------------------------------------------------------------------------------

@pytest.mark.parametrize("call, field", [
    (lambda: dq.sclerp(np.ones(8), dq.identity(), 0.5), "a"),
    (lambda: dq.sclerp(dq.identity(), dq.identity(), [0.5, np.nan]), "t"),
    (lambda: dq.sclerp(dq.identity(), dq.identity(), 0.5, turn="up"), "turn"),
    (lambda: dq.from_rt([1, 0, 0], [0, 0, 0]), "rotation"),
    (lambda: dq.from_rt([1, 0, 0, 0], [0, np.inf, 0]), "translation"),
    (lambda: dq.transform(dq.identity(), [1.0, 2.0]), "points"),
    (lambda: dq.conj(dq.identity(), "hermitian"), "kind"),
    (lambda: dq.dlb(np.stack([dq.identity()] * 2), [1.0]), "weights"),
    (lambda: dq.inv(np.r_[1.0, 0, 0, 0, 0.5, 0, 0, 0]), "z (⟨q_r, q_d⟩ + 1)"),
])
def test_bad_input_raises(call, field):
    with pytest.raises(InputError) as info:
        call()
    assert info.value.field == field


def test_degenerate_operations_raise():
    with pytest.raises(DegenerateError):
        dq.dlb(np.stack([dq.identity(), dq.identity()]), [1.0, -1.0])
    with pytest.raises(DegenerateError):
        dq.power(np.r_[-1.0, 0, 0, 0, 0, 0.2, 0, 0], 0.5)
    with pytest.raises(DegenerateError):
        dq.cayley(dq.identity())
