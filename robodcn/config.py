"""Arm and bus configuration: frozen dataclasses loaded from TOML (stdlib ``tomllib``).

Inside robodcn everything is SI: metres, radians, rad/s, rad/s². A TOML file may give
angles in degrees instead, through keys with an explicit unit suffix (``min_deg``,
``max_velocity_deg_s``, ``theta_deg`` ...); a quantity given twice (``min`` and ``min_deg``)
is an error. Unknown keys, missing keys and impossible values raise
:class:`robodcn.errors.ConfigError` naming the file, the dotted key
(``joints[1].servo.id``) and the value.

File layout (see ``configs/arm3r.toml``)::

    [arm]      name, links = [l1, l2(, l3)] metres, elbow = "up" | "down"
    [arm.home] x, y (metres), theta | theta_deg
    [bus]      port, baud, protocol = 2.0, rate_hz
    [[joints]] name, min | min_deg, max | max_deg, max_velocity | max_velocity_deg_s,
               max_acceleration | max_acceleration_deg_s2,
               optional max_jerk | max_jerk_deg_s3 (absent: no jerk limit)
    [joints.servo] id, model, ticks_per_turn, zero_offset, direction, min_tick, max_tick

Two joints make a position-only arm (θ free), three joints a full-pose arm.

Values are checked against the servo model (:data:`SERVO_SPECS`: ticks a turn, no-load
speed, largest profile acceleration) and physical sense (link lengths in
:data:`LINK_RANGE`, joint limits within one turn); messages stay one short line.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robodcn.errors import ConfigError


@dataclass(frozen=True)
class ServoModel:
    """What one Dynamixel model can do (ROBOTIS e-manual; shared/dynamixel-notes.md §2).

    ticks_per_turn : position resolution (pulse/rev) in position mode (Operating Mode 3)
    max_velocity : no-load speed at the highest rated voltage (rad/s): no joint driven by
        this servo can be faster
    max_acceleration : the largest Profile Acceleration the servo can express
        (32 767 × 214.577 rev/min², rad/s²)
    """

    ticks_per_turn: int
    max_velocity: float
    max_acceleration: float


_RPM = 2.0 * math.pi / 60.0
_PROFILE_ACCELERATION_MAX = 32_767 * 214.577 * 2.0 * math.pi / 3600.0  # ≈ 12 272 rad/s²
#: Dynamixel models robodcn knows (X series, Protocol 2.0): name → capabilities.
SERVO_SPECS = {
    # XM430-W350: 57 rev/min no-load at 14.8 V (46 at 12 V).
    "xm430-w350": ServoModel(4096, 57 * _RPM, _PROFILE_ACCELERATION_MAX),
    # XL430-W250: 61 rev/min no-load at 12 V.
    "xl430-w250": ServoModel(4096, 61 * _RPM, _PROFILE_ACCELERATION_MAX),
}
SERVO_MODELS = tuple(SERVO_SPECS)
#: Link lengths accepted (m): a planar Dynamixel arm, from a millimetre to ten metres.
LINK_RANGE = (1e-3, 10.0)
#: Largest jerk limit accepted (rad/s³): the largest acceleration reached within 1 ms.
MAX_JERK = _PROFILE_ACCELERATION_MAX / 1e-3
#: Largest integer any key may hold (a 32-bit register; far past every real range).
_MAX_INT = 2**31 - 1
#: Baud rates an X-series servo can be set to (Baud Rate register, address 8).
BAUD_RATES = (9_600, 57_600, 115_200, 1_000_000, 2_000_000, 3_000_000, 4_000_000, 4_500_000)
ELBOWS = ("up", "down")
#: Stream rates the planner accepts (Hz).
RATE_RANGE = (1.0, 1000.0)
#: Highest Dynamixel id a servo may carry (254 is broadcast, 253 reserved).
MAX_SERVO_ID = 252


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


@dataclass(frozen=True)
class JointSpec:
    """A revolute joint: position limits (rad), velocity (rad/s), acceleration (rad/s²) and
    an optional jerk limit (rad/s³; None: no jerk limit)."""

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


@dataclass(frozen=True)
class BusSpec:
    """The serial bus: port path, baud rate, protocol version and stream rate (Hz)."""

    port: str
    baud: int = 1_000_000
    protocol: float = 2.0
    rate_hz: float = 100.0


@dataclass(frozen=True)
class Arm:
    """A planar serial arm of 2 (position only) or 3 (full pose) revolute joints.

    ``links`` are the link lengths in metres from base to tool; ``home`` is a pose
    (x, y, θ); ``elbow`` is the preferred IK branch ("up": elbow angle q2 ≤ 0, "down":
    q2 ≥ 0, see :mod:`robodcn.kinematics`); ``source`` is the file it came from.
    """

    name: str
    links: tuple[float, ...]
    joints: tuple[JointSpec, ...]
    home: tuple[float, float, float]
    elbow: str
    bus: BusSpec
    source: str
    #: The optional ``[dynamics]`` table as written (link_masses, link_com, link_inertias,
    #: payload_kg, gravity); read by the servo simulator and the current prediction.
    dynamics: dict[str, Any] = field(default_factory=dict)

    @property
    def dof(self) -> int:
        """Number of joints."""
        return len(self.joints)

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

    def to_dict(self) -> dict[str, Any]:
        """A plain dict in SI keys that :func:`arm_from_dict` turns back into this arm."""
        return {
            "arm": {"name": self.name, "links": list(self.links), "elbow": self.elbow,
                    "home": {"x": self.home[0], "y": self.home[1], "theta": self.home[2]}},
            "bus": {"port": self.bus.port, "baud": self.bus.baud,
                    "protocol": self.bus.protocol, "rate_hz": self.bus.rate_hz},
            "joints": [
                {"name": j.name, "min": j.min_angle, "max": j.max_angle,
                 "max_velocity": j.max_velocity, "max_acceleration": j.max_acceleration,
                 **({} if j.max_jerk is None else {"max_jerk": j.max_jerk}),
                 "servo": {"id": j.servo.id, "model": j.servo.model,
                           "ticks_per_turn": j.servo.ticks_per_turn,
                           "zero_offset": j.servo.zero_offset,
                           "direction": j.servo.direction, "min_tick": j.servo.min_tick,
                           "max_tick": j.servo.max_tick},
                 **({} if j.collision_current is None
                    else {"collision_current_a": j.collision_current})}
                for j in self.joints],
            **({"dynamics": dict(self.dynamics)} if self.dynamics else {}),
        }


# -- reading ---------------------------------------------------------------------------------

def _show(value: Any) -> str:
    """A short form of a config value for messages: never a whole table or a long number."""
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list) and any(isinstance(v, dict | list) for v in value):
        return f"an array of {len(value)} entries"
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > _MAX_INT:
        return f"an integer of {len(str(abs(value)))} digits"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


class _Reader:
    """Typed access to one TOML table that names file and dotted key in every error."""

    def __init__(self, source: str, table: Any, prefix: str) -> None:
        self.source = source
        self.prefix = prefix
        if not isinstance(table, dict):
            raise ConfigError(f"{self.key_name('')!r} must be a table, got {_show(table)}",
                              file=source, key=prefix or "<top>", value=table)
        self.table = table

    def key_name(self, key: str) -> str:
        if not key:
            return self.prefix
        return f"{self.prefix}.{key}" if self.prefix else key

    def fail(self, key: str, message: str, value: Any) -> ConfigError:
        name = self.key_name(key)
        return ConfigError(f"key {name!r} = {_show(value)}: {message}", file=self.source,
                           key=name, value=value)

    def only(self, allowed: set[str]) -> None:
        for key in self.table:
            if key not in allowed:
                raise self.fail(key, f"unknown key (allowed: {', '.join(sorted(allowed))})",
                                self.table[key])

    def missing(self, key: str) -> ConfigError:
        name = self.key_name(key)
        return ConfigError(f"missing key {name!r}", file=self.source, key=name, value=None)

    def has(self, key: str) -> bool:
        return key in self.table

    def string(self, key: str, default: str | None = None,
               choices: tuple[str, ...] | None = None) -> str:
        if key not in self.table:
            if default is None:
                raise self.missing(key)
            return default
        value = self.table[key]
        if not isinstance(value, str) or not value:
            raise self.fail(key, "must be a non-empty string", value)
        if choices is not None and value not in choices:
            raise self.fail(key, f"must be one of {', '.join(choices)}", value)
        return value

    def integer(self, key: str, default: int | None = None) -> int:
        if key not in self.table:
            if default is None:
                raise self.missing(key)
            return default
        value = self.table[key]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(key, "must be an integer", value)
        if abs(value) > _MAX_INT:
            raise self.fail(key, "is far too large", value)
        return value

    def number(self, key: str, default: float | None = None) -> float:
        if key not in self.table:
            if default is None:
                raise self.missing(key)
            return default
        value = self.table[key]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, "must be a number", value)
        if isinstance(value, int) and abs(value) > _MAX_INT:
            raise self.fail(key, "is far too large", value)
        if not math.isfinite(value):
            raise self.fail(key, "must be finite", value)
        return float(value)

    def angle(self, key: str, deg_key: str, scale: float = math.pi / 180.0,
              default: float | None = None) -> float:
        """A quantity given in SI under ``key`` or in degrees under ``deg_key`` (not both)."""
        if key in self.table and deg_key in self.table:
            raise self.fail(deg_key, f"give either {self.key_name(key)!r} or "
                            f"{self.key_name(deg_key)!r}, not both", self.table[deg_key])
        if deg_key in self.table:
            return self.number(deg_key) * scale
        if key in self.table or default is not None:
            return self.number(key, default)
        raise ConfigError(f"missing key {self.key_name(key)!r} (or {self.key_name(deg_key)!r})",
                          file=self.source, key=self.key_name(key), value=None)

    def sub(self, key: str, default: Any = None) -> _Reader:
        if key not in self.table:
            if default is None:
                raise self.missing(key)
            return _Reader(self.source, default, self.key_name(key))
        return _Reader(self.source, self.table[key], self.key_name(key))


def _servo(r: _Reader) -> ServoSpec:
    r.only({"id", "model", "ticks_per_turn", "zero_offset", "direction", "min_tick", "max_tick"})
    servo_id = r.integer("id")
    if not 0 <= servo_id <= MAX_SERVO_ID:
        raise r.fail("id", f"servo id must be 0..{MAX_SERVO_ID}", servo_id)
    model = r.string("model", choices=SERVO_MODELS)
    spec = SERVO_SPECS[model]
    ticks = r.integer("ticks_per_turn", spec.ticks_per_turn)
    if ticks != spec.ticks_per_turn:
        raise r.fail("ticks_per_turn", f"a {model} has {spec.ticks_per_turn} ticks a turn",
                     ticks)
    direction = r.integer("direction", 1)
    if direction not in (1, -1):
        raise r.fail("direction", "must be +1 or -1", direction)
    min_tick = r.integer("min_tick", 0)
    max_tick = r.integer("max_tick", ticks - 1)
    # Position mode (Operating Mode 3) accepts goals 0..ticks_per_turn-1 only.
    for key, value in (("min_tick", min_tick), ("max_tick", max_tick)):
        if not 0 <= value <= ticks - 1:
            raise r.fail(key, f"must be within 0..{ticks - 1}", value)
    if min_tick >= max_tick:
        raise r.fail("max_tick", f"must be greater than min_tick = {min_tick}", max_tick)
    zero = r.integer("zero_offset", ticks // 2)
    if not min_tick <= zero <= max_tick:
        raise r.fail("zero_offset", f"must lie within min_tick..max_tick = "
                     f"{min_tick}..{max_tick}", zero)
    return ServoSpec(servo_id, model, ticks, zero, direction, min_tick, max_tick)


def _joint(r: _Reader) -> JointSpec:
    r.only({"name", "min", "min_deg", "max", "max_deg", "max_velocity", "max_velocity_deg_s",
            "max_acceleration", "max_acceleration_deg_s2", "max_jerk", "max_jerk_deg_s3",
            "servo", "collision_current_a"})
    name = r.string("name")
    servo = _servo(r.sub("servo"))
    model = SERVO_SPECS[servo.model]

    def key_of(si: str, deg: str) -> str:
        return deg if r.has(deg) else si

    def in_deg(si: str, deg: str, x: float, unit: str) -> str:
        """``x`` (SI) in the unit of the key the file used."""
        return f"{math.degrees(x):.6g} {unit}" if r.has(deg) else f"{x:.6g} {unit_si[unit]}"

    unit_si = {"°": "rad", "deg/s": "rad/s", "deg/s²": "rad/s²", "deg/s³": "rad/s³"}
    lo = r.angle("min", "min_deg")
    hi = r.angle("max", "max_deg")
    turn = 2.0 * math.pi
    for si, deg, x in (("min", "min_deg", lo), ("max", "max_deg", hi)):
        if abs(x) > turn:
            raise r.fail(key_of(si, deg), "a joint limit must be within one turn of zero "
                         f"({in_deg(si, deg, turn, '°')})", r.table[key_of(si, deg)])
    if lo >= hi:
        key = key_of("max", "max_deg")
        raise r.fail(key, f"joint upper limit must exceed the lower limit "
                     f"{in_deg('min', 'min_deg', lo, '°')}", r.table[key])
    if hi - lo > turn:
        key = key_of("max", "max_deg")
        raise r.fail(key, "the joint range must be at most one servo turn "
                     f"({in_deg('max', 'max_deg', turn, '°')})", r.table[key])
    vel = r.angle("max_velocity", "max_velocity_deg_s")
    acc = r.angle("max_acceleration", "max_acceleration_deg_s2")
    jerk = (r.angle("max_jerk", "max_jerk_deg_s3")
            if r.has("max_jerk") or r.has("max_jerk_deg_s3") else None)
    for si, deg, x, cap, unit, why in (
            ("max_velocity", "max_velocity_deg_s", vel, model.max_velocity, "deg/s",
             f"the {servo.model}'s no-load speed"),
            ("max_acceleration", "max_acceleration_deg_s2", acc, model.max_acceleration,
             "deg/s²", f"the {servo.model}'s largest profile acceleration"),
            ("max_jerk", "max_jerk_deg_s3", jerk, MAX_JERK, "deg/s³",
             "that acceleration reached in 1 ms")):
        if x is None:
            continue
        key = key_of(si, deg)
        if x <= 0.0:
            raise r.fail(key, "must be positive", r.table[key])
        if x > cap * (1.0 + 1e-9):
            raise r.fail(key, f"must be at most {in_deg(si, deg, cap, unit)} ({why})",
                         r.table[key])
    collision = r.number("collision_current_a") if r.has("collision_current_a") else None
    if collision is not None and not 0.0 < collision <= 100.0:
        raise r.fail("collision_current_a", "must be a current in amperes within 0..100",
                     collision)
    return JointSpec(name, lo, hi, vel, acc, servo, jerk, collision)


def _bus(r: _Reader) -> BusSpec:
    r.only({"port", "baud", "protocol", "rate_hz"})
    port = r.string("port")
    baud = r.integer("baud", 1_000_000)
    if baud not in BAUD_RATES:
        raise r.fail("baud", f"must be one of {', '.join(map(str, BAUD_RATES))}", baud)
    protocol = r.number("protocol", 2.0)
    if protocol != 2.0:
        raise r.fail("protocol", "robodcn speaks Dynamixel Protocol 2.0 only", protocol)
    rate = r.number("rate_hz", 100.0)
    if not RATE_RANGE[0] <= rate <= RATE_RANGE[1]:
        raise r.fail("rate_hz", f"must be within {RATE_RANGE[0]:g}..{RATE_RANGE[1]:g} Hz", rate)
    return BusSpec(port, baud, protocol, rate)


def arm_from_dict(data: Any, source: str = "<dict>") -> Arm:
    """Build and validate an :class:`Arm` from a parsed TOML document (or an equal dict).

    Raises
    ------
    ConfigError
        Naming ``source``, the dotted key and the value: unknown or missing keys, wrong
        types, non-positive lengths or limits, bad servo ids or tick ranges, duplicate
        names or ids, a home pose out of reach.
    """
    top = _Reader(source, data, "")
    top.only({"arm", "bus", "joints", "dynamics"})
    a = top.sub("arm")
    a.only({"name", "links", "elbow", "home"})
    name = a.string("name")
    links_raw = a.table.get("links")
    if links_raw is None:
        raise a.missing("links")
    if not isinstance(links_raw, list) or len(links_raw) not in (2, 3):
        raise a.fail("links", "must be a list of 2 or 3 link lengths in metres", links_raw)
    link_reader = _Reader(source, {f"links[{i}]": v for i, v in enumerate(links_raw)},
                          a.prefix)
    links = tuple(link_reader.number(f"links[{i}]") for i in range(len(links_raw)))
    for i, length in enumerate(links):
        if not LINK_RANGE[0] <= length <= LINK_RANGE[1]:
            raise a.fail(f"links[{i}]", f"a link length must be within "
                         f"{LINK_RANGE[0]:g}..{LINK_RANGE[1]:g} m", links_raw[i])
    elbow = a.string("elbow", "up", choices=ELBOWS)
    h = a.sub("home")
    h.only({"x", "y", "theta", "theta_deg"})
    home = (h.number("x"), h.number("y"), h.angle("theta", "theta_deg", default=0.0))

    bus = _bus(top.sub("bus"))

    joints_raw = top.table.get("joints")
    if joints_raw is None:
        raise top.missing("joints")
    if not isinstance(joints_raw, list):
        raise top.fail("joints", "must be an array of tables ([[joints]])", joints_raw)
    if len(joints_raw) != len(links):
        raise top.fail("joints", f"needs one joint per link ({len(links)}), got "
                       f"{len(joints_raw)}", joints_raw)
    joints = tuple(_joint(_Reader(source, j, f"joints[{i}]")) for i, j in enumerate(joints_raw))
    seen_names: dict[str, int] = {}
    seen_ids: dict[int, int] = {}
    for i, joint in enumerate(joints):
        if joint.name in seen_names:
            raise ConfigError(f"key 'joints[{i}].name' = {joint.name!r}: duplicate of "
                              f"joints[{seen_names[joint.name]}]", file=source,
                              key=f"joints[{i}].name", value=joint.name)
        if joint.servo.id in seen_ids:
            raise ConfigError(f"key 'joints[{i}].servo.id' = {joint.servo.id}: duplicate of "
                              f"joints[{seen_ids[joint.servo.id]}].servo.id", file=source,
                              key=f"joints[{i}].servo.id", value=joint.servo.id)
        seen_names[joint.name] = i
        seen_ids[joint.servo.id] = i

    arm = Arm(name, links, joints, home, elbow, bus, source,
              _dynamics(top.sub("dynamics", {}), len(links)))
    _check_home(arm)
    return arm


_DYNAMICS_PER_LINK = ("link_masses", "link_com", "link_inertias")


def _dynamics(r: _Reader, n: int) -> dict[str, Any]:
    """The ``[dynamics]`` table, checked: per-link lists of n numbers ≥ 0 (masses > 0),
    ``payload_kg`` ≥ 0, ``gravity`` [gx, gy] m/s² or true/false."""
    r.only({*_DYNAMICS_PER_LINK, "payload_kg", "gravity"})
    out: dict[str, Any] = {}
    for key in _DYNAMICS_PER_LINK:
        if not r.has(key):
            continue
        raw = r.table[key]
        if not isinstance(raw, list) or len(raw) != n:
            raise r.fail(key, f"must be a list of {n} numbers (one per link)", raw)
        values = [_Reader(r.source, {f"{key}[{i}]": v}, r.prefix).number(f"{key}[{i}]")
                  for i, v in enumerate(raw)]
        if any(v < 0 or (key == "link_masses" and v == 0) for v in values):
            raise r.fail(key, "must be positive" if key == "link_masses"
                         else "must be non-negative", raw)
        out[key] = values
    if r.has("payload_kg"):
        payload = r.number("payload_kg")
        if payload < 0:
            raise r.fail("payload_kg", "must be non-negative (kg)", payload)
        out["payload_kg"] = payload
    if r.has("gravity"):
        raw = r.table["gravity"]
        if isinstance(raw, bool):
            out["gravity"] = [0.0, -9.81] if raw else [0.0, 0.0]
        elif isinstance(raw, list) and len(raw) == 2:
            out["gravity"] = [_Reader(r.source, {"gravity": v}, r.prefix).number("gravity")
                              for v in raw]
        else:
            raise r.fail("gravity", "must be [gx, gy] in m/s² (or true for [0, -9.81])", raw)
    return out


def _check_home(arm: Arm) -> None:
    # Imported here: kinematics needs Arm, config must not import it at module load.
    from robodcn import kinematics

    inner, outer = kinematics.workspace(arm.links)
    radius = float(kinematics.wrist_radius(arm.links, [arm.home])[0])
    if not inner - kinematics.REACH_TOLERANCE <= radius <= outer + kinematics.REACH_TOLERANCE:
        raise ConfigError(f"key 'arm.home' = {list(arm.home)!r}: home pose is out of reach "
                          f"(wrist point {radius:.4f} m from the base, the arm reaches "
                          f"{inner:.4f}..{outer:.4f} m)", file=arm.source, key="arm.home",
                          value=list(arm.home))


def load_arm(path: str | Path) -> Arm:
    """Read and validate an arm TOML file (see the module docstring for its layout).

    Raises
    ------
    ConfigError
        The file is missing, not valid TOML, or any key is unknown, missing or impossible;
        the message names the file, key and value.
    """
    path = Path(path)
    source = str(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot read arm config: {exc.strerror}", file=source, key=None,
                          value=source) from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(f"arm config is not UTF-8 text: {exc}", file=source, key=None,
                          value=source) from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"invalid TOML: {exc}", file=source, key=None, value=None) from exc
    return arm_from_dict(data, source=source)
