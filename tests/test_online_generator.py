"""The online motion generator (robodcn.online) against Ruckig's own offline laws: random
step targets from rest and from motion on arm3r with jerk limits and on the omx, reached in
at most 1.02 × Ruckig's duration + one period, every sample within v, a and jerk; stops;
torque checks with a payload; infeasible inputs as values."""

from __future__ import annotations

import math

import numpy as np
import pytest
from omx_helpers import OMX
from online_helpers import JERK_ARM
from ruckig import InputParameter, Ruckig, Trajectory

from robodcn.online import Generator, Infeasible, Input, Sample
from robodcn.path_timing import JointLimits

RATE = 1000.0
T = 1.0 / RATE
#: relative slack on a limit (float rounding of Ruckig's profiles)
SLACK = 1e-6


def _bounds(arm):
    return np.array([[j.min_angle, j.max_angle] for j in arm.joints])


def _random_state(rng, arm, limits, moving):
    lo, hi = _bounds(arm).T
    q = rng.uniform(lo + 0.2 * (hi - lo), hi - 0.2 * (hi - lo))
    if not moving:
        return q, np.zeros_like(q), np.zeros_like(q)
    qd = rng.uniform(-0.8, 0.8, len(q)) * limits.v
    qdd = rng.uniform(-0.5, 0.5, len(q)) * limits.a
    if limits.j is None:
        qdd = np.zeros_like(q)      # a second-order law starts at zero acceleration
    return q, qd, qdd


def _ruckig_duration(limits, state, target):
    """Ruckig's offline time-optimal duration for the same limits and initial state."""
    k = len(target)
    ip = InputParameter(k)
    ip.current_position, ip.current_velocity, ip.current_acceleration = map(list, state)
    ip.target_position = list(target)
    ip.max_velocity, ip.max_acceleration = list(limits.v), list(limits.a)
    ip.max_jerk = list(limits.jerk)
    law = Trajectory(k)
    Ruckig(k).calculate(ip, law)
    return law.duration


def _run(gen, inp, limit_s=20.0):
    """Samples until the input's state is reached (the first one with the new input)."""
    samples = [gen.update(inp)]
    while not samples[-1].reached:
        assert isinstance(samples[-1], Sample), samples[-1]
        samples.append(gen.update())
        assert len(samples) * T < limit_s
    return samples


def _check_limits(samples, limits, start_qdd):
    """|q̇| ≤ v, |q̈| ≤ a at every sample, |Δq̈|/T ≤ j (from the start's q̈), and the
    positions' own finite differences agree with the velocities the law reports."""
    qd = np.array([s.qd for s in samples])
    qdd = np.array([s.qdd for s in samples])
    assert (np.abs(qd) <= limits.v * (1 + SLACK)).all()
    assert (np.abs(qdd) <= limits.a * (1 + SLACK)).all()
    if limits.j is not None:
        jerk = np.abs(np.diff(np.vstack([start_qdd, qdd]), axis=0)) / T
        assert (jerk <= limits.j * (1 + SLACK)).all(), jerk.max(axis=0)
    q = np.array([s.q for s in samples])
    fd = np.diff(q, axis=0) / T
    mid = 0.5 * (qd[1:] + qd[:-1])
    assert np.allclose(fd, mid, atol=limits.a.max() * T)


@pytest.mark.parametrize("arm", [JERK_ARM, OMX], ids=["arm3r-jerk", "omx"])
@pytest.mark.parametrize("moving", [False, True], ids=["from-rest", "from-motion"])
def test_step_targets_are_time_optimal_against_ruckig(arm, moving):
    """≥ 20 random step targets per case: the generator reaches each in ≤ 1.02 × Ruckig's
    offline duration (same v, a, j and initial state) + one period, within the limits."""
    rng = np.random.default_rng(28 + moving)
    limits = JointLimits.of(arm, torque=False)
    lo, hi = _bounds(arm).T
    ratios = []
    for _ in range(22):
        state = _random_state(rng, arm, limits, moving)
        target = rng.uniform(lo, hi)
        gen = Generator(limits, RATE, state[0], qd=state[1], qdd=state[2],
                        position_limits=_bounds(arm))
        samples = _run(gen, Input(target=target))
        took = len(samples) * T
        ruckig = _ruckig_duration(limits, state, target)
        assert took <= 1.02 * ruckig + T, (took, ruckig)
        np.testing.assert_allclose(samples[-1].q, target, atol=1e-9)
        np.testing.assert_allclose(samples[-1].qd, 0.0, atol=1e-9)
        _check_limits(samples, limits, state[2])
        ratios.append(took / ruckig)
    assert max(ratios) <= 1.02 + T / 0.05


def test_a_new_target_is_met_from_the_commanded_state_at_once():
    """A reversal mid-flight: the very next sample is on the new law (its velocity falls
    toward the new target), and the whole motion stays within the jerk limits."""
    limits = JointLimits.of(JERK_ARM)
    gen = Generator(limits, RATE, np.zeros(3))
    far = np.array([1.0, -0.8, 1.2])
    samples = [gen.update(Input(target=far))] + [gen.update() for _ in range(149)]
    before = samples[-1]
    assert (np.sign(before.qd) == np.sign(far)).all()
    back = _run(gen, Input(target=-far))
    first = back[0]
    assert (np.sign(first.qdd) == -np.sign(far)).all() or \
        (np.sign(first.qdd - before.qdd) == -np.sign(far)).all()
    _check_limits(samples + back, limits, np.zeros(3))
    np.testing.assert_allclose(back[-1].q, -far, atol=1e-9)


