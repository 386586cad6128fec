"""firmware_sim's arm dynamics against MuJoCo's for the same OpenMANIPULATOR-X (issue 18 §5).

Both engines are built from configs/omx.toml: firmware_sim parses the file itself
(:func:`firmware_sim.arm_model.load_arm`), MuJoCo gets the MJCF of tests/omx_mujoco.py from
robodcn's :class:`~robodcn.dynamics.RigidChain` of the same file (omx_numbers). The MJCF
has every link's moments about the radial and the vertical axis (MuJoCo needs a positive
inertia obeying the triangle inequality); firmware_sim reads them from the optional
``[dynamics] link_inertias_r`` / ``link_inertias_z`` keys, given here on top of the file
(robodcn's configuration does not take those keys yet, so they are not in omx.toml).

(a) Forward dynamics: q̈ = (M + diag J)⁻¹ (τ − b) of firmware_sim's chain (J the rotor's
J_rotor·N², MuJoCo's ``armature``) against ``mj_forward``'s ``qacc`` with the same τ as
``qfrc_applied``, on random states with a spinning yaw, with and without a 0.5 kg payload.
Both are closed forms evaluated in double precision: they agree to round-off.

(b) A free motion under gravity, torque off: firmware_sim's plant (its semi-implicit Euler,
backward in the damping, on the bus's own servos with their rotor inertia and viscous
friction; Coulomb friction zeroed, which MuJoCo's soft ``frictionloss`` would not match)
against MuJoCo's RK4 at 0.1 ms with the same viscous ``damping``, 300 ms from a moving
start. RK4's error is O(h⁴) (≈ 1e−9 rad here): the reference. The plant's Euler is first
order: for a constant acceleration a its position is off by exactly ½·a·h·T = ½·h·Δω
(Σ_{k≤N} k·h²·a against ½·a·T²), so the tolerance is h·max|Δω| (twice that leading term),
the error must halve with h, and Richardson's 2·q(h/2) − q(h) — whose first-order terms
cancel — must sit far closer to MuJoCo's. A model error does not shrink with h and fails
the last check even where it hides inside the first.
"""

from __future__ import annotations

import copy
import functools
import tomllib
from dataclasses import replace

import mujoco
import numpy as np
import pytest
from conftest import CONFIGS
from omx_mujoco import omx_model
from omx_numbers import OMX, OMX_ANISO

from firmware_sim.arm_model import ArmModel, load_arm
from firmware_sim.bus import SimBus
from firmware_sim.clock import VirtualClock
from firmware_sim.dynamics import PHYSICS_STEP_S
from robodcn.dynamics import RigidChain

CHAINS = {"omx": OMX, "anisotropic": OMX_ANISO}
PAYLOADS = (0.0, 0.5)
DOC = tomllib.loads((CONFIGS / "omx.toml").read_text(encoding="utf-8"))


def fw_doc(chain: RigidChain, payload: float) -> dict:
    """omx.toml with the chain's moments about the other axes and the payload."""
    doc = copy.deepcopy(DOC)
    doc["dynamics"].update(payload_kg=payload,
                           link_inertias_r=[link.inertia_r for link in chain.links],
                           link_inertias_z=[link.inertia_z for link in chain.links])
    return doc


@functools.cache
def engines(name: str, payload: float) -> tuple[ArmModel, mujoco.MjModel]:
    chain = CHAINS[name]
    return load_arm(fw_doc(chain, payload)), omx_model(chain, payload)


def fw_qacc(model: ArmModel, q, qd, tau) -> np.ndarray:
    m, bias = model.dynamics(list(q), list(qd))
    rotor = np.diag(model.rotor_inertia)
    return np.linalg.solve(np.array(m) + rotor, np.asarray(tau) - np.array(bias))


def mj_qacc(m: mujoco.MjModel, q, qd, tau) -> np.ndarray:
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, qd, tau
    mujoco.mj_forward(m, d)
    return d.qacc.copy()


def test_both_engines_read_the_same_arm():
    model, m = engines("anisotropic", 0.5)
    chain = OMX_ANISO
    assert model.masses == pytest.approx([link.mass for link in chain.links], rel=1e-15)
    np.testing.assert_allclose(model.com, [link.com for link in chain.links], rtol=1e-15)
    assert model.inertias == pytest.approx([link.inertia for link in chain.links], rel=1e-15)
    assert model.inertias_r == pytest.approx([link.inertia_r for link in chain.links])
    assert model.inertias_z == pytest.approx([link.inertia_z for link in chain.links])
    np.testing.assert_allclose(model.rotor_inertia, m.dof_armature, rtol=1e-15)
    assert model.gravity == (0.0, m.opt.gravity[2])
    assert m.nv == model.dof == 4


