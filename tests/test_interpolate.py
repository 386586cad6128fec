"""The public planar API: robodcn.interpolate and robodcn.blend."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from strategies import params, poses

import robodcn
from robodcn import dcn
from robodcn.errors import DegenerateError, InputError
from robodcn.interpolate import METHODS, turn_angle

TURNS = ("shortest", "ccw", "cw")


def pole(start, end, delta):
    """Fixed point of the relative motion taking start to end while turning by delta."""
    c_p, c_q = complex(*start[:2]), complex(*end[:2])
    # c_q = z + e^{iΔ}(c_p − z)  ⇒  z = c_p + (c_q − c_p)/(1 − e^{iΔ})
    return c_p + (c_q - c_p) / (1.0 - np.exp(1j * delta))


@settings(max_examples=60)
@given(poses(), poses(), params, st.sampled_from(METHODS), st.sampled_from(TURNS),
       st.floats(-0.5, 2.5))
def test_the_three_backends_agree(a, b, s, method, turn, beta):
    # The dq backend sees only the relative quaternion, whose z part is sin(Δ₀/2) for the
    # wrapped rotation Δ₀ between the poses: within dualquat's tie (1e-12) of zero it counts
    # as no rotation, so ccw/cw of an all-but-zero rotation (a turn of 2π − 1e-12) is not
    # the one the DCN backend (which has Δ exactly) draws. Such pairs are outside the check.
    wrapped = (b[2] - a[2] + np.pi) % (2 * np.pi) - np.pi
    assume(turn == "shortest" or wrapped == 0.0 or abs(np.sin(wrapped / 2)) >= 1e-9)
    try:
        fast = robodcn.interpolate(a, b, s, method=method, beta=beta, turn=turn)
    except DegenerateError:
        return
    slow = robodcn.interpolate(a, b, s, method=method, beta=beta, turn=turn, backend="dq")
    scale = max(1.0, np.abs(fast).max())  # near-full turns put the pole far away
    tolerance = 1e-11 * scale + angle_conditioning(a, b, s, turn_angle(a[2], b[2], turn))
    assert np.abs(fast - slow).max() < tolerance
    if method == "sclerp":
        mat = robodcn.interpolate(a, b, s, turn=turn, backend="matrix")
        assert np.abs(fast - mat).max() < tolerance


def angle_conditioning(start, end, s, delta):
    """How far an error of a few ulps in Δθ alone moves the screw motion's positions.

    x(s) = p + f(Δ)·(q − p) with f(Δ) = (1 − e^{isΔ}) / (1 − e^{iΔ}); near a whole turn the
    denominator vanishes and |f′(Δ)|·|q − p| grows as |pole|² / |q − p|. Δθ itself cannot be
    known better than an ulp of 2π, so backends that differ only in rounding may differ by
    this much (a = 0, b = (1, 1, 4e-5) turned cw puts the pole 3.5e4 m away: 1.1e-6 m).
    """
    if delta == 0.0:
        return 0.0
    s = np.asarray(s, dtype=float)
    gap = abs(1.0 - np.exp(1j * delta))
    h = 1e-3 * min(gap, abs(delta))  # well inside the distance to the nearest pole of f

    def f(d):
        return (1.0 - np.exp(1j * s * d)) / (1.0 - np.exp(1j * d))

    slope = np.abs(f(delta + h) - f(delta - h)).max() / (2.0 * h)
    chord = np.hypot(end[0] - start[0], end[1] - start[1])
    return 16.0 * np.finfo(float).eps * 2.0 * np.pi * slope * chord


@given(poses(), poses(), st.sampled_from(METHODS), st.sampled_from(TURNS))
def test_every_method_hits_both_ends_with_theta_unwrapped_from_start(a, b, method, turn):
    a = a + np.array([0.0, 0.0, 6.0])  # θ outside (−π, π] must be kept, not wrapped
    try:
        out = robodcn.interpolate(a, b, [0.0, 1.0], method=method, beta=0.3, turn=turn)
    except DegenerateError:
        return
    assert np.allclose(out[0], a, atol=1e-12)
    assert np.allclose(out[1, :2], b[:2], atol=1e-11)
    assert out[1, 2] - a[2] == pytest.approx(turn_angle(a[2], b[2], turn), abs=1e-12)
    assert np.exp(1j * out[1, 2]) == pytest.approx(np.exp(1j * b[2]), abs=1e-11)


@given(poses(), poses(), st.sampled_from(TURNS))
def test_sclerp_moves_points_on_a_circle_about_the_pole_at_constant_speed(a, b, turn):
    delta = turn_angle(a[2], b[2], turn)
    s = np.linspace(0.0, 1.0, 11)
    out = robodcn.interpolate(a, b, s, turn=turn)
    c = out[:, 0] + 1j * out[:, 1]
    steps = np.abs(np.diff(c))
    assert np.allclose(steps, steps[0], atol=1e-9)  # constant speed
    assert np.allclose(np.diff(out[:, 2]), delta / 10, atol=1e-12)  # constant turn rate
    if 1e-3 < abs(delta) < 2 * np.pi - 1e-3:  # the pole is ill-conditioned near whole turns
        z = pole(a, b, delta)
        assert np.allclose(np.abs(c - z), abs(c[0] - z), rtol=1e-9, atol=1e-9)
        # a body point fixed to the end effector moves on a circle about the same pole
        body = dcn.act(dcn.from_pose(out), [0.3, -0.2])
        radii = np.abs(body[:, 0] + 1j * body[:, 1] - z)
        assert np.allclose(radii, radii[0], rtol=1e-9, atol=1e-9)


@given(poses(), poses())
def test_sclerp_without_rotation_is_a_straight_line(a, b):
    b = np.r_[b[:2], a[2]]
    s = np.linspace(-0.5, 1.5, 9)
    out = robodcn.interpolate(a, b, s)
    assert np.allclose(out[:, :2], a[:2] + s[:, None] * (b[:2] - a[:2]), atol=1e-12)
    assert np.allclose(out[:, 2], a[2])


@given(poses(), poses(), params)
def test_kenlerp_bias(a, b, s):
    sep = robodcn.interpolate(a, b, s, method="seplerp")
    sc = robodcn.interpolate(a, b, s, method="sclerp")
    assert np.allclose(robodcn.interpolate(a, b, s, method="kenlerp", beta=0.0), sep,
                       atol=1e-12)
    assert np.allclose(robodcn.interpolate(a, b, s, method="kenlerp", beta=1.0), sc,
                       atol=1e-12)
    amplified = robodcn.interpolate(a, b, s, method="kenlerp", beta=2.5)
    assert np.allclose(amplified[:, :2] - sep[:, :2], 2.5 * (sc[:, :2] - sep[:, :2]),
                       atol=1e-11)


@given(poses(), poses(), params)
def test_seplerp_translates_on_a_line_and_turns_uniformly(a, b, s):
    out = robodcn.interpolate(a, b, s, method="seplerp")
    assert np.allclose(out[:, :2], a[:2] + s[:, None] * (b[:2] - a[:2]), atol=1e-12)
    assert np.allclose(out[:, 2], a[2] + s * turn_angle(a[2], b[2]), atol=1e-12)


@given(poses(), poses(), st.floats(0.0, 1.0))
def test_two_pose_dlb_is_the_weighted_blend(a, b, t):
    try:
        out = robodcn.interpolate(a, b, [t], method="dlb")[0]
        want = robodcn.blend(np.stack([a, b]), [1 - t, t])
    except DegenerateError:
        return
    assert np.allclose(out[:2], want[:2], atol=1e-11)
    assert np.exp(1j * out[2]) == pytest.approx(np.exp(1j * want[2]), abs=1e-11)


@given(poses(n=3), poses())
def test_blend_is_left_invariant_on_poses(ps, p0):
    w = np.array([0.2, 0.5, 0.3])
    try:
        blended = robodcn.blend(ps, w)
    except DegenerateError:
        return
    moved = dcn.to_pose(dcn.mul(dcn.from_pose(p0), dcn.from_pose(ps)))
    lhs = dcn.to_pose(dcn.mul(dcn.from_pose(p0), dcn.from_pose(blended)))
    rhs = robodcn.blend(moved, w)
    assert np.allclose(lhs[:2], rhs[:2], atol=1e-10)
    assert np.exp(1j * lhs[2]) == pytest.approx(np.exp(1j * rhs[2]), abs=1e-10)


@pytest.mark.parametrize("theta_a", [0.0, 0.1, -3.0, np.pi, -np.pi])
@pytest.mark.parametrize("offset", [0.0, 4e-13, 9e-13, 1.5e-12, 3e-12])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_near_half_turns_break_the_same_way_in_every_path(theta_a, offset, sign):
    """Within 1e-12 rad of a half turn the turn is +π in turn_angle, the two-pose DLB of
    interpolate and the n-pose blend alike; beyond it, the shorter side (both paths)."""
    a = np.array([0.3, -0.2, theta_a])
    b = np.array([1.0, 2.0, theta_a + sign * (np.pi + offset)])
    delta = turn_angle(a[2], b[2])
    tie = offset <= 1e-12 - 1e-15
    assert delta == (np.pi if tie else pytest.approx(-sign * (np.pi - offset), abs=1e-14))
    out = robodcn.interpolate(a, b, [0.5], method="dlb")[0]
    want = robodcn.blend(np.stack([a, b]), [0.5, 0.5])
    assert np.allclose(out[:2], want[:2], atol=1e-11)
    assert np.exp(1j * out[2]) == pytest.approx(np.exp(1j * want[2]), abs=1e-11)
    assert np.exp(1j * out[2]) == pytest.approx(np.exp(1j * (a[2] + delta / 2)), abs=1e-11)


def test_half_turn_follows_the_turn_rule():
    a, b = [0.0, 0.0, 0.25], [1.0, 1.0, 0.25 + np.pi]
    mid = {turn: robodcn.interpolate(a, b, [0.5], turn=turn)[0, 2] for turn in TURNS}
    assert mid["shortest"] == pytest.approx(0.25 + np.pi / 2)
    assert mid["ccw"] == pytest.approx(0.25 + np.pi / 2)
    assert mid["cw"] == pytest.approx(0.25 - np.pi / 2)
    # the same half turn written with a negative end angle
    b2 = [1.0, 1.0, 0.25 - np.pi]
    assert robodcn.interpolate(a, b2, [1.0])[0, 2] == pytest.approx(0.25 + np.pi)


def test_long_way_round_turns():
    a, b = [0.0, 0.0, 0.0], [0.5, 0.0, 0.5]
    assert robodcn.interpolate(a, b, [1.0], turn="ccw")[0, 2] == pytest.approx(0.5)
    assert robodcn.interpolate(a, b, [1.0], turn="cw")[0, 2] == pytest.approx(0.5 - 2 * np.pi)
    out = robodcn.interpolate(a, b, np.linspace(0, 1, 50), turn="cw", method="dlb")
    assert np.all(np.diff(out[:, 2]) < 0)  # monotone the long way, no wrap jumps


@pytest.mark.parametrize("kwargs, field", [
    ({"start": [0, 0, np.nan]}, "start"),
    ({"start": [0, 0]}, "start"),
    ({"end": [[0, 0, 0]]}, "end"),
    ({"s": [[0.1, 0.2]]}, "s"),
    ({"s": [0.1, np.inf]}, "s"),
    ({"method": "spline"}, "method"),
    ({"turn": "left"}, "turn"),
    ({"backend": "gpu"}, "backend"),
    ({"method": "kenlerp", "beta": np.nan}, "beta"),
    ({"method": "seplerp", "backend": "matrix"}, "backend"),
])
def test_interpolate_rejects_bad_input_naming_it(kwargs, field):
    args = {"start": [0.0, 0.0, 0.0], "end": [1.0, 0.0, 1.0], "s": [0.0, 0.5, 1.0]} | kwargs
    start, end, s = args.pop("start"), args.pop("end"), args.pop("s")
    with pytest.raises(InputError) as info:
        robodcn.interpolate(start, end, s, **args)
    assert info.value.field == field
    assert field in info.value.message


def test_dlb_through_a_vanishing_blend_raises():
    with pytest.raises(DegenerateError) as info:
        robodcn.interpolate([0, 0, 0], [1, 0, -2e-12], [0.0, 0.5, 1.0], method="dlb",
                            turn="ccw")
    assert "s[1]" in info.value.message
    with pytest.raises(DegenerateError):
        robodcn.blend([[0, 0, 0], [1, 0, 0]], [1.0, -1.0])


@pytest.mark.parametrize("poses_, weights, field", [
    ([0, 0, 0], [1.0], "poses"),
    ([[0, 0, 0]], [1.0, 2.0], "weights"),
    ([[0, 0, np.nan]], [1.0], "poses"),
])
def test_blend_rejects_bad_input(poses_, weights, field):
    with pytest.raises(InputError) as info:
        robodcn.blend(poses_, weights)
    assert info.value.field == field