def test_stop_brakes_to_rest_in_ruckig_s_least_time():
    """A stop input from full motion: at rest in Ruckig's velocity-interface duration,
    within the limits, short of where the target was."""
    limits = JointLimits.of(JERK_ARM)
    gen = Generator(limits, RATE, np.zeros(3))
    for _ in range(120):
        moving = gen.update(Input(target=np.full(3, 2.0)) if _ == 0 else None)
    stopped = _run(gen, Input.stop())
    assert np.abs(stopped[-1].qd).max() < 1e-9
    assert (stopped[-1].q < 2.0).all()
    _check_limits([moving, *stopped], limits, moving.qdd)
    speed = np.abs(moving.qd).max()
    # braking from speed v needs at least v / a_max
    assert len(stopped) * T >= speed / limits.a.max() - T


def test_speed_scale_slows_the_law():
    """Scale k: the law keeps v·k, a·k², j·k³ and takes longer than at k = 1."""
    limits = JointLimits.of(JERK_ARM)
    target = np.array([0.9, -0.5, 1.1])
    full = _run(Generator(limits, RATE, np.zeros(3)), Input(target=target))
    half = _run(Generator(limits, RATE, np.zeros(3)), Input(target=target, scale=0.5))
    assert len(half) > 1.5 * len(full)
    _check_limits(half, limits.scaled(0.5), np.zeros(3))


def test_target_velocity_is_clamped_to_limits_and_braking_room():
    """A target velocity beyond v is clamped to it; one toward a position limit to what
    the joint can still brake from before it."""
    limits = JointLimits.of(JERK_ARM)
    bounds = _bounds(JERK_ARM)
    gen = Generator(limits, RATE, np.zeros(3), position_limits=bounds)
    near = bounds[:, 1] - 0.01
    samples = _run(gen, Input(target=near, velocity=10 * limits.v))
    end = samples[-1].qd
    assert (end <= np.sqrt(2 * limits.a * 0.01) + 1e-9).all()
    assert (end > 0).all()
    _check_limits(samples, limits, np.zeros(3))


def test_torque_check_lowers_the_scale_with_a_payload():
    """The omx with a heavy payload: the full-speed law from a stretched pose would exceed a
    joint's torque limit; check() lowers the scale until the sampled law keeps every
    joint's |τ| ≤ τ_max, and the law it returns does."""
    limits = JointLimits.of(OMX, 0.6)
    q0 = np.array([0.0, 0.6, -0.6, 0.0])
    gen = Generator(limits, RATE, q0)
    inp = Input(target=np.array([1.5, -0.9, 0.9, 1.2]))
    checked = gen.check(inp)
    assert isinstance(checked, Input)
    law = gen.law(checked)
    ts = np.linspace(0, law.duration, 300)
    rows = [law.at_time(float(t)) for t in ts]
    q, qd, qdd = (np.array([r[i] for r in rows]) for i in range(3))
    tau = np.abs(limits.torque.torques(q, qd, qdd))
    assert (tau <= limits.torque.tau * (1 + 1e-3)).all()
    full = gen.law(inp)
    rows = [full.at_time(float(t)) for t in np.linspace(0, full.duration, 300)]
    tau_full = np.abs(limits.torque.torques(*(np.array([r[i] for r in rows])
                                              for i in range(3))))
    assert (tau_full > limits.torque.tau).any()     # the case this test is about
    assert checked.scale < 1.0


def test_torque_beyond_gravity_is_infeasible_as_a_value():
    """A payload gravity alone overloads a joint with: Infeasible("torque"), naming the
    joint and the torque against its limit (never an exception)."""
    limits = JointLimits.of(OMX, 3.0)
    gen = Generator(limits, RATE, np.array([0.0, 0.6, -0.6, 0.0]))
    got = gen.check(Input(target=np.array([0.0, 1.2, -0.8, 0.0])))
    assert isinstance(got, Infeasible) and got.reason == "torque"
    assert got.joint is not None and got.value > got.limit
    assert "N·m" in got.message


def test_an_input_ruckig_refuses_is_infeasible_and_changes_nothing():
    """A non-finite target: Infeasible, the state and the previous input stand."""
    limits = JointLimits.of(JERK_ARM)
    gen = Generator(limits, RATE, np.zeros(3))
    good = Input(target=np.full(3, 0.3))
    gen.update(good)
    state = gen.state
    bad = gen.update(Input(target=np.array([math.nan, 0.0, 0.0])))
    assert isinstance(bad, Infeasible) and bad.reason in ("input", "calculation")
    assert gen.input is good
    np.testing.assert_array_equal(gen.state[0], state[0])
    after = gen.update()
    assert isinstance(after, Sample)
