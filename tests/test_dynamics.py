"""robodcn.dynamics: the Newton–Euler inverse dynamics checked against its own laws (linearity
in q̈, the energy balance, the TOPP coefficients, V's gradient), against independent formulas
(the yaw inertia of a pose, the planar model of tests/planar_reference.py, a mirrored chain)
and against the OM-X's published holding torques (../shared/omx.md: rough figures, loose
tolerances). MuJoCo's view of the same arm is in test_mujoco_omx.py."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from omx_numbers import LOWER, OMX, OMX_ANISO, UPPER, XM430_ARMATURE
from planar_reference import ArmDynamics

from robodcn.dynamics import (
    GRAVITY_DOWN,
    Link,
    RigidChain,
    Yaw,
    gravity_torque,
    holding_torque_box,
    inverse_dynamics,
    kinetic_potential,
    mass_matrix,
    path_torque_coefficients,
    tool_point,
)
from robodcn.errors import InputError

small = st.floats(-0.3, 0.3, allow_nan=False)
positive = st.floats(0.01, 1.0, allow_nan=False)
moment = st.floats(1e-5, 1e-3, allow_nan=False)


@st.composite
def links(draw) -> Link:
    inertia = draw(moment)
    return Link(vector=(draw(small), draw(small)), mass=draw(positive),
                com=(draw(small), draw(small)), inertia=inertia,
                inertia_r=draw(st.none() | moment), inertia_z=draw(st.none() | moment),
                armature=draw(st.sampled_from([0.0, XM430_ARMATURE])))


@st.composite
def chains(draw) -> RigidChain:
    """Random chains of 1–4 links, with or without a yaw, either sense, with gravity."""
    body = draw(st.lists(links(), min_size=1, max_size=4))
    if draw(st.booleans()):
        yaw = Yaw(mass=draw(positive), com=(draw(small), draw(small)),
                  inertia_z=draw(moment), armature=draw(st.sampled_from([0.0, 0.0125])))
        gravity = (0.0, draw(st.floats(-10.0, 10.0)))
    else:
        yaw, gravity = None, (draw(st.floats(-10.0, 10.0)), draw(st.floats(-10.0, 10.0)))
    return RigidChain(tuple(body), yaw=yaw, shoulder=(draw(small), draw(small)),
                      gravity=gravity, sense=draw(st.sampled_from(["cw", "ccw"])))


def states(draw, chain: RigidChain, n: int = 3, scale: float = 3.0) -> np.ndarray:
    """n random joint vectors (n, dof) in [−scale, scale]."""
    seed = draw(st.integers(0, 2 ** 32 - 1))
    return np.random.default_rng(seed).uniform(-scale, scale, (n, chain.dof))


@st.composite
def chain_and_motion(draw):
    chain = draw(chains())
    return (chain, states(draw, chain), states(draw, chain), states(draw, chain, scale=10.0),
            draw(st.sampled_from([0.0, 0.5])))


# ---- laws of the equations of motion -------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(chain_and_motion())
def test_torque_is_mass_matrix_times_acceleration_plus_bias(case):
    """τ(q, q̇, q̈) − τ(q, q̇, 0) = M(q)·q̈ with M symmetric positive definite (≥ armature)."""
    chain, q, qd, qdd, payload = case
    bias = inverse_dynamics(chain, q, qd, np.zeros_like(q), payload)
    m = mass_matrix(chain, q, payload)
    np.testing.assert_allclose(inverse_dynamics(chain, q, qd, qdd, payload) - bias,
                               np.einsum("nij,nj->ni", m, qdd), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(m, np.swapaxes(m, 1, 2), rtol=1e-9, atol=1e-14)
    assert (np.linalg.eigvalsh(m) > 0.0).all()
    assert (np.diagonal(m, axis1=1, axis2=2) >= np.asarray(chain.armature) - 1e-15).all()


@settings(max_examples=60, deadline=None)
@given(chain_and_motion())
def test_energy_balance(case):
    """d/dt (T + V) = τ·q̇ along q(t) = q₀ + q̇₀t + q̈₀t²/2 + j t³/6 (central differences)."""
    chain, q0, qd0, qdd0, payload = case
    jerk = np.roll(qdd0, 1, axis=0)
    h = 1e-4

    def total(t: float) -> np.ndarray:
        q = q0 + qd0 * t + qdd0 * t * t / 2 + jerk * t ** 3 / 6
        qd = qd0 + qdd0 * t + jerk * t * t / 2
        kinetic, potential = kinetic_potential(chain, q, qd, payload)
        return kinetic + potential

    power = np.einsum("ni,ni->n", inverse_dynamics(chain, q0, qd0, qdd0, payload), qd0)
    rate = (total(h) - total(-h)) / (2 * h)
    scale = np.einsum("ni,ni->n", np.abs(inverse_dynamics(chain, q0, qd0, qdd0, payload)),
                      np.abs(qd0))
    np.testing.assert_allclose(rate, power, atol=1e-6 * (1.0 + scale.max()))


@settings(max_examples=40, deadline=None)
@given(chain_and_motion())
def test_gravity_torque_is_the_gradient_of_potential_energy(case):
    chain, q, _, _, payload = case
    h = 1e-6
    grad = np.empty_like(q)
    for i in range(chain.dof):
        step = np.zeros(chain.dof)
        step[i] = h
        grad[:, i] = (kinetic_potential(chain, q + step, np.zeros_like(q), payload)[1]
                      - kinetic_potential(chain, q - step, np.zeros_like(q), payload)[1]) / (2 * h)
    np.testing.assert_allclose(gravity_torque(chain, q, payload), grad, atol=1e-7)


@settings(max_examples=60, deadline=None)
@given(chain_and_motion(), st.floats(-3, 3), st.floats(-20, 20))
def test_path_coefficients_give_the_inverse_dynamics_along_a_path(case, sd, sdd):
    """On q(s) = q₀ + A·s + B·s² + C·s³: τ(q, q'ṡ, q's̈ + q''ṡ²) = a·s̈ + b·ṡ² + c, a = M·q'."""
    chain, q0, coef_a, coef_b, payload = case
    coef_c = np.roll(coef_a, 1, axis=0)
    s = np.array([[0.0], [0.4], [1.0]])
    q = q0 + coef_a * s + coef_b * s ** 2 + coef_c * s ** 3
    q_s = coef_a + 2 * coef_b * s + 3 * coef_c * s ** 2
    q_ss = 2 * coef_b + 6 * coef_c * s
    a, b, c = path_torque_coefficients(chain, q, q_s, q_ss, payload)
    tau = inverse_dynamics(chain, q, q_s * sd, q_s * sdd + q_ss * sd ** 2, payload)
    np.testing.assert_allclose(a * sdd + b * sd ** 2 + c, tau, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(a, np.einsum("nij,nj->ni", mass_matrix(chain, q, payload), q_s),
                               rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c, gravity_torque(chain, q, payload), rtol=1e-12, atol=1e-12)


# ---- independent formulas ------------------------------------------------------------------

def plane_points(chain: RigidChain, q_chain: np.ndarray) -> tuple[list, list, complex]:
    """Per link its joint and centre of mass in the (r, z) plane as complex numbers, and the
    tool point, by complex products (one sample)."""
    sign = chain.sign
    joint = complex(*chain.shoulder)
    joints, coms, angle = [], [], 0.0
    for link, qi in zip(chain.links, q_chain, strict=True):
        angle += sign * qi
        turn = complex(math.cos(angle), math.sin(angle))
        joints.append(joint)
        coms.append(joint + turn * complex(*link.com))
        joint = joint + turn * complex(*link.vector)
    return joints, coms, joint


@settings(max_examples=60, deadline=None)
@given(st.sampled_from([OMX, OMX_ANISO]), st.data(), st.sampled_from([0.0, 0.5]))
def test_yaw_inertia_of_a_pose(chain, data, payload):
    """M_yaw,yaw = J₀ + I₀ + m₀r₀² + Σ (m_j·r_j² + I_xx sin²θ_j + I_zz cos²θ_j) + m_p·r_tool²."""
    q = states(data.draw, chain, n=1)[0]
    _, coms, tool = plane_points(chain, q[1:])
    yaw = chain.yaw
    expected = yaw.armature + yaw.inertia_z + yaw.mass * yaw.com[0] ** 2 + payload * tool.real ** 2
    theta = chain.sign * np.cumsum(q[1:])
    for link, com, th in zip(chain.links, coms, theta, strict=True):
        expected += (link.mass * com.real ** 2 + link.inertia_r * math.sin(th) ** 2
                     + link.inertia_z * math.cos(th) ** 2)
    assert mass_matrix(chain, q, payload)[0, 0] == pytest.approx(expected, rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(chains(), st.data())
def test_tool_point_is_the_chain_of_link_vectors(chain, data):
    q = states(data.draw, chain, n=1)[0]
    psi = q[0] if chain.yaw is not None else 0.0
    _, _, tool = plane_points(chain, q[chain.dof - len(chain.links):])
    expected = [tool.real * math.cos(psi), tool.real * math.sin(psi), tool.imag]
    np.testing.assert_allclose(tool_point(chain, q), expected, atol=1e-14)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(positive, positive, st.floats(0.1, 0.9), moment), min_size=2,
                max_size=3), st.floats(-10, 10), st.floats(-10, 10), st.floats(0.0, 0.5),
       st.data())