@pytest.mark.parametrize("payload", PAYLOADS)
@pytest.mark.parametrize("name", sorted(CHAINS))
def test_forward_dynamics_match_mj_forward(name, payload):
    """Random poses, rates (the yaw up to 6 rad/s: its coupling with the chain) and
    torques up to the servo's 4 N·m."""
    model, m = engines(name, payload)
    rng = np.random.default_rng(18)
    for _ in range(60):
        q = rng.uniform(-np.pi, np.pi, 4)
        qd = rng.uniform(-6.0, 6.0, 4)
        tau = rng.uniform(-4.0, 4.0, 4)
        ref = mj_qacc(m, q, qd, tau)
        np.testing.assert_allclose(fw_qacc(model, q, qd, tau), ref, rtol=1e-9,
                                   atol=1e-9 * np.abs(ref).max())


@pytest.mark.parametrize("name", sorted(CHAINS))
def test_the_yaw_coupling_is_not_idle(name):
    """The states of the test above exercise every term: with the yaw spinning, the
    chain's accelerations differ from those without it by far more than the tolerance,
    and the links' own moments change the yaw's acceleration (anisotropic: also its
    coupling), so a missing term cannot pass."""
    model, m = engines(name, 0.0)
    q, qd, tau = [0.3, -0.8, 0.6, 0.9], [5.0, 1.0, -2.0, 1.5], [1.0, 0.5, -0.3, 0.2]
    spun = mj_qacc(m, q, qd, tau)
    still = mj_qacc(m, q, [0.0, *qd[1:]], tau)
    assert np.abs(spun[1:] - still[1:]).min() > 1e-3
    point_masses = load_arm(DOC)                    # the file alone: I_r = I_z = 0
    assert abs(fw_qacc(point_masses, q, qd, tau)[0] - spun[0]) > 1e-3 * abs(spun[0])
    np.testing.assert_allclose(fw_qacc(model, q, qd, tau), spun, rtol=1e-9)


# ---- (b) a free motion ----------------------------------------------------------------
START_Q = (0.4, -0.6, 0.5, 0.3)            # rad: leaning back, elbow and wrist bent
START_QD = (3.0, 1.0, -1.5, 2.0)           # rad/s: the yaw spinning, the chain moving
DURATION_S = 0.3
SAMPLES = 30                                # compared every 10 ms
MJ_STEP_S = 1e-4


def fw_free_motion(name: str, payload: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Joint angles (SAMPLES, 4) of firmware_sim's arm with torque off (the servos' state
    at power-on), every DURATION_S / SAMPLES, on a virtual clock."""
    doc = fw_doc(CHAINS[name], payload)
    clock = VirtualClock()
    with SimBus(arm=doc, dynamics=True, clock=clock) as bus:
        ids = [jm.servo_id for jm in bus.arm.joints]
        servo = bus.servo(ids[0])
        plant = servo.motion.plant
        assert not any(bus.servo(i).torque_enabled for i in ids)
        for d in plant.drives:
            d.motor = replace(d.motor, coulomb=0.0)
        plant.step = step
        plant.theta = [plant.shaft_angle(j, q) for j, q in enumerate(START_Q)]
        plant.omega = [w * rho for w, rho in zip(START_QD, plant.rho, strict=True)]
        out = []
        for _ in range(SAMPLES):
            clock.advance(DURATION_S / SAMPLES)
            servo.update()
            out.append([plant.joint_angle(j) for j in range(4)])
        viscous = [d.motor.viscous for d in plant.drives]
    return np.array(out), np.array(viscous)


def mj_free_motion(name: str, payload: float, viscous: np.ndarray) -> tuple[np.ndarray,
                                                                             np.ndarray]:
    """(angles, rates) (SAMPLES, 4) of MuJoCo's RK4 with the servos' viscous damping."""
    m = omx_model(CHAINS[name], payload)
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    m.opt.timestep = MJ_STEP_S
    m.dof_damping[:] = viscous
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = START_Q, START_QD
    per_sample = round(DURATION_S / SAMPLES / MJ_STEP_S)
    angles, rates = [], []
    for _ in range(SAMPLES):
        mujoco.mj_step(m, d, nstep=per_sample)
        angles.append(d.qpos.copy())
        rates.append(d.qvel.copy())
    return np.array(angles), np.array(rates)


@pytest.mark.parametrize("payload", PAYLOADS)
@pytest.mark.parametrize("name", sorted(CHAINS))
def test_free_motion_under_gravity_matches_mujoco(name, payload):
    h = PHYSICS_STEP_S                                  # the plant's own step, 0.5 ms
    coarse, viscous = fw_free_motion(name, payload, h)
    fine, _ = fw_free_motion(name, payload, h / 2)
    ref, rates = mj_free_motion(name, payload, viscous)
    # the motion is a real one: the arm falls and the yaw's rate changes with its reach
    assert np.abs(ref[-1] - START_Q).min() > 0.05
    delta_omega = np.abs(rates - START_QD).max()
    assert abs(rates[-1, 0] - START_QD[0]) > 0.05
    err_coarse = np.abs(coarse - ref).max()
    err_fine = np.abs(fine - ref).max()
    err_richardson = np.abs(2 * fine - coarse - ref).max()
    assert err_coarse <= h * delta_omega, (err_coarse, h * delta_omega)
    assert 0.4 <= err_fine / err_coarse <= 0.6, (err_fine, err_coarse)     # first order
    assert err_richardson <= 0.01 * err_coarse, (err_richardson, err_coarse)
