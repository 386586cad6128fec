"""An arm's rigid-body description for :mod:`robodcn.dynamics`: the one builder.

The dynamics package takes plain numbers (it sits below the configuration); this module
turns an :class:`~robodcn.config.Arm` into that :class:`~robodcn.dynamics.RigidChain`, so the
optimal timing's torque limits, the current prediction, the tracking compensation, the
collision threshold and ``check-config --payload`` all see the same bodies.

Where the ``[dynamics]`` table is silent, the defaults of a light Dynamixel arm apply:
0.10 kg a link (its next servo included), the centre of mass mid-link, a slender rod's
inertia m·l²/12 about it, and each servo's reflected rotor inertia J_rotor·N² from its
datasheet figures (:attr:`robodcn.servo_models.ServoModel.rotor_inertia`: the figure
firmware_sim's motor uses, e.g.
1.0e-7 kg·m² × 353.5² ≈ 0.0125 kg·m² for the XM430-W350; ../shared/omx.md).
"""

from __future__ import annotations

from robodcn.config._specs import Arm
from robodcn.dynamics import Link, RigidChain, Yaw
from robodcn.servo_models import SERVO_SPECS

#: Default mass of a chain link, kg (a bracket with the next servo's share).
DEFAULT_LINK_MASS_KG = 0.10
#: Reflected rotor inertia J_rotor·N² at the output shaft per servo model, kg·m² (the
#: records' :attr:`~robodcn.servo_models.ServoModel.rotor_inertia`).
ROTOR_INERTIA = {name: model.rotor_inertia for name, model in SERVO_SPECS.items()}


def rotor_inertias(arm: Arm) -> tuple[float, ...]:
    """Per joint (yaw first) J_rotor·N²: the file's ``rotor_inertia_kg_m2``, else the model's."""
    given = arm.mass_properties.rotor_inertia
    if given is not None:
        return tuple(float(v) for v in given)
    return tuple(ROTOR_INERTIA.get(s.model, 0.0) for s in arm.servos)


def rigid_chain(arm: Arm) -> RigidChain:
    """The arm's bodies as a :class:`RigidChain` (joint order: the arm's, yaw first).

    A yawed arm turns clockwise-positive in its vertical (r, z) plane (ROBOTIS's servo
    angles, ``sense="cw"``) with gravity along −z; a planar arm is counter-clockwise in
    its plane with the file's in-plane gravity (0 for a horizontal arm).
    """
    props = arm.mass_properties
    vectors = [tuple(float(c) for c in v) for v in arm.chain_links.tolist()]
    lengths = [float((x * x + y * y) ** 0.5) for x, y in vectors]
    n = len(vectors)
    masses = props.link_masses or (DEFAULT_LINK_MASS_KG,) * n
    com = props.link_com or tuple((0.5 * x, 0.5 * y) for x, y in vectors)
    inertias = props.link_inertias or tuple(
        m * length ** 2 / 12.0 for m, length in zip(masses, lengths, strict=True))
    armature = rotor_inertias(arm)
    chain_armature = armature[1:] if arm.yawed else armature
    links = tuple(Link(vector=v, mass=float(m), com=tuple(c), inertia=float(i), armature=a)
                  for v, m, c, i, a in zip(vectors, masses, com, inertias, chain_armature,
                                           strict=True))
    if not arm.yawed:
        return RigidChain(links, gravity=props.gravity, sense="ccw")
    yaw = Yaw(mass=float(props.yaw_body_mass or 0.0),
              com=tuple(props.yaw_body_com or (0.0, 0.0)),
              inertia_z=float(props.yaw_body_inertia or 0.0), armature=armature[0])
    return RigidChain(links, yaw=yaw, shoulder=(0.0, float(arm.shoulder_height)),
                      gravity=props.gravity, sense="cw")


__all__ = ["DEFAULT_LINK_MASS_KG", "ROTOR_INERTIA", "rigid_chain", "rotor_inertias"]
