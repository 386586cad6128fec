"""The arm load: planar chain dynamics against an independent Lagrangian, and the arm TOML.

The reference takes the kinetic energy straight from the bodies' positions (finite
differences of forward kinematics, no mass matrix) and forms the Euler–Lagrange torques
τ = d/dt(∂T/∂q̇) − ∂T/∂q + ∂V/∂q by finite differences; arm_model's closed form must agree.
"""

from __future__ import annotations

import math
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from firmware_sim.arm_model import ArmConfigError, load_arm
from firmware_sim.bus import SimBus
from firmware_sim.clock import VirtualClock
from firmware_sim.control_socket import execute

ROOT = Path(__file__).resolve().parent.parent
ARM3 = ROOT / "configs" / "arm3r.toml"
OMX = ROOT / "configs" / "omx.toml"


def _doc(**dynamics) -> dict:
    import tomllib
    data = tomllib.loads(ARM3.read_text())
    if dynamics:
        data["dynamics"] = dynamics
    return data


def _omx_doc(**dynamics) -> dict:
    import tomllib
    data = tomllib.loads(OMX.read_text())
    data["dynamics"].update(dynamics)
    return data


def _rot(v, a):
    return (v[0] * math.cos(a) - v[1] * math.sin(a), v[0] * math.sin(a) + v[1] * math.cos(a))


def _fk_points(model, q):
    """Bodies' positions in the chain's plane and in 3-D, the links' plane angles and the
    yaw, from plain trigonometry (no arm_model algebra). A yawed chain turns clockwise
    in (r, z) for positive angles; the yaw turns (r, z) about the vertical."""
    yaw, qc = (q[0], q[1:]) if model.base_yaw else (0.0, q)
    sign = -1 if model.base_yaw else 1
    plane, angles, joint, phi = [], [], (0.0, model.shoulder_height), 0.0
    for i, link in enumerate(model.links):
        phi += sign * qc[i]
        angles.append(phi)
        c = _rot(model.com[i], phi)
        plane.append((joint[0] + c[0], joint[1] + c[1]))
        step = _rot(link, phi)
        joint = (joint[0] + step[0], joint[1] + step[1])
    if model.payload:
        plane.append(joint)
    space = [(r * math.cos(yaw), r * math.sin(yaw), z) for r, z in plane]
    return np.array(plane), np.array(space), np.array(angles), yaw


def _lagrangian(model, q, qd):
    eps = 1e-6
    _, p1, a1, y1 = _fk_points(model, q + eps * qd)
    _, p0, a0, y0 = _fk_points(model, q - eps * qd)
    v = (p1 - p0) / (2 * eps)
    w = (a1 - a0) / (2 * eps)
    wy = (y1 - y0) / (2 * eps)
    masses = list(model.masses) + ([model.payload] if model.payload else [])
    kinetic = 0.5 * sum(m * vi @ vi for m, vi in zip(masses, v, strict=True)) \
        + 0.5 * sum(i * wi ** 2 for i, wi in zip(model.inertias, w, strict=True)) \
        + 0.5 * model.yaw_inertia * wy ** 2 + 0.5 * wy ** 2 * _links_about_vertical(model, q)
    plane, _, _, _ = _fk_points(model, q)
    potential = -sum(m * (model.gravity[0] * p[0] + model.gravity[1] * p[1])
                     for m, p in zip(masses, plane, strict=True))
    return kinetic - potential


def _links_about_vertical(model, q):
    """Σ_s ẑᵀ R I_s Rᵀ ẑ: each link's principal moments (radial, joint axis, vertical at
    zero) turned by its plane angle about the joint axis, seen along the vertical."""
    if not model.base_yaw or (model.inertias_r is None and model.inertias_z is None):
        return 0.0
    _, _, angles, _ = _fk_points(model, q)
    total = 0.0
    for s, theta in enumerate(-angles):              # a turn by θ about +y
        rot = np.array([[math.cos(theta), 0, math.sin(theta)], [0, 1, 0],
                        [-math.sin(theta), 0, math.cos(theta)]])
        body = np.diag([(model.inertias_r or (0.0,) * 3)[s], model.inertias[s],
                        (model.inertias_z or (0.0,) * 3)[s]])
        total += (rot @ body @ rot.T)[2, 2]
    return total


def _euler_lagrange(model, q, qd, qdd):
    n, h = len(q), 1e-4

    def dl_dqd(qq, qqd):
        return np.array([(_lagrangian(model, qq, qqd + h * e) - _lagrangian(model, qq, qqd - h * e))
                         / (2 * h) for e in np.eye(n)])

    dt = 1e-4
    ddt = (dl_dqd(q + dt * qd, qd + dt * qdd) - dl_dqd(q - dt * qd, qd - dt * qdd)) / (2 * dt)
    dl_dq = np.array([(_lagrangian(model, q + h * e, qd) - _lagrangian(model, q - h * e, qd))
                      / (2 * h) for e in np.eye(n)])
    return ddt - dl_dq


