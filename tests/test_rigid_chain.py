"""robodcn.config.rigid_chain: the arm file's bodies reach the dynamics as written."""

from __future__ import annotations

import numpy as np
import pytest
from planar_reference import ArmDynamics

from robodcn import load_arm
from robodcn.config import rigid_chain
from robodcn.dynamics import gravity_torque, inverse_dynamics, tool_point
from robodcn.kinematics import fk_yawed

OMX = load_arm("configs/omx.toml")
ARM3R = load_arm("configs/arm3r.toml")


def test_omx_chain_is_the_file():
    chain = rigid_chain(OMX)
    props = OMX.mass_properties
    assert chain.yaw is not None and chain.sense == "cw"
    assert [link.mass for link in chain.links] == list(props.link_masses)
    assert chain.shoulder == (0.0, OMX.shoulder_height)
    assert chain.yaw.armature == pytest.approx(props.rotor_inertia[0])


def test_omx_tool_point_is_the_kinematics_tool_point():
    rng = np.random.default_rng(3)
    lo = np.array([j.min_angle for j in OMX.joints])
    hi = np.array([j.max_angle for j in OMX.joints])
    q = rng.uniform(lo, hi, size=(50, 4))
    pose = fk_yawed(OMX.chain, q)
    assert np.allclose(tool_point(rigid_chain(OMX), q), pose[:, :3], atol=1e-12)


def test_omx_shoulder_holds_the_published_torque_at_zero():
    # ../shared/omx.md: ≈ 0.43 N·m at zero (rough figure).
    tau = gravity_torque(rigid_chain(OMX), np.zeros(4))
    assert abs(tau[1]) == pytest.approx(0.43, rel=0.1)


def test_planar_defaults_match_the_stream_planar_model():
    """The default bodies of a planar arm are those of the stream's planar model."""
    chain = rigid_chain(ARM3R)
    model = ArmDynamics.of(ARM3R.links, {"gravity": [0.0, -9.81]})
    assert [link.mass for link in chain.links] == pytest.approx(list(model.masses))
    assert [link.inertia for link in chain.links] == pytest.approx(list(model.inertias))
    q = np.array([[0.3, -0.7, 0.2]])
    tau = inverse_dynamics(chain, q, np.zeros_like(q), np.ones_like(q))
    armature = np.array([link.armature for link in chain.links])
    assert np.all(tau[0] > armature)      # the rotor inertia is in (and positive)
