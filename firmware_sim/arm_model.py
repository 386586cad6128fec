"""An arm's mass properties and joint ↔ servo maps, read from its TOML file.

firmware_sim reads the arm file itself (``tomllib``): the other side of the wire never
depends on robodcn. It uses::

    [arm]
    links = [0.20, 0.15, 0.05]        # lengths along each link, m (a planar arm), or
    links = [[0.024, 0.128], ...]     # each link's vector (r, z) at zero, joint → next
    base_yaw = false                  # true: the first [[joints]] turns the chain's
                                      #   (vertical) plane about +z; then the chain's
                                      #   angles are clockwise-positive in (r, z) (ROBOTIS)
    shoulder_height = 0.0             # m, where the chain starts on the yaw axis
    [[joints]] ... [joints.servo] id, model, ticks_per_turn, zero_offset, direction
    [gripper] id, model, zero_offset, ...    # a servo that is not a joint (optional)
    [arm.rest] x, y, z, pitch_deg     # the resting pose (optional; :mod:`.arm_pose`)
    end_stops = true                  # [arm]: mechanical end stops on the chain's joints
                                      #   (default: when the arm is under gravity)
    end_stop_margin_deg = 3.0         # [arm]: each stop this far beyond [[joints]] min/max

An arm may also be named (``load_arm("omx")``, ``--arm omx``): :mod:`.arm_files`.

    [dynamics]                        # every key optional
    link_masses = [...]               # kg per link (default 0.10 each)
    link_com = [...]                  # per link from its joint: m along it, or [r, z] at zero
                                      #   (default half the link)
    link_inertias = [...]             # kg·m² about the centre of mass (default m·l²/12)
    link_inertias_r = [...]           # a yawed arm: kg·m² at the centre of mass about the
    link_inertias_z = [...]           #   radial and the vertical axis at zero (default 0:
                                      #   the links turn with the yaw as point masses)
    payload_kg = 0.0                  # point mass at the tool point
    gravity = [0.0, -9.81]            # m/s² in the arm's plane (or true), or
    gravity_m_s2 = 9.81               # along −z: in (r, z) of a vertical plane
    yaw_body_mass, yaw_body_com, yaw_body_inertia   # the body turning with the yaw
                                      #   (its inertia about the vertical through its
                                      #   centre of mass, + m·r² of that centre; default 0)
    rotor_inertia_kg_m2 = 0.0125      # the servo's J_rotor·N² (one, or one per joint);
                                      #   default the motor model's

The equations are in :mod:`firmware_sim.chain`.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from firmware_sim.arm_files import SEARCH_DIRS, find_arm, is_name, known_arms
from firmware_sim.arm_pose import joint_limits, rest_joints
from firmware_sim.chain import Chain, Vec

#: Default mass of a link, kg (a bracket with the next servo's share of a light arm).
DEFAULT_LINK_MASS_KG = 0.10
#: Inertia a gripper's servo carries, kg·m² at its output: jaws and their rack, ~30 g at
#: ~2 cm (an estimate; tiny beside the rotor's reflected 0.0125 kg·m²).
GRIPPER_INERTIA_KG_M2 = 1.2e-5
#: How far beyond a joint's configured limit its mechanical end stop sits, degrees.
END_STOP_MARGIN_DEG = 3.0
_DYNAMICS_KEYS = frozenset({"link_masses", "link_com", "link_inertias", "link_inertias_r",
                            "link_inertias_z", "payload_kg",
                            "gravity", "gravity_m_s2", "yaw_body_mass", "yaw_body_com",
                            "yaw_body_inertia", "rotor_inertia_kg_m2"})


class ArmConfigError(ValueError):
    """An arm file firmware_sim cannot use; the message names the key and the value."""


@dataclass(frozen=True)
class JointMap:
    """How a joint angle maps to its servo's position: tick = zero + direction·q·ticks/2π."""

    servo_id: int
    model: str = "xm430-w350"
    ticks_per_turn: int = 4096
    zero_offset: int = 2048
    direction: int = 1


