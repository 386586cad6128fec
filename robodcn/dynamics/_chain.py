"""The rigid chain an arm's dynamics sees, in plain numbers (SI): links, yaw body, gravity.

Geometry (the arm's vertical plane, coordinates (r, z): r outward, z up; shared/omx.md):

- an optional **base yaw** joint turns the plane about the vertical z axis (positive CCW seen
  from above); its body has a mass, a centre of mass (r, z) and an inertia about the vertical
  axis through that centre;
- the first **chain joint** sits at ``shoulder`` = (r, z) in the yaw frame;
- **link** i goes from its joint to the next by the 2-D vector ``vector`` = (r, z) at zero
  joint angles; its centre of mass ``com`` = (r, z) is measured from its joint, also at zero;
- the **tool point** is the end of the last link's vector (where a payload sits).

``sense`` says which way a positive chain angle turns the link in the (r, z) plane:
``"cw"`` (ROBOTIS's OpenMANIPULATOR-X: a positive shoulder angle leans the arm forward and
down, a rotation about the base's +y axis) or ``"ccw"`` (robodcn's planar arms, where the
"(r, z)" plane is the arm's own (x, y) plane: φ = q₁ + … + q_i counter-clockwise).

Inertias are principal moments at the link's centre of mass, along the axes of the yawed
frame at zero chain angles: ``inertia`` (I_yy) about the joint-axis direction — the only one
a planar chain needs —, ``inertia_r`` (I_xx) about the radial axis and ``inertia_z`` (I_zz)
about the vertical one; the last two default to I_yy and matter only for the yaw joint.

Each joint also carries an ``armature``: the servo's reflected rotor inertia J_rotor·N² at
the output shaft (≈ 1.0e−7 × 353.5² ≈ 0.0125 kg·m² for an XM430-W350), which adds
armature·q̈ to that joint's torque (MuJoCo's ``armature`` is the same term).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from robodcn import _checks
from robodcn.errors import InputError

Sense = Literal["cw", "ccw"]
#: Standard gravity (m/s²) and the (r, z) vector of a vertical arm's plane.
STANDARD_GRAVITY = 9.81
GRAVITY_DOWN = (0.0, -STANDARD_GRAVITY)


def _real(field: str, value: object, *, positive: bool = False,
          nonnegative: bool = False) -> float:
    if not _checks.is_finite_real(value):
        raise InputError(f"{field} must be a finite number, got {_checks.show(value)}",
                         field=field, value=value)
    number = float(value)  # type: ignore[arg-type]
    if positive and number <= 0.0:
        raise InputError(f"{field} must be positive, got {number!r}", field=field,
                         value=value)
    if nonnegative and number < 0.0:
        raise InputError(f"{field} must be ≥ 0, got {number!r}", field=field, value=value)
    return number


def _pair(field: str, value: object) -> tuple[float, float]:
    if not isinstance(value, tuple | list) or len(value) != 2:
        raise InputError(f"{field} must be a pair (r, z) of numbers, got "
                         f"{_checks.show(value)}", field=field, value=value)
    return _real(f"{field}[0]", value[0]), _real(f"{field}[1]", value[1])


@dataclass(frozen=True)
class Link:
    """One link of the planar chain and the joint that turns it (module docstring).

    Parameters
    ----------
    vector : (r, z)
        Its joint → the next joint (or the tool point), m, at zero chain angles.
    mass : float
        kg (> 0), its servo included.
    com : (r, z)
        Centre of mass from its joint, m, at zero chain angles.
    inertia : float
        I_yy: about the joint-axis direction through the centre of mass, kg·m².
    inertia_r, inertia_z : float or None
        I_xx, I_zz at the centre of mass about the radial and vertical axes at zero
        (None: equal to ``inertia``); they only matter for a yaw joint.
    armature : float
        Reflected rotor inertia J_rotor·N² of the joint's servo, kg·m².
    """

    vector: tuple[float, float]
    mass: float
    com: tuple[float, float]
    inertia: float
    inertia_r: float | None = None
    inertia_z: float | None = None
    armature: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "vector", _pair("vector", self.vector))
        object.__setattr__(self, "com", _pair("com", self.com))
        object.__setattr__(self, "mass", _real("mass", self.mass, positive=True))
        object.__setattr__(self, "inertia", _real("inertia", self.inertia, nonnegative=True))
        for name in ("inertia_r", "inertia_z"):
            value = getattr(self, name)
            object.__setattr__(self, name, self.inertia if value is None
                               else _real(name, value, nonnegative=True))
        object.__setattr__(self, "armature", _real("armature", self.armature,
                                                   nonnegative=True))

    @property
    def principal(self) -> tuple[float, float, float]:
        """(I_xx, I_yy, I_zz) at the centre of mass in the yawed frame at zero."""
        assert self.inertia_r is not None and self.inertia_z is not None
        return self.inertia_r, self.inertia, self.inertia_z


@dataclass(frozen=True)
class Yaw:
    """The base yaw joint and the body it turns (before the first chain joint).

    Parameters
    ----------
    mass : float
        kg of the yaw body (≥ 0).
    com : (r, z)
        Its centre of mass in the yaw frame at yaw 0, m.
    inertia_z : float
        About the vertical axis through that centre of mass, kg·m².
    armature : float
        Reflected rotor inertia J_rotor·N² of the yaw servo, kg·m².
    """

    mass: float = 0.0
    com: tuple[float, float] = (0.0, 0.0)
    inertia_z: float = 0.0
    armature: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", _real("yaw.mass", self.mass, nonnegative=True))
        object.__setattr__(self, "com", _pair("yaw.com", self.com))
        object.__setattr__(self, "inertia_z", _real("yaw.inertia_z", self.inertia_z,
                                                    nonnegative=True))
        object.__setattr__(self, "armature", _real("yaw.armature", self.armature,
                                                   nonnegative=True))


@dataclass(frozen=True)
class RigidChain:
    """A serial arm as rigid bodies: optional base yaw, then a planar chain (module docstring).

    Joint order everywhere (q, τ, limits): the yaw first when there is one, then the chain's
    joints from the shoulder out.

    Parameters
    ----------
    links : tuple of Link
        The planar chain, shoulder first (at least one).
    yaw : Yaw or None
        The base yaw joint, or None for a chain fixed in its plane.
    shoulder : (r, z)
        The first chain joint in the yaw frame, m (the OM-X: (0, 0.0765)).
    gravity : (g_r, g_z)
        Gravity in the chain's plane, m/s² (a vertical arm: (0, −9.81), :data:`GRAVITY_DOWN`;
        a horizontal planar arm: (0, 0) or any in-plane vector). With a yaw joint the
        gravity must be vertical (g_r = 0).
    sense : "cw" or "ccw"
        Which way a positive chain angle turns in the (r, z) plane.
    """

    links: tuple[Link, ...]
    yaw: Yaw | None = None
    shoulder: tuple[float, float] = (0.0, 0.0)
    gravity: tuple[float, float] = (0.0, 0.0)
    sense: Sense = "ccw"

    def __post_init__(self) -> None:
        links = tuple(self.links)
        if not links or not all(isinstance(link, Link) for link in links):
            raise InputError(f"links must be a non-empty tuple of Link, got "
                             f"{_checks.show(self.links)}", field="links", value=self.links)
        object.__setattr__(self, "links", links)
        if self.yaw is not None and not isinstance(self.yaw, Yaw):
            raise InputError(f"yaw must be a Yaw or None, got {_checks.show(self.yaw)}",
                             field="yaw", value=self.yaw)
        object.__setattr__(self, "shoulder", _pair("shoulder", self.shoulder))
        gravity = _pair("gravity", self.gravity)
        if self.yaw is not None and gravity[0] != 0.0:
            raise InputError(f"a chain with a yaw joint needs vertical gravity (g_r = 0), "
                             f"got {gravity!r}", field="gravity", value=self.gravity)
        object.__setattr__(self, "gravity", gravity)
        _checks.one_of("sense", self.sense, ("cw", "ccw"))

    @property
    def dof(self) -> int:
        """Number of joints (the yaw included)."""
        return len(self.links) + (self.yaw is not None)

    @property
    def sign(self) -> float:
        """+1 when positive chain angles turn CCW in (r, z), −1 for clockwise."""
        return 1.0 if self.sense == "ccw" else -1.0

    @property
    def armature(self) -> tuple[float, ...]:
        """Each joint's reflected rotor inertia, in joint order."""
        chain = tuple(link.armature for link in self.links)
        return chain if self.yaw is None else (self.yaw.armature, *chain)

    @property
    def reach(self) -> float:
        """Σ |link vector|: the tool point's largest distance from the shoulder, m."""
        return sum(math.hypot(*link.vector) for link in self.links)


__all__ = ["GRAVITY_DOWN", "STANDARD_GRAVITY", "Link", "RigidChain", "Sense", "Yaw"]
