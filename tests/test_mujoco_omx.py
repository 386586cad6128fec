"""MuJoCo as an independent engine: robodcn's OM-X inverse dynamics, mass matrix, holding
torques and tool point against mj_inverse, mj_fullM and the site position of the MJCF model
in omx_mujoco.py (same numbers, MuJoCo's own axes and signs; rotor inertia as armature)."""

from __future__ import annotations

import functools

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from omx_mujoco import JOINTS, omx_model
from omx_numbers import OMX, OMX_ANISO, OMX_ARM

from robodcn import kinematics
from robodcn.dynamics import (
    RigidChain,
    gravity_torque,
    inverse_dynamics,
    mass_matrix,
    tool_point,
)

CHAINS = {"omx": OMX, "anisotropic": OMX_ANISO}


@functools.cache
def model(name: str, payload: float) -> mujoco.MjModel:
    return omx_model(CHAINS[name], payload)


def mj_inverse(m: mujoco.MjModel, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """MuJoCo's qfrc_inverse (n, 4), one sample at a time."""
    d = mujoco.MjData(m)
    out = np.empty_like(q)
    for i in range(len(q)):
        d.qpos[:], d.qvel[:], d.qacc[:] = q[i], qd[i], qdd[i]
        mujoco.mj_inverse(m, d)
        out[i] = d.qfrc_inverse
    return out


def draw(data, n: int, scale: float) -> np.ndarray:
    seed = data.draw(st.integers(0, 2 ** 32 - 1))
    return np.random.default_rng(seed).uniform(-scale, scale, (n, 4))


def test_the_model_has_the_joints_in_robodcns_order():
    m = model("omx", 0.0)
    assert [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, i) for i in range(m.njnt)] \
        == list(JOINTS) == list(OMX_ARM.joint_names)
    np.testing.assert_allclose(m.dof_armature, OMX.armature)
    assert m.opt.gravity.tolist() == [0.0, 0.0, OMX.gravity[1]]


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(sorted(CHAINS)), st.sampled_from([0.0, 0.5]), st.data())
def test_inverse_dynamics_matches_mj_inverse(name, payload, data):
    """Random (q, q̇, q̈) with the yaw: fast yaw rates bring in the chain's coupling terms."""
    q = draw(data, 8, np.pi)
    qd = draw(data, 8, 5.0)
    qdd = draw(data, 8, 30.0)
    ours = inverse_dynamics(CHAINS[name], q, qd, qdd, payload)
    np.testing.assert_allclose(ours, mj_inverse(model(name, payload), q, qd, qdd),
                               rtol=1e-9, atol=1e-8)


@settings(max_examples=30, deadline=None)
@given(st.sampled_from(sorted(CHAINS)), st.sampled_from([0.0, 0.5]), st.data())
def test_mass_matrix_matches_mujoco(name, payload, data):
    m = model(name, payload)
    d = mujoco.MjData(m)
    q = draw(data, 1, np.pi)[0]
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    full = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, full)         # MuJoCo 4: (model, data, dst)
    np.testing.assert_allclose(mass_matrix(CHAINS[name], q, payload), full, rtol=1e-9,
                               atol=1e-12)


@pytest.mark.parametrize("payload", [0.0, 0.5])
def test_holding_torques_match_mj_inverse(payload):
    """At rest, at zero, stretched out horizontally and at random poses (omx.md's figures
    are in test_dynamics)."""
    r, z = OMX.links[0].vector
    lean = np.arctan2(z, r)
    q = np.vstack([np.zeros(4), [0.0, lean, -lean, 0.0],
                   np.random.default_rng(7).uniform(-1.5, 1.5, (6, 4))])
    zero = np.zeros_like(q)
    np.testing.assert_allclose(gravity_torque(OMX, q, payload),
                               mj_inverse(model("omx", payload), q, zero, zero),
                               rtol=1e-9, atol=1e-10)


@settings(max_examples=40, deadline=None)
@given(st.data())
def test_tool_point_matches_mujocos_site_and_the_yawed_fk(data):
    """robodcn.dynamics.tool_point, robodcn.kinematics.fk_yawed and MuJoCo's tool site agree."""
    m = model("omx", 0.0)
    d = mujoco.MjData(m)
    q = draw(data, 5, np.pi)
    site = np.empty((len(q), 3))
    for i, row in enumerate(q):
        d.qpos[:] = row
        mujoco.mj_kinematics(m, d)
        site[i] = d.site_xpos[0]
    np.testing.assert_allclose(tool_point(OMX, q), site, atol=1e-12)
    np.testing.assert_allclose(kinematics.fk_yawed(OMX_ARM.chain, q)[:, :3], site, atol=1e-12)


def test_published_tool_point_at_zero():
    """omx.md: (0.274, 0, 0.2045) m at zero joint angles, in MuJoCo too."""
    m = model("omx", 0.0)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    np.testing.assert_allclose(d.site_xpos[0], [0.274, 0.0, 0.2045], atol=1e-9)


def test_a_wrong_sign_would_show():
    """The check can fail: the same numbers with the CCW convention disagree with MuJoCo."""
    ccw = RigidChain(OMX.links, yaw=OMX.yaw, shoulder=OMX.shoulder, gravity=OMX.gravity,
                     sense="ccw")
    q = np.array([[0.0, 0.4, -0.3, 0.2]])
    zero = np.zeros_like(q)
    ref = mj_inverse(model("omx", 0.0), q, zero, zero)
    assert np.abs(gravity_torque(ccw, q) - ref).max() > 0.01