@dataclass(frozen=True)
class ArmModel:
    """An arm's mass properties and its joint ↔ servo maps (SI units).

    Attributes
    ----------
    links : tuple of (float, float)
        Each chain link's vector at zero, m (a length l reads as (l, 0)).
    masses, inertias : tuple of float
        Per link: mass (kg), inertia about its centre of mass (kg·m²).
    com : tuple of (float, float)
        Per link: centre of mass at zero from its joint, m.
    payload : float
        Point mass at the tool point, kg.
    gravity : (float, float)
        In the chain's plane, m/s².
    joints : tuple of JointMap
        In joint order (the yaw first with ``base_yaw``).
    base_yaw : bool
        The first joint turns the chain's plane about the vertical.
    yaw_inertia : float
        The yaw body's inertia about the yaw axis, kg·m² (its own at its centre of mass
        plus m·r² of that centre).
    rotor_inertia : tuple of float or None
        Per joint the servo's reflected rotor inertia, kg·m² (None: the motor model's).
    gripper : JointMap or None
        A servo that is not a joint of the chain.
    shoulder_height : float
        The chain's first joint above the base, m.
    inertias_r, inertias_z : tuple of float or None
        Per link its moments at the centre of mass about the radial and the vertical axis
        at zero, kg·m² (a yawed arm; None: 0, only the point masses turn with the yaw).
    stops : tuple of (float, float) or None
        Per joint its mechanical end stops (low, high), rad, or None (free): the chain's
        joints under gravity, ``end_stop_margin_deg`` beyond their limits (the yaw has
        none); :class:`firmware_sim.dynamics.Plant` makes them inelastic.
    rest : tuple of float or None
        The ``[arm.rest]`` pose's joint angles, rad (:mod:`.arm_pose`): where an arm under
        gravity starts, lying on its support.
    """

    links: tuple[Vec, ...]
    masses: tuple[float, ...]
    com: tuple[Vec, ...]
    inertias: tuple[float, ...]
    payload: float
    gravity: Vec
    joints: tuple[JointMap, ...]
    base_yaw: bool = False
    yaw_inertia: float = 0.0
    rotor_inertia: tuple[float, ...] | None = None
    gripper: JointMap | None = None
    shoulder_height: float = 0.0
    inertias_r: tuple[float, ...] | None = None
    inertias_z: tuple[float, ...] | None = None
    stops: tuple[tuple[float, float] | None, ...] | None = None
    rest: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        chain = Chain(self.links, self.masses, self.com, self.inertias, self.payload,
                      self.gravity, sign=-1 if self.base_yaw else 1,
                      yaw_inertia=self.yaw_inertia if self.base_yaw else None,
                      origin=(0.0, self.shoulder_height), inertias_r=self.inertias_r,
                      inertias_z=self.inertias_z)
        object.__setattr__(self, "chain", chain)

    @property
    def dof(self) -> int:
        """Joints (the yaw included)."""
        return len(self.joints)

    def dynamics(self, q: Sequence[float], qd: Sequence[float]
                 ) -> tuple[list[list[float]], list[float]]:
        """(M(q), b(q, q̇)): joint-space mass matrix and bias torques (:mod:`.chain`)."""
        return self.chain.dynamics(q, qd)            # type: ignore[attr-defined]

    def body_positions(self, q: Sequence[float]) -> list[tuple[float, float]]:
        """Each body's centre in the chain's plane (links' centres of mass, then the
        payload), m."""
        return [(p.real, p.imag) for p in self.chain.plane_positions(q)]  # type: ignore[attr-defined]

    def energy(self, q: Sequence[float], qd: Sequence[float]) -> float:
        """Kinetic plus potential energy, J (for conservation checks)."""
        return self.chain.energy(q, qd)              # type: ignore[attr-defined]


# ---- reading the file ---------------------------------------------------------------------
def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ArmConfigError(f"{where} = {value!r}: expected a finite number")
    return float(value)


