"""The validated arm: frozen dataclasses (SI inside); the servo models robodcn knows are
:mod:`robodcn.servo_models`'s records (re-exported here)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn import kinematics
from robodcn.config._zones import Workspace
from robodcn.servo_models import PROFILE_ACCELERATION_MAX

#: Link lengths accepted (m): a Dynamixel arm, from a millimetre to ten metres.
LINK_RANGE = (1e-3, 10.0)
#: Largest jerk limit accepted (rad/s³): the largest acceleration reached within 1 ms.
MAX_JERK = PROFILE_ACCELERATION_MAX / 1e-3
#: Baud rates an X-series servo can be set to (Baud Rate register, address 8).
BAUD_RATES = (9_600, 57_600, 115_200, 1_000_000, 2_000_000, 3_000_000, 4_000_000, 4_500_000)
ELBOWS = ("up", "down")
#: The plane the chain moves in: a planar arm's is horizontal unless said, a yawed arm's
#: vertical.
PLANES = ("horizontal", "vertical")
#: Stream rates the planner accepts (Hz).
RATE_RANGE = (1.0, 1000.0)
#: Highest Dynamixel id a servo may carry (254 is broadcast, 253 reserved).
MAX_SERVO_ID = 252
#: Default in-position tolerance of a joint, servo ticks (0.26° on a 4096-tick servo): a few
#: ticks, the servo's own resolution and a P loop's rest dead band.
IN_POSITION_TICKS = 3
#: Largest ``in_position`` accepted, rad (10°): beyond it "in position" would mean nothing.
IN_POSITION_MAX = math.radians(10.0)
#: Pose keys of a planar arm (x, y, θ) and of a yawed arm (x, y, z, pitch), in order.
PLANAR_POSE = ("x", "y", "theta")
YAWED_POSE = ("x", "y", "z", "pitch")


@dataclass(frozen=True)
class ServoSpec:
    """One Dynamixel servo: ``tick = zero_offset + direction·angle·ticks_per_turn/2π``."""

    id: int
    model: str
    ticks_per_turn: int = 4096
    zero_offset: int = 2048
    direction: int = 1
    min_tick: int = 0
    max_tick: int = 4095

    def to_dict(self) -> dict[str, Any]:
        """The ``[joints.servo]`` keys of this servo."""
        return {"id": self.id, "model": self.model, "ticks_per_turn": self.ticks_per_turn,
                "zero_offset": self.zero_offset, "direction": self.direction,
                "min_tick": self.min_tick, "max_tick": self.max_tick}


@dataclass(frozen=True)
class JointSpec:
    """A revolute joint: position limits (rad), velocity (rad/s), acceleration (rad/s²), an
    optional jerk limit (rad/s³; None: no jerk limit) and torque limit (N·m; None: none)."""

    name: str
    min_angle: float
    max_angle: float
    max_velocity: float
    max_acceleration: float
    servo: ServoSpec
    max_jerk: float | None = None
    #: Collision-stop current threshold, A (``collision_current_a``); None: derived from the
    #: plan (:func:`robodcn.stream.collision.thresholds`).
    collision_current: float | None = None
    #: Largest torque the timing may ask of the joint, N·m (``max_torque_nm``); None: none.
    max_torque: float | None = None
    #: How far the arm may rest from a move's goal and still be in position, rad
    #: (``in_position`` | ``in_position_deg``); None: :data:`IN_POSITION_TICKS` ticks.
    in_position: float | None = None

    @property
    def in_position_tolerance(self) -> float:
        """The in-position tolerance, rad: ``in_position``, else :data:`IN_POSITION_TICKS`
        ticks (2π·ticks / ticks_per_turn)."""
        if self.in_position is not None:
            return self.in_position
        return IN_POSITION_TICKS * 2.0 * math.pi / self.servo.ticks_per_turn


@dataclass(frozen=True)
class BusSpec:
    """The serial bus: port path, baud rate, protocol version and stream rate (Hz)."""

    port: str
    baud: int = 1_000_000
    protocol: float = 2.0
    rate_hz: float = 100.0


@dataclass(frozen=True)
class GripperSpec:
    """A gripper driven by one servo that is not a joint of the chain (``[gripper]``).

    ``open_angle`` / ``closed_angle`` are the servo's angles (rad, tick zero_offset = 0) at
    which the jaws are ``open_width`` / ``closed_width`` apart (m); widths in between map
    linearly. Closing uses current-based position mode with ``grip_current`` (A) as the goal
    current, below the servo's limit, so squeezing an object does not overload it.
    """

    servo: ServoSpec
    open_angle: float
    closed_angle: float
    open_width: float
    closed_width: float
    grip_current: float

    def angle_of_width(self, width: float) -> float:
        """Servo angle (rad) for a jaw width (m), on the line through (closed, open)."""
        t = (width - self.closed_width) / (self.open_width - self.closed_width)
        return self.closed_angle + t * (self.open_angle - self.closed_angle)

    def width_of_angle(self, angle: float) -> float:
        """Jaw width (m) at a servo angle (rad): the inverse of :meth:`angle_of_width`."""
        t = (angle - self.closed_angle) / (self.open_angle - self.closed_angle)
        return self.closed_width + t * (self.open_width - self.closed_width)

    def to_dict(self) -> dict[str, Any]:
        """The ``[gripper]`` table in SI keys."""
        return {**self.servo.to_dict(), "open": self.open_angle, "closed": self.closed_angle,
                "open_width_m": self.open_width, "closed_width_m": self.closed_width,
                "grip_current_a": self.grip_current}


@dataclass(frozen=True)
class MassProperties:
    """The ``[dynamics]`` numbers, typed (SI); None where the file leaves them to defaults.

    gravity : the gravity vector in the chain's plane, m/s²: a planar arm's (gx, gy), a
        yawed arm's (0, −g) in (r, z) (``gravity_m_s2`` = g along −z)
    link_masses : kg per chain link (its next servo included)
    link_com : per chain link the centre of mass as the vector (r, z) from its joint, in
        the link's frame at zero (a planar arm's scalar c along the link is (c, 0))
    link_inertias : kg·m² per chain link, about the joint-axis direction at the COM
    yaw_body_mass, yaw_body_com, yaw_body_inertia : the body turning with a base yaw: kg,
        (r, z) m, kg·m² about the vertical through its COM
    payload_kg : the default point mass at the tool point
    rotor_inertia : per joint (the arm's joint order) the servo's reflected rotor inertia
        J_rotor·N² at the output shaft, kg·m²
    """

    gravity: tuple[float, float] = (0.0, 0.0)
    link_masses: tuple[float, ...] | None = None
    link_com: tuple[tuple[float, float], ...] | None = None
    link_inertias: tuple[float, ...] | None = None
    yaw_body_mass: float | None = None
    yaw_body_com: tuple[float, float] | None = None
    yaw_body_inertia: float | None = None
    payload_kg: float = 0.0
    rotor_inertia: tuple[float, ...] | None = None

    @property
    def gravity_m_s2(self) -> float:
        """|g| (m/s²): 0 for an arm lying in a horizontal plane."""
        return math.hypot(*self.gravity)


@dataclass(frozen=True)
class ToolSpec:
    """The ``[tool]`` table, SI: the tool point's default limits and the largest a request
    may ask for (None: not set).

    speed : default ``tool_speed`` (m/s); angular_speed : default ``tool_angular_speed``
        (rad/s: θ's rate, the omx's pitch and yaw rates); acceleration : default
        ``tool_acceleration`` (m/s², along the path); max_speed, max_angular_speed,
        max_acceleration : the ceilings a request (or a default) may not pass.
    """

    speed: float | None = None
    angular_speed: float | None = None
    acceleration: float | None = None
    max_speed: float | None = None
    max_angular_speed: float | None = None
    max_acceleration: float | None = None

    def to_dict(self) -> dict[str, float]:
        """The ``[tool]`` table in SI keys (the keys that are set)."""
        return {k: v for k, v in vars(self).items() if v is not None}


@dataclass(frozen=True)
class Arm:
    """A serial arm: a planar chain of 2 (position only) or 3 (full pose) revolute joints,
    optionally turned about the vertical by a base yaw joint (joint 0).

    Planar arm: ``links`` are the link lengths in metres from base to tool; ``home`` is a
    pose (x, y, θ); ``elbow`` is the preferred IK branch ("up": elbow angle q2 ≤ 0, "down":
    q2 ≥ 0, see :mod:`robodcn.kinematics`). Yawed arm (``base_yaw``): the chain moves in a
    vertical plane, its links are the (r, z) vectors ``link_vectors`` (``links`` holds their
    lengths), the first chain joint sits ``shoulder_height`` above the base on the yaw axis,
    poses are (x, y, z, pitch) and the angles are the servos' (ROBOTIS's conventions, see
    :mod:`robodcn.kinematics._yawed`). ``rest`` is an optional pose to lower to before
    torque goes off; ``source`` is the file the arm came from.
    """

    name: str
    links: tuple[float, ...]
    joints: tuple[JointSpec, ...]
    home: tuple[float, ...]
    elbow: str
    bus: BusSpec
    source: str
    #: The optional ``[dynamics]`` table as written (SI keys; see :class:`MassProperties`
    #: for the typed numbers); read by the servo simulator and the current prediction.
    dynamics: dict[str, Any] = field(default_factory=dict)
    base_yaw: bool = False
    plane: str = "horizontal"
    shoulder_height: float = 0.0
    link_vectors: tuple[tuple[float, float], ...] | None = None
    rest: tuple[float, ...] | None = None
    gripper: GripperSpec | None = None
    mass_properties: MassProperties = field(default_factory=MassProperties)
    #: The ``[tool]`` table: default tool-point limits and their ceilings.
    tool: ToolSpec = field(default_factory=ToolSpec)
    #: The keep-out zones (``[workspace]``; :mod:`robodcn.config._workspace`): none unless
    #: loaded from a file (whose defaults give a yawed arm a floor and a base cylinder).
    workspace: Workspace = field(default_factory=Workspace)

    @property
    def dof(self) -> int:
        """Number of joints (the yaw included)."""
        return len(self.joints)

    @property
    def yawed(self) -> bool:
        """Whether joint 0 is a base yaw turning the chain's plane (poses x, y, z, pitch)."""
        return self.base_yaw

    @property
    def pose_keys(self) -> tuple[str, ...]:
        """Names of a pose's numbers: ("x", "y", "theta") or ("x", "y", "z", "pitch")."""
        return YAWED_POSE if self.base_yaw else PLANAR_POSE

    @property
    def chain_links(self) -> NDArray[np.float64]:
        """The chain's links as (r, z) vectors at zero, (k, 2) m; (l, 0) for a planar arm."""
        if self.link_vectors is not None:
            return np.array(self.link_vectors, dtype=np.float64)
        return np.column_stack([self.links, np.zeros(len(self.links))])

    @property
    def chain(self) -> kinematics.Chain | None:
        """The yaw and chain for :func:`robodcn.kinematics.fk_yawed` & co.; None if planar."""
        if not self.base_yaw:
            return None
        return kinematics.Chain(tuple(map(tuple, self.chain_links.tolist())),
                                self.shoulder_height)

    @property
    def chain_joints(self) -> tuple[JointSpec, ...]:
        """The joints of the planar chain (all but the yaw of a yawed arm)."""
        return self.joints[1:] if self.base_yaw else self.joints

    @property
    def payload_kg(self) -> float:
        """The default payload (kg) at the tool point (``[dynamics] payload_kg``)."""
        return self.mass_properties.payload_kg

    @property
    def max_torques(self) -> tuple[float | None, ...]:
        """Per joint ``max_torque_nm`` (N·m), None where a joint has none."""
        return tuple(j.max_torque for j in self.joints)

    @property
    def servo_ids(self) -> tuple[int, ...]:
        """Servo ids in joint order."""
        return tuple(j.servo.id for j in self.joints)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Joint names in joint order."""
        return tuple(j.name for j in self.joints)

    @property
    def servos(self) -> tuple[ServoSpec, ...]:
        """Servo specs in joint order."""
        return tuple(j.servo for j in self.joints)

    def _pose_table(self, pose: tuple[float, ...]) -> dict[str, float]:
        return dict(zip(self.pose_keys, pose, strict=True))

    def to_dict(self) -> dict[str, Any]:
        """A plain dict in SI keys that :func:`arm_from_dict` turns back into this arm."""
        arm: dict[str, Any] = {"name": self.name}
        if self.base_yaw:
            arm.update(base_yaw=True, plane=self.plane, shoulder_height=self.shoulder_height,
                       links=[list(v) for v in self.chain_links.tolist()])
        else:
            arm["links"] = list(self.links)
            if self.plane != "horizontal":
                arm["plane"] = self.plane
        arm["elbow"] = self.elbow
        arm["home"] = self._pose_table(self.home)
        if self.rest is not None:
            arm["rest"] = self._pose_table(self.rest)
        return {
            "arm": arm,
            "bus": {"port": self.bus.port, "baud": self.bus.baud,
                    "protocol": self.bus.protocol, "rate_hz": self.bus.rate_hz},
            "joints": [
                {"name": j.name, "min": j.min_angle, "max": j.max_angle,
                 "max_velocity": j.max_velocity, "max_acceleration": j.max_acceleration,
                 **({} if j.max_jerk is None else {"max_jerk": j.max_jerk}),
                 **({} if j.max_torque is None else {"max_torque_nm": j.max_torque}),
                 "servo": j.servo.to_dict(),
                 **({} if j.collision_current is None
                    else {"collision_current_a": j.collision_current}),
                 **({} if j.in_position is None else {"in_position": j.in_position})}
                for j in self.joints],
            **({"dynamics": dict(self.dynamics)} if self.dynamics else {}),
            **({"gripper": self.gripper.to_dict()} if self.gripper is not None else {}),
            **({"tool": self.tool.to_dict()} if self.tool.to_dict() else {}),
            "workspace": self.workspace.to_dict(planar=not self.base_yaw),
        }