@pytest.mark.parametrize("doc", [
    _doc(), _doc(gravity=True, payload_kg=0.2),
    _doc(link_masses=[0.3, 0.2, 0.1], link_com=[0.05, 0.1, 0.0], gravity=[1.0, -9.0]),
    _omx_doc(), _omx_doc(payload_kg=0.5),
    _omx_doc(link_inertias_r=[2e-4, 1e-4, 5e-5], link_inertias_z=[3e-4, 2.2e-4, 9e-5]),
], ids=["arm3r", "arm3r-gravity", "arm3r-masses", "omx", "omx-payload", "omx-link-moments"])
def test_dynamics_match_a_numerical_lagrangian(doc):
    model = load_arm(doc)
    n = model.dof
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-2, 2, n), rng.uniform(-3, 3, n), rng.uniform(-5, 5, n)
        m, bias = model.dynamics(q, qd)
        tau = np.array(m) @ qdd + np.array(bias)
        ref = _euler_lagrange(model, q, qd, qdd)
        # nested finite differences carry ~1e-4 relative noise; a wrong term is O(1)
        scale = max(1.0, float(np.abs(ref).max()))
        assert np.allclose(tau, ref, rtol=5e-3, atol=1e-4 * scale), (tau, ref)


def test_omx_file_reads_as_a_yawed_vertical_arm_under_gravity():
    model = load_arm(OMX)
    assert model.base_yaw and model.dof == 4
    assert [jm.servo_id for jm in model.joints] == [11, 12, 13, 14]
    assert model.gripper is not None and model.gripper.servo_id == 15
    assert model.gravity == (0.0, -9.81)
    assert model.rotor_inertia == (0.0125,) * 4
    # shaped like ROBOTIS's arm at zero: the tool point at (0.274, 0.2045) in (r, z)
    tool = load_arm(_omx_doc(payload_kg=0.1)).body_positions([0.0] * 4)[-1]
    assert tool == pytest.approx((0.274, 0.2045))
    # holding torques at zero (omx.md: the shoulder ≈ 0.43 N·m); gravity pulls the arm
    # forward and down, i.e. towards positive shoulder angles, so holding pushes back
    _, bias = model.dynamics([0.0] * 4, [0.0] * 4)
    assert bias[0] == 0.0                                    # gravity does not load the yaw
    assert bias[1] == pytest.approx(-9.81 * (0.1385 * 0.0103 + 0.1327 * 0.1149
                                             + 0.1433 * 0.1922), rel=1e-9)
    assert -0.44 < bias[1] < -0.43
    # stretched out horizontally (every link level) the shoulder holds ≈ 0.84 N·m
    level = math.pi / 2 - math.atan2(0.024, 0.128)
    _, bias = model.dynamics([0.0, level, -level, 0.0], [0.0] * 4)
    assert 0.80 < -bias[1] < 0.90
    # the yaw's inertia grows with the reach: Σ m r² of the chain
    m_folded, _ = model.dynamics([0.0, -1.4, 1.3, 0.8], [0.0] * 4)
    m_zero, _ = model.dynamics([0.0] * 4, [0.0] * 4)
    assert m_zero[0][0] > m_folded[0][0] > model.yaw_inertia
    assert all(m_zero[0][j] == 0.0 for j in range(1, 4))


@pytest.mark.parametrize("doc, omega", [
    (_doc(gravity=True, payload_kg=0.1), [2.0, -1.0, 3.0]),
    (_omx_doc(payload_kg=0.2), [3.0, 2.0, -1.0, 3.0]),        # the yaw spinning too
], ids=["arm3r", "omx"])
def test_free_arm_conserves_energy(doc, omega):
    """The plant with the motors' friction and back-EMF removed keeps the arm's energy."""
    model = load_arm(doc)
    clock = VirtualClock()
    zero = {jm.servo_id: jm.zero_offset for jm in model.joints}   # not at rest: at zero
    bus = SimBus(arm=doc, dynamics=True, clock=clock, positions=zero)
    plant = bus.servo(model.joints[0].servo_id).motion.plant
    n = model.dof
    for d in plant.drives:                      # a frictionless, unmotored arm
        d.motor = type(d.motor)(**{**d.motor.__dict__, "viscous": 0.0, "coulomb": 0.0,
                                   "rotor_inertia": 1e-12})
    plant.inertia = [d.motor.inertia for d in plant.drives]
    plant.stops, plant.rest_support = [None] * n, []    # nothing to hit: a free chain
    plant.omega = list(omega)
    q0 = [plant.joint_angle(j) for j in range(n)]

    def energy():
        q = [plant.joint_angle(j) for j in range(n)]
        qd = [plant.omega[j] / plant.rho[j] for j in range(n)]
        return model.energy(q, qd)

    e0 = energy()
    plant.step = 1e-5
    clock.advance(0.2)
    bus.servo(model.joints[0].servo_id).update()
    assert abs(energy() - e0) <= 1e-2 * abs(e0)     # semi-implicit Euler's drift
    assert [plant.joint_angle(j) for j in range(n)] != q0