def test_horizontal_planar_arm_matches_the_streams_model(rows, gx, gy, payload, data):
    """A planar CCW chain (arm3r-like, gravity in the plane) gives the torques of
    planar_reference.ArmDynamics (Lagrangian, absolute angles)."""
    lengths = tuple(r[0] for r in rows)
    model = ArmDynamics(lengths, tuple(r[1] for r in rows),
                        tuple(r[0] * r[2] for r in rows), tuple(r[3] for r in rows), payload,
                        (gx, gy))
    chain = RigidChain(tuple(Link((length, 0.0), mass, (length * frac, 0.0), inertia)
                             for length, mass, frac, inertia in rows), gravity=(gx, gy),
                       sense="ccw")
    q, qd, qdd = (states(data.draw, chain, n=4) for _ in range(3))
    np.testing.assert_allclose(inverse_dynamics(chain, q, qd, qdd, payload),
                               model.torques(q, qd, qdd), rtol=1e-9, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(chain_and_motion())
def test_a_clockwise_chain_is_the_mirror_of_a_counter_clockwise_one(case):
    """Mirroring z → −z turns a "cw" chain into a "ccw" one with the same joint dynamics."""
    chain, q, qd, qdd, payload = case
    if chain.yaw is not None:       # the mirror flips the yaw axis too: planar chains only
        q, qd, qdd = q[:, 1:], qd[:, 1:], qdd[:, 1:]
    mirrored = RigidChain(
        tuple(Link((lk.vector[0], -lk.vector[1]), lk.mass, (lk.com[0], -lk.com[1]), lk.inertia,
                   armature=lk.armature) for lk in chain.links),
        shoulder=(chain.shoulder[0], -chain.shoulder[1]),
        gravity=(chain.gravity[0], -chain.gravity[1]),
        sense="ccw" if chain.sense == "cw" else "cw")
    plain = RigidChain(tuple(Link(lk.vector, lk.mass, lk.com, lk.inertia, armature=lk.armature)
                             for lk in chain.links), shoulder=chain.shoulder,
                       gravity=chain.gravity, sense=chain.sense)
    np.testing.assert_allclose(inverse_dynamics(mirrored, q, qd, qdd, payload),
                               inverse_dynamics(plain, q, qd, qdd, payload),
                               rtol=1e-9, atol=1e-12)


def test_rotor_armature_adds_j_times_acceleration():
    qdd = np.array([[1.0, -2.0, 3.0, 0.5]])
    q = np.zeros((1, 4))
    bare = RigidChain(tuple(Link(lk.vector, lk.mass, lk.com, lk.inertia) for lk in OMX.links),
                      yaw=Yaw(OMX.yaw.mass, OMX.yaw.com, OMX.yaw.inertia_z),
                      shoulder=OMX.shoulder, gravity=OMX.gravity, sense="cw")
    np.testing.assert_allclose(inverse_dynamics(OMX, q, q, qdd) - inverse_dynamics(bare, q, q, qdd),
                               np.asarray(OMX.armature) * qdd, rtol=1e-12)
    # the packaged figure is omx.md's J_rotor·N² rounded
    assert OMX.armature == pytest.approx((XM430_ARMATURE,) * 4, rel=1e-3)


# ---- the OM-X's published figures ----------------------------------------------------------

def stretched() -> np.ndarray:
    """Shoulder turned until link 1 is horizontal, elbow back so links 2 and 3 stay so."""
    r, z = OMX.links[0].vector
    lean = math.atan2(z, r)         # link 1's elevation at zero; positive angles turn down
    return np.array([0.0, lean, -lean, 0.0])


def test_omx_tool_point_and_reach():
    """omx.md: tool point (0.274, 0, 0.2045) m at zero; reach 380 mm stretched out."""
    np.testing.assert_allclose(tool_point(OMX, np.zeros(4)), [0.274, 0.0, 0.2045], atol=1e-9)
    point = tool_point(OMX, stretched())
    assert point[2] == pytest.approx(OMX.shoulder[1], abs=1e-12)
    assert point[0] == pytest.approx(0.380, abs=0.001)


def test_omx_holding_torques():
    """omx.md (rough): the shoulder holds ≈ 0.43 N·m at zero, ≈ 0.84 N·m stretched out
    horizontally, ≈ 2.7 N·m stretched with the 500 g payload; gravity pulls the arm forward
    and down (the positive direction), so the holding torque is negative."""
    at_zero = gravity_torque(OMX, np.zeros(4))
    assert at_zero[0] == 0.0
    assert at_zero[1] == pytest.approx(-0.43, abs=0.02)
    assert gravity_torque(OMX, stretched())[1] == pytest.approx(-0.84, abs=0.03)
    assert gravity_torque(OMX, stretched(), 0.5)[1] == pytest.approx(-2.7, abs=0.1)
    assert gravity_torque(OMX, np.array([0.0, -0.2, 0.0, 0.0]))[1] > at_zero[1]   # leaned back


@functools.cache
def omx_box(payload: float) -> np.ndarray:
    return holding_torque_box(OMX, LOWER, UPPER, payload)


def test_omx_holding_torque_box():
    """The box's worst holding torque: at least a fine grid's best everywhere and not much
    more; and g·Σ_{j ≥ i} |w_j| at joint i, w_j = m_j·com_j + (mass beyond link j)·v_j the
    first moment link j carries (each w_j turned horizontal: inside the OM-X's limits)."""
    for payload in (0.0, 0.5):
        worst = omx_box(payload)
        assert worst[0] == 0.0
        axes = [np.linspace(lo, hi, 41) for lo, hi in zip(LOWER[1:], UPPER[1:], strict=True)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        q = np.column_stack([np.zeros(len(grid)), grid])
        fine = np.abs(gravity_torque(OMX, q, payload)).max(axis=0)
        assert (worst >= fine - 1e-12).all()
        assert (worst <= fine * 1.01 + 1e-6).all()
        beyond = np.cumsum([lk.mass for lk in OMX.links][::-1])[::-1] + payload
        beyond = np.append(beyond[1:], payload)
        w = [math.hypot(*(lk.mass * np.asarray(lk.com) + m * np.asarray(lk.vector)))
             for lk, m in zip(OMX.links, beyond, strict=True)]
        g = -OMX.gravity[1]
        np.testing.assert_allclose(worst[1:], g * np.cumsum(w[::-1])[::-1], rtol=1e-7)
    assert worst[1] == pytest.approx(2.7, abs=0.1)          # omx.md's two thirds of stall


@settings(max_examples=30, deadline=None)
@given(st.data(), st.sampled_from([0.0, 0.5]))
def test_holding_torque_box_bounds_every_pose_in_it(data, payload):
    u = states(data.draw, OMX, n=200, scale=1.0) * 0.5 + 0.5
    q = np.asarray(LOWER) + u * (np.asarray(UPPER) - np.asarray(LOWER))
    worst = omx_box(payload)
    assert (np.abs(gravity_torque(OMX, q, payload)) <= worst + 1e-12).all()


def test_no_gravity_no_holding_torque():
    flat = RigidChain(OMX.links, shoulder=OMX.shoulder, gravity=(0.0, 0.0), sense="cw")
    assert (holding_torque_box(flat, LOWER[1:], UPPER[1:], 0.5) == 0.0).all()
    assert GRAVITY_DOWN == (0.0, -9.81)


# ---- shapes and errors ---------------------------------------------------------------------

def test_one_sample_is_the_n_equals_1_case():
    q = np.array([0.3, -0.5, 0.7, 0.1])
    qd = np.array([0.5, 1.0, -1.0, 2.0])
    qdd = np.array([1.0, -3.0, 2.0, 5.0])
    one = inverse_dynamics(OMX, q, qd, qdd, 0.5)
    assert one.shape == (4,)
    np.testing.assert_array_equal(one, inverse_dynamics(OMX, q[None], qd[None], qdd[None], 0.5)[0])
    assert mass_matrix(OMX, q).shape == (4, 4)
    assert [c.shape for c in path_torque_coefficients(OMX, q, qd, qdd)] == [(4,)] * 3


@pytest.mark.parametrize(("call", "field"), [
    (lambda: inverse_dynamics(OMX, np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3))), "q"),
    (lambda: inverse_dynamics(OMX, np.zeros((2, 4)), np.zeros((3, 4)), np.zeros((2, 4))), "qd"),
    (lambda: inverse_dynamics(OMX, np.zeros(4), np.zeros(4), [0, 0, np.nan, 0]), "qdd"),
    (lambda: gravity_torque(OMX, np.zeros(4), -0.1), "payload_kg"),
    (lambda: gravity_torque(OMX, np.zeros(4), True), "payload_kg"),
    (lambda: holding_torque_box(OMX, UPPER, LOWER), "lower[0]"),
    (lambda: holding_torque_box(OMX, LOWER[1:], UPPER[1:]), "lower"),
    (lambda: path_torque_coefficients(OMX, np.zeros((2, 4)), np.zeros((1, 4)),
                                      np.zeros((2, 4))), "q_s"),
    (lambda: RigidChain(OMX.links, yaw=OMX.yaw, gravity=(1.0, -9.81)), "gravity"),
    (lambda: RigidChain(OMX.links, sense="up"), "sense"),
    (lambda: RigidChain(()), "links"),
    (lambda: Link((0.1, 0.0), 0.0, (0.05, 0.0), 1e-4), "mass"),
    (lambda: Link((0.1, 0.0), 0.1, (0.05,), 1e-4), "com"),
    (lambda: Link((0.1, 0.0), 0.1, (0.05, 0.0), -1e-4), "inertia"),
    (lambda: Yaw(mass=-1.0), "yaw.mass"),
])
def test_errors_name_the_argument(call, field):
    with pytest.raises(InputError) as info:
        call()
    assert info.value.field == field
