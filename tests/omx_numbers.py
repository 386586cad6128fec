"""The OpenMANIPULATOR-X numbers the dynamics tests use, read from the packaged configs/omx.toml
(ROBOTIS's figures, ../shared/omx.md), as a :class:`robodcn.dynamics.RigidChain`.

One place for them: tests/test_dynamics.py and the MuJoCo model of tests/omx_mujoco.py both
build from :data:`OMX` / :func:`omx_chain`, so the two engines see the same arm.
"""

from __future__ import annotations

from conftest import CONFIGS

from robodcn.config import Arm, load_arm
from robodcn.dynamics import Link, RigidChain, Yaw

OMX_ARM: Arm = load_arm(CONFIGS / "omx.toml")


def omx_chain(inertia_r: tuple[float, ...] | None = None,
              inertia_z: tuple[float, ...] | None = None) -> RigidChain:
    """The OM-X as a RigidChain; ``inertia_r`` / ``inertia_z`` per link (default: I_yy)."""
    props = OMX_ARM.mass_properties
    assert props.link_masses and props.link_com and props.link_inertias
    assert props.rotor_inertia and props.yaw_body_mass is not None
    assert props.yaw_body_com is not None and props.yaw_body_inertia is not None
    k = len(props.link_masses)
    inertia_r = inertia_r or (None,) * k
    inertia_z = inertia_z or (None,) * k
    links = tuple(
        Link(vector=tuple(v), mass=m, com=c, inertia=i, inertia_r=ir, inertia_z=iz,
             armature=j)
        for v, m, c, i, ir, iz, j in zip(OMX_ARM.chain_links.tolist(), props.link_masses,
                                         props.link_com, props.link_inertias, inertia_r,
                                         inertia_z, props.rotor_inertia[1:], strict=True))
    yaw = Yaw(mass=props.yaw_body_mass, com=props.yaw_body_com,
              inertia_z=props.yaw_body_inertia, armature=props.rotor_inertia[0])
    return RigidChain(links, yaw=yaw, shoulder=(0.0, OMX_ARM.shoulder_height),
                      gravity=props.gravity, sense="cw")


#: The packaged arm with I_xx = I_zz = I_yy on every link.
OMX: RigidChain = omx_chain()
#: Distinct moments about the other axes (I_xx = 0.5·I_yy, I_zz = 0.8·I_yy: they satisfy
#: the triangle inequality MuJoCo checks), so a swapped axis shows in the yaw torque.
OMX_ANISO: RigidChain = omx_chain(
    inertia_r=tuple(0.5 * link.inertia for link in OMX.links),
    inertia_z=tuple(0.8 * link.inertia for link in OMX.links))
#: The joint limits (rad), yaw first.
LOWER = tuple(j.min_angle for j in OMX_ARM.joints)
UPPER = tuple(j.max_angle for j in OMX_ARM.joints)
#: Reflected rotor inertia of an XM430-W350 (omx.md): J_rotor·N² = 1.0e−7 × 353.5².
XM430_ARMATURE = 1.0e-7 * 353.5 ** 2
