"""robodcn.path_timing.moving_start: joining a path from a moving joint state."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from robodcn.config import load_arm
from robodcn.path_timing import JointLimits, moving_start
from robodcn.path_timing.moving_start import BlendOut, JointState, join, retry

ARM = load_arm(Path(__file__).resolve().parent.parent / "configs" / "arm3r.toml")
RATE = 1000.0
LIM = JointLimits.of(ARM)


def line(q0, q1, n: int = 50) -> tuple[np.ndarray, np.ndarray]:
    s = np.linspace(0.0, 1.0, n)
    return np.asarray(q0) + np.outer(s, np.asarray(q1) - np.asarray(q0)), s


def test_blend_out_matches_the_residual_and_vanishes_at_its_end():
    b = BlendOut(np.array([0.3, -0.2, 0.1]), np.array([1.0, 0.5, -2.0]), 0.4)
    h = 1e-6
    e = b.correction(np.array([0.0, h, 2 * h]))
    np.testing.assert_allclose(e[0], 0.0, atol=1e-15)
    np.testing.assert_allclose((e[1] - e[0]) / h, b.rv, rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose((e[2] - 2 * e[1] + e[0]) / h ** 2, b.ra, rtol=1e-2, atol=1e-2)
    np.testing.assert_allclose(b.correction(np.array([0.4, 0.5, 1.0])), 0.0, atol=1e-15)


def test_a_state_along_the_path_joins_it_tangent():
    q, s = line([0.0, 0.5, 0.0], [1.0, 1.0, 0.5])
    direction = q[-1] - q[0]
    state = JointState(q[0], 0.3 * direction, np.zeros(3))
    seg = join(state, q, s, LIM, RATE)
    assert seg.kind == "tangent" and seg.law is not None
    assert seg.sd0 == pytest.approx(0.3, rel=1e-6)  # q̇ = q' ṡ₀
    assert seg.law.at(np.array([0.0])).sd[0] == pytest.approx(0.3, rel=1e-6)


def test_a_reversal_brakes_along_the_present_motion_to_rest():
    q, s = line([0.0, 0.5, 0.0], [1.0, 1.0, 0.5])
    qd = -0.5 * (q[-1] - q[0])  # moving away from the path
    state = JointState(q[0], qd, np.zeros(3))
    seg = join(state, q, s, LIM, RATE)
    assert seg.kind == "brake" and seg.brake is not None
    stop = seg.brake.q_stop - state.q
    assert np.allclose(np.cross(stop, qd), 0.0, atol=1e-12) and stop @ qd > 0  # along q̇₀
    m = seg.brake.law.sample(RATE)
    v = np.diff(seg.brake.q[0] + np.outer(m.s, stop), axis=0) * RATE
    assert np.abs(v[0] - qd).max() < LIM.a.max() / RATE * 2  # starts at q̇₀
    assert m.sd[-1] == pytest.approx(0.0, abs=1e-9) and m.s[-1] == pytest.approx(1.0)


def test_without_brakes_it_blends_and_retries_slower():
    q, s = line([0.0, 0.5, 0.0], [1.0, 1.0, 0.5])
    state = JointState(q[0], np.array([0.0, -0.8, 0.6]), np.zeros(3))
    seg = join(state, q, s, LIM, RATE, allow_brake=False)
    assert seg.kind == "blend" and seg.blend is not None and seg.law is not None
    # the residual is what the projection leaves of q̇₀
    d1 = (q[1] - q[0]) / (s[1] - s[0])
    np.testing.assert_allclose(seg.blend.rv, state.qd - d1 * seg.sd0, atol=1e-9)
    nxt = retry(seg, state, q, s, LIM, RATE)
    assert nxt is not None and nxt.kind == "blend" and len(nxt.tries) < len(seg.tries)
    assert nxt.scale <= seg.scale


def test_jerk_limited_never_brakes_and_at_rest_is_tangent():
    jerky = dataclasses.replace(ARM, joints=tuple(dataclasses.replace(j, max_jerk=200.0)
                                                  for j in ARM.joints))
    lim = JointLimits.of(jerky)
    q, s = line([0.0, 0.5, 0.0], [1.0, 1.0, 0.5])
    state = JointState(q[0], -0.5 * (q[-1] - q[0]), np.zeros(3))
    assert join(state, q, s, lim, RATE).kind == "blend"
    rest = JointState(q[0], np.zeros(3), np.zeros(3))
    seg = join(rest, q, s, lim, RATE)
    assert seg.kind == "tangent" and seg.law is not None and seg.law.s_start == 0.0
    assert moving_start.retry(dataclasses.replace(seg, kind="brake"), rest, q, s, lim,
                              RATE) is None
