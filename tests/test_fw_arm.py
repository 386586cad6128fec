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


def _doc(**dynamics) -> dict:
    import tomllib
    data = tomllib.loads(ARM3.read_text())
    if dynamics:
        data["dynamics"] = dynamics
    return data


def _fk_points(model, q):
    """Bodies' positions and link angles from plain trigonometry (no arm_model algebra)."""
    pts, phi, x, y = [], 0.0, 0.0, 0.0
    for i, length in enumerate(model.links):
        phi += q[i]
        pts.append((x + model.com[i] * math.cos(phi), y + model.com[i] * math.sin(phi)))
        x, y = x + length * math.cos(phi), y + length * math.sin(phi)
    if model.payload:
        pts.append((x, y))
    return np.array(pts), np.cumsum(q)


def _lagrangian(model, q, qd):
    eps = 1e-6
    p1, a1 = _fk_points(model, q + eps * qd)
    p0, a0 = _fk_points(model, q - eps * qd)
    v = (p1 - p0) / (2 * eps)
    w = (a1 - a0) / (2 * eps)
    masses = list(model.masses) + ([model.payload] if model.payload else [])
    kinetic = 0.5 * sum(m * vi @ vi for m, vi in zip(masses, v, strict=True)) \
        + 0.5 * sum(i * wi ** 2 for i, wi in zip(model.inertias, w, strict=True))
    pts, _ = _fk_points(model, q)
    potential = -sum(m * (model.gravity[0] * p[0] + model.gravity[1] * p[1])
                     for m, p in zip(masses, pts, strict=True))
    return kinetic - potential


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


@pytest.mark.parametrize("dynamics", [
    {}, {"gravity": True, "payload_kg": 0.2},
    {"link_masses": [0.3, 0.2, 0.1], "link_com": [0.05, 0.1, 0.0], "gravity": [1.0, -9.0]},
])
def test_dynamics_match_a_numerical_lagrangian(dynamics):
    model = load_arm(_doc(**dynamics))
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-2, 2, 3), rng.uniform(-3, 3, 3), rng.uniform(-5, 5, 3)
        m, bias = model.dynamics(q, qd)
        tau = np.array(m) @ qdd + np.array(bias)
        ref = _euler_lagrange(model, q, qd, qdd)
        # nested finite differences carry ~1e-4 relative noise; a wrong term is O(1)
        assert np.allclose(tau, ref, rtol=5e-3, atol=1e-4), (tau, ref)


def test_free_arm_conserves_energy():
    """The plant with the motors' friction and back-EMF removed keeps the arm's energy."""
    model = load_arm(_doc(gravity=True, payload_kg=0.1))
    clock = VirtualClock()
    bus = SimBus(arm=_doc(gravity=True, payload_kg=0.1), dynamics=True, clock=clock)
    plant = bus.servo(1).motion.plant
    for d in plant.drives:                      # a frictionless, unmotored arm
        d.motor = type(d.motor)(**{**d.motor.__dict__, "viscous": 0.0, "coulomb": 0.0,
                                   "rotor_inertia": 1e-12})
    plant.inertia = [d.motor.inertia for d in plant.drives]
    plant.omega = [2.0, -1.0, 3.0]
    q0 = [plant.joint_angle(j) for j in range(3)]

    def energy():
        q = [plant.joint_angle(j) for j in range(3)]
        qd = [plant.omega[j] / plant.rho[j] for j in range(3)]
        return model.energy(q, qd)

    e0 = energy()
    plant.step = 1e-5
    clock.advance(0.2)
    bus.servo(1).update()
    assert abs(energy() - e0) <= 1e-2 * abs(e0)     # semi-implicit Euler's drift
    assert [plant.joint_angle(j) for j in range(3)] != q0


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


def test_arm_config_errors_name_the_key():
    with pytest.raises(ArmConfigError, match=r"dynamics\.link_masses"):
        load_arm(_doc(link_masses=[1.0]))
    with pytest.raises(ArmConfigError, match="dynamics: unknown key"):
        load_arm(_doc(mass=1.0))
    with pytest.raises(ValueError, match="needs the physics model"):
        SimBus(arm=ARM3)


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