def _vector(value: Any, where: str) -> Vec:
    if not isinstance(value, list) or len(value) != 2:
        raise ArmConfigError(f"{where} = {value!r}: expected a vector [r, z] in metres")
    return _number(value[0], f"{where}[0]"), _number(value[1], f"{where}[1]")


def _links(raw: Any) -> tuple[Vec, ...]:
    if not isinstance(raw, list) or not 2 <= len(raw) <= 6:
        raise ArmConfigError(f"arm.links = {raw!r}: expected 2 to 6 lengths (m) or [r, z] "
                             "vectors")
    links = tuple(_vector(v, f"arm.links[{i}]") if isinstance(v, list)
                  else (_number(v, f"arm.links[{i}]"), 0.0) for i, v in enumerate(raw))
    for i, (v, r) in enumerate(zip(links, raw, strict=True)):
        if (not isinstance(r, list) and v[0] <= 0) or math.hypot(*v) == 0:
            raise ArmConfigError(f"arm.links[{i}] = {r!r}: a link must have a positive length")
    return links


def _per_link(dyn: Mapping[str, Any], key: str, n: int, default: list[float],
              positive: bool) -> tuple[float, ...]:
    if key not in dyn:
        return tuple(default)
    raw = dyn[key]
    if not isinstance(raw, list) or len(raw) != n:
        raise ArmConfigError(f"dynamics.{key} = {raw!r}: expected a list of {n} numbers "
                             "(one per link)")
    values = tuple(_number(v, f"dynamics.{key}[{i}]") for i, v in enumerate(raw))
    for i, v in enumerate(values):
        if v < 0 or (positive and v == 0):
            raise ArmConfigError(f"dynamics.{key}[{i}] = {v!r}: must be "
                                 f"{'positive' if positive else 'non-negative'}")
    return values


def _com(dyn: Mapping[str, Any], links: tuple[Vec, ...]) -> tuple[Vec, ...]:
    """Per link the centre of mass vector: given as [r, z], or m along the link."""
    if "link_com" not in dyn:
        return tuple((v[0] / 2, v[1] / 2) for v in links)
    raw = dyn["link_com"]
    if not isinstance(raw, list) or len(raw) != len(links):
        raise ArmConfigError(f"dynamics.link_com = {raw!r}: expected {len(links)} entries "
                             "(one per link: m along it, or [r, z])")
    out = []
    for i, (c, v) in enumerate(zip(raw, links, strict=True)):
        if isinstance(c, list):
            out.append(_vector(c, f"dynamics.link_com[{i}]"))
            continue
        along = _number(c, f"dynamics.link_com[{i}]")
        if along < 0:
            raise ArmConfigError(f"dynamics.link_com[{i}] = {along!r}: must be non-negative")
        length = math.hypot(*v)
        out.append((along * v[0] / length, along * v[1] / length))
    return tuple(out)


def _gravity(dyn: Mapping[str, Any], vertical: bool) -> Vec:
    if "gravity" in dyn and "gravity_m_s2" in dyn:
        raise ArmConfigError("dynamics: give gravity or gravity_m_s2, not both")
    if "gravity_m_s2" in dyn:
        g = _number(dyn["gravity_m_s2"], "dynamics.gravity_m_s2")
        if g < 0:
            raise ArmConfigError(f"dynamics.gravity_m_s2 = {g!r}: must be non-negative "
                                 "(it acts along −z)")
        return (0.0, -g) if vertical else (0.0, 0.0)   # a horizontal plane feels none
    raw = dyn.get("gravity", [0.0, 0.0])
    if raw is True:
        raw = [0.0, -9.81]
    elif raw is False:
        raw = [0.0, 0.0]
    if not isinstance(raw, list) or len(raw) != 2:
        raise ArmConfigError(f"dynamics.gravity = {raw!r}: expected [gx, gy] in m/s² "
                             "(or true for [0, -9.81])")
    return _number(raw[0], "dynamics.gravity[0]"), _number(raw[1], "dynamics.gravity[1]")