def test_arm_toml_maps_joints_to_servos_and_obstacles_in_joint_degrees():
    clock = VirtualClock()
    with SimBus(arm=ARM3, dynamics=True, clock=clock) as bus:
        assert [s.id for s in bus.servos] == [1, 2, 3]
        assert [s.present_position for s in bus.servos] == [2048] * 3
        wrist = bus.servo(3)                      # direction -1 in arm3r.toml
        assert execute(bus, "obstacle 3 -10") == "ok"
        wrist.push(1.0)             # ticks up = joint angle down (direction -1): towards it
        clock.advance(1.0)
        # joint -10° with direction -1: tick 2048 + 10·4096/360
        assert wrist.present_position == round(2048 + 10 * 4096 / 360)
        assert execute(bus, "move 2 2100") == "ok" and bus.servo(2).present_position == 2100
        assert execute(bus, "move 9 1").startswith("error no servo 9")
        assert execute(bus, "fly 1 2").startswith("error unknown command")


def test_link_moments_about_the_other_axes_default_to_point_masses():
    """Without link_inertias_r/z the yaw sees the links as point masses (as before the
    keys); with them it sees their moments too, the vertical one at zero."""
    q = [0.0] * 4
    plain = load_arm(_omx_doc())
    zeros = load_arm(_omx_doc(link_inertias_r=[0.0] * 3, link_inertias_z=[0.0] * 3))
    given = load_arm(_omx_doc(link_inertias_r=[1e-3] * 3, link_inertias_z=[2e-3] * 3))
    assert plain.inertias_r is None and plain.inertias_z is None
    assert plain.dynamics(q, [1.0, 2.0, -1.0, 0.5]) == zeros.dynamics(q, [1.0, 2.0, -1.0, 0.5])
    assert given.dynamics(q, q)[0][0][0] == pytest.approx(plain.dynamics(q, q)[0][0][0]
                                                          + 3 * 2e-3, rel=1e-12)
    # the yaw body's inertia about the yaw axis: its own + m·r² of its centre of mass
    assert plain.yaw_inertia == pytest.approx(3.3e-5 + 0.0984 * 0.0003 ** 2, rel=1e-12)
    with pytest.raises(ArmConfigError, match=r"dynamics\.link_inertias_z\[1\]"):
        load_arm(_omx_doc(link_inertias_z=[1e-4, -1e-4, 1e-4]))
    with pytest.raises(ArmConfigError, match=r"dynamics\.link_inertias_r"):
        load_arm(_omx_doc(link_inertias_r=[1e-4]))


def test_arm_config_errors_name_the_key():
    with pytest.raises(ArmConfigError, match=r"dynamics\.link_masses"):
        load_arm(_doc(link_masses=[1.0]))
    with pytest.raises(ArmConfigError, match="dynamics: unknown key"):
        load_arm(_doc(mass=1.0))
    with pytest.raises(ValueError, match="needs the physics model"):
        SimBus(arm=ARM3)
    with pytest.raises(ArmConfigError, match="gravity or gravity_m_s2"):
        load_arm(_omx_doc(gravity=[0.0, -9.81]))
    yawless = _omx_doc()
    yawless["arm"]["base_yaw"] = False
    with pytest.raises(ArmConfigError, match=r"expected 3 .*joints"):
        load_arm(yawless)
    with pytest.raises(ArmConfigError, match="rotor_inertia_kg_m2"):
        load_arm(_omx_doc(rotor_inertia_kg_m2=[0.01, 0.01]))
    with pytest.raises(ArmConfigError, match="no arm of that name"):
        load_arm("no-such-arm")


def test_cli_arm_and_control_socket(tmp_path):
    path = str(tmp_path / "ctl")
    proc = subprocess.Popen([sys.executable, "-m", "firmware_sim", "--arm", str(ARM3),
                             "--control", path], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().startswith("/dev/")
        with socket.socket(socket.AF_UNIX) as s:
            s.connect(path)
            f = s.makefile("rw")
            for line, answer in (("move 2 1500", "ok"), ("push 1 0", "ok"),
                                 ("obstacle 1 30", "ok"), ("move 7 1", "error no servo 7")):
                f.write(line + "\n")
                f.flush()
                assert f.readline().startswith(answer)
            f.write("get 2\n")
            f.flush()
            assert f.readline().split()[:2] == ["ok", "1500"]
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err


def test_cli_dynamics_off_with_arm_is_refused():
    out = subprocess.run([sys.executable, "-m", "firmware_sim", "--arm", str(ARM3),
                          "--dynamics", "off"], cwd=ROOT, capture_output=True, text=True,
                         timeout=20)
    assert out.returncode == 2 and "--arm needs the physics model" in out.stderr
