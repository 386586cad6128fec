"""An MJCF model of the OpenMANIPULATOR-X, written for the tests from ../shared/omx.md
(not ROBOTIS's file): MuJoCo is the independent engine robodcn's dynamics and kinematics
are checked against. Tests only; the product never imports mujoco.

The model, base frame as in omx.md (origin on the yaw axis at the mounting plate, z up, x
forward at yaw 0)::

    world
    └─ yaw body       hinge "yaw"      axis +z at the origin
       └─ link1       hinge "shoulder" axis +y at (0, 0, h)        h = shoulder height
          └─ link2    hinge "elbow"    axis +y at link1's vector (0.024, 0, 0.128)
             └─ link3 hinge "wrist"    axis +y at link2's vector (0.124, 0, 0)
                ├─ site "tool"            at link3's vector (0.126, 0, 0)
                └─ body "payload"         a point mass there (optional)

A rotation about +y by a positive angle turns x toward −z: ROBOTIS's "forward and down".
Each body's ``inertial`` is its mass, its centre of mass (r, 0, z) from its joint at zero
and the principal moments (I_xx, I_yy, I_zz) there along the base axes at zero; every joint
has the servo's reflected rotor inertia as ``armature``, no damping, no limits, no geoms
(so no contacts). The numbers come from a :class:`robodcn.dynamics.RigidChain` (the test
fixture :mod:`omx_numbers` reads configs/omx.toml), so both engines see the same arm; the
axes and signs above are MuJoCo's own.
"""

from __future__ import annotations

import mujoco

from robodcn.dynamics import RigidChain

#: Moment (kg·m²) about each axis of the payload body: MuJoCo wants a positive inertia; this
#: one adds < 1e−9 N·m at the accelerations of the tests (a point mass in robodcn).
PAYLOAD_INERTIA = 1e-12
JOINTS = ("yaw", "shoulder", "elbow", "wrist")


def _v(*values: float) -> str:
    return " ".join(repr(float(v)) for v in values)


def omx_xml(chain: RigidChain, payload_kg: float = 0.0) -> str:
    """The MJCF text of the OM-X (module docstring) with ``chain``'s numbers."""
    if chain.yaw is None or chain.sense != "cw" or len(chain.links) != 3:
        raise ValueError("omx_xml models a yawed 3-link chain with ROBOTIS's signs")
    yaw = chain.yaw
    gravity = -chain.gravity[1]
    link1, link2, link3 = chain.links

    def inertial(link) -> str:
        return (f'<inertial pos="{_v(link.com[0], 0, link.com[1])}" mass="{link.mass!r}" '
                f'diaginertia="{_v(link.inertia_r, link.inertia, link.inertia_z)}"/>')

    def hinge(name: str, axis: str, armature: float) -> str:
        return (f'<joint name="{name}" type="hinge" axis="{axis}" armature="{armature!r}" '
                f'damping="0" limited="false"/>')

    payload = ""
    if payload_kg > 0.0:
        payload = (f'<body name="payload" pos="{_v(link3.vector[0], 0, link3.vector[1])}">'
                   f'<inertial pos="0 0 0" mass="{payload_kg!r}" '
                   f'diaginertia="{_v(PAYLOAD_INERTIA, PAYLOAD_INERTIA, PAYLOAD_INERTIA)}"/>'
                   f'</body>')
    return f"""
<mujoco model="omx">
  <compiler angle="radian" inertiafromgeom="false" autolimits="true"/>
  <option gravity="0 0 {-gravity!r}"/>
  <worldbody>
    <body name="yaw" pos="0 0 0">
      {hinge("yaw", "0 0 1", yaw.armature)}
      <inertial pos="{_v(yaw.com[0], 0, yaw.com[1])}" mass="{max(yaw.mass, 1e-9)!r}"
                diaginertia="{_v(*(max(yaw.inertia_z, 1e-12),) * 3)}"/>
      <body name="link1" pos="{_v(chain.shoulder[0], 0, chain.shoulder[1])}">
        {hinge("shoulder", "0 1 0", link1.armature)}
        {inertial(link1)}
        <body name="link2" pos="{_v(link1.vector[0], 0, link1.vector[1])}">
          {hinge("elbow", "0 1 0", link2.armature)}
          {inertial(link2)}
          <body name="link3" pos="{_v(link2.vector[0], 0, link2.vector[1])}">
            {hinge("wrist", "0 1 0", link3.armature)}
            {inertial(link3)}
            <site name="tool" pos="{_v(link3.vector[0], 0, link3.vector[1])}"/>
            {payload}
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def omx_model(chain: RigidChain, payload_kg: float = 0.0) -> mujoco.MjModel:
    """The compiled MjModel of :func:`omx_xml`."""
    return mujoco.MjModel.from_xml_string(omx_xml(chain, payload_kg))