def _non_negative(dyn: Mapping[str, Any], key: str) -> float:
    value = _number(dyn[key], f"dynamics.{key}") if key in dyn else 0.0
    if value < 0:
        raise ArmConfigError(f"dynamics.{key} = {value!r}: must be non-negative")
    return value


def _rotor(dyn: Mapping[str, Any], dof: int) -> tuple[float, ...] | None:
    if "rotor_inertia_kg_m2" not in dyn:
        return None
    raw = dyn["rotor_inertia_kg_m2"]
    if isinstance(raw, list):
        if len(raw) != dof:
            raise ArmConfigError(f"dynamics.rotor_inertia_kg_m2 = {raw!r}: expected one "
                                 f"number or {dof} (one per joint)")
        values = tuple(_number(v, f"dynamics.rotor_inertia_kg_m2[{i}]")
                       for i, v in enumerate(raw))
    else:
        values = (_number(raw, "dynamics.rotor_inertia_kg_m2"),) * dof
    if any(v < 0 for v in values):
        raise ArmConfigError(f"dynamics.rotor_inertia_kg_m2 = {raw!r}: must be non-negative")
    return values


def _servo_map(servo: Any, where: str) -> JointMap:
    if not isinstance(servo, Mapping) or "id" not in servo:
        raise ArmConfigError(f"{where}.id is missing")
    ticks = int(servo.get("ticks_per_turn", 4096))
    jm = JointMap(int(servo["id"]), str(servo.get("model", "xm430-w350")), ticks,
                  int(servo.get("zero_offset", ticks // 2)), int(servo.get("direction", 1)))
    if jm.direction not in (1, -1) or jm.ticks_per_turn <= 0:
        raise ArmConfigError(f"{where}: direction must be ±1 and ticks_per_turn positive, "
                             f"got {jm.direction}, {jm.ticks_per_turn}")
    return jm


def arm_from_dict(data: Mapping[str, Any]) -> ArmModel:
    """An :class:`ArmModel` from a parsed arm TOML document (keys in the module notes)."""
    try:
        arm = data["arm"]
        links_raw = arm["links"]
        joints_raw = data["joints"]
    except (KeyError, TypeError):
        raise ArmConfigError("arm file needs [arm] links and [[joints]] tables") from None
    links = _links(links_raw)
    n = len(links)
    base_yaw = arm.get("base_yaw", False)
    if not isinstance(base_yaw, bool):
        raise ArmConfigError(f"arm.base_yaw = {base_yaw!r}: expected true or false")
    plane = arm.get("plane", "vertical" if base_yaw else "horizontal")
    if plane not in ("horizontal", "vertical") or (base_yaw and plane != "vertical"):
        raise ArmConfigError(f"arm.plane = {plane!r}: expected 'horizontal' or 'vertical' "
                             "(a base yaw turns a vertical plane)")
    height = _number(arm.get("shoulder_height", 0.0), "arm.shoulder_height")
    dof = n + base_yaw
    if not isinstance(joints_raw, list) or len(joints_raw) != dof:
        raise ArmConfigError(f"joints: expected {dof} [[joints]] tables, one per "
                             f"{'joint (the yaw, then one per link)' if base_yaw else 'link'}")
    joints = tuple(_servo_map(j.get("servo") if isinstance(j, Mapping) else None,
                              f"joints[{i}].servo") for i, j in enumerate(joints_raw))
    gripper = _servo_map(data["gripper"], "gripper") if "gripper" in data else None
    ids = [jm.servo_id for jm in joints] + ([gripper.servo_id] if gripper else [])
    if len(set(ids)) != len(ids):
        raise ArmConfigError(f"joints[].servo.id and gripper.id = {ids}: ids must be unique")
    dyn = data.get("dynamics", {})
    if not isinstance(dyn, Mapping):
        raise ArmConfigError(f"dynamics = {dyn!r}: expected a table")
    unknown = sorted(set(dyn) - _DYNAMICS_KEYS)
    if unknown:
        raise ArmConfigError(f"dynamics: unknown key(s) {', '.join(unknown)}; known: "
                             f"{', '.join(sorted(_DYNAMICS_KEYS))}")
    masses = _per_link(dyn, "link_masses", n, [DEFAULT_LINK_MASS_KG] * n, positive=True)
    inertias = _per_link(dyn, "link_inertias", n,
                         [m * (v[0] ** 2 + v[1] ** 2) / 12 for m, v in zip(masses, links,
                                                                             strict=True)],
                         positive=False)
    yaw_com = _vector(dyn["yaw_body_com"], "dynamics.yaw_body_com") \
        if "yaw_body_com" in dyn else (0.0, 0.0)
    # the yaw body about the yaw axis: its own inertia + m·r² of its centre (parallel axes)
    yaw_inertia = (_non_negative(dyn, "yaw_body_inertia")
                   + _non_negative(dyn, "yaw_body_mass") * yaw_com[0] ** 2)
    about_r, about_z = (None if key not in dyn else
                        _per_link(dyn, key, n, [0.0] * n, positive=False)
                        for key in ("link_inertias_r", "link_inertias_z"))
    gravity = _gravity(dyn, plane == "vertical")
    stops = _stops(arm, joints_raw, base_yaw, gravity)
    rest = None
    if isinstance(arm.get("rest"), Mapping) and gravity != (0.0, 0.0):
        rest = rest_joints(arm["rest"], links, base_yaw, (0.0, height),
                           str(arm.get("elbow", "up")))
        if rest is None:
            raise ArmConfigError(f"arm.rest = {dict(arm['rest'])!r}: out of reach of the "
                                 "chain (or the chain is not of 2 or 3 links)")
    return ArmModel(links, masses, _com(dyn, links), inertias,
                    _non_negative(dyn, "payload_kg"), gravity,
                    joints, base_yaw=base_yaw, yaw_inertia=yaw_inertia,
                    rotor_inertia=_rotor(dyn, dof), gripper=gripper, shoulder_height=height,
                    inertias_r=about_r, inertias_z=about_z, stops=stops, rest=rest)


def _stops(arm: Mapping[str, Any], joints_raw: Sequence[Any], base_yaw: bool,
           gravity: Vec) -> tuple[tuple[float, float] | None, ...] | None:
    """Per joint its end stops (the class notes), None for an arm without them."""
    on = arm.get("end_stops", gravity != (0.0, 0.0))
    if not isinstance(on, bool):
        raise ArmConfigError(f"arm.end_stops = {on!r}: expected true or false")
    margin = math.radians(_number(arm.get("end_stop_margin_deg", END_STOP_MARGIN_DEG),
                                  "arm.end_stop_margin_deg"))
    if margin < 0:
        raise ArmConfigError(f"arm.end_stop_margin_deg = {math.degrees(margin)!r}: must be "
                             "non-negative")
    if not on:
        return None
    limits = joint_limits(joints_raw)
    return tuple(None if lim is None or (base_yaw and j == 0) else
                 (lim[0] - margin, lim[1] + margin) for j, lim in enumerate(limits))


def load_arm(source: str | Path | Mapping[str, Any]) -> ArmModel:
    """An :class:`ArmModel` from a TOML path, an arm name (``"omx"``: looked up by
    :func:`firmware_sim.arm_files.find_arm`) or an already parsed document."""
    if isinstance(source, Mapping):
        return arm_from_dict(source)
    path = Path(source)
    if not path.exists() and is_name(source):
        found = find_arm(str(source))
        if found is None:
            raise ArmConfigError(
                f"arm {str(source)!r}: no such file, and no arm of that name in "
                f"{' or '.join(str(d) for d in SEARCH_DIRS)} (known: "
                f"{', '.join(known_arms()) or 'none'})")
        path = found
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ArmConfigError(f"cannot read arm file {str(path)!r}: {exc.strerror}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ArmConfigError(f"arm file {str(path)!r} is not valid TOML: {exc}") from None
    return arm_from_dict(data)
