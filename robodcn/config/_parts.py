"""Parsing of the per-part tables: ``[[joints]]`` with their ``[joints.servo]``, ``[bus]``
and ``[gripper]`` (units converted to SI, every value checked, errors naming the key)."""

from __future__ import annotations

import math

from robodcn.config._reader import Reader
from robodcn.config._specs import (
    BAUD_RATES,
    IN_POSITION_MAX,
    MAX_JERK,
    MAX_SERVO_ID,
    RATE_RANGE,
    BusSpec,
    GripperSpec,
    JointSpec,
    ServoSpec,
)
from robodcn.servo_models import OPERATING_MODE_CURRENT_POSITION, SERVO_MODELS, SERVO_SPECS

#: The ``[joints.servo]`` keys (also accepted in ``[gripper]``).
SERVO_KEYS = {"id", "model", "ticks_per_turn", "zero_offset", "direction", "min_tick",
              "max_tick"}


def servo(r: Reader, extra: frozenset[str] = frozenset()) -> ServoSpec:
    """A servo table (``extra``: more keys its table may hold, read by the caller)."""
    r.only(SERVO_KEYS | extra)
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


def joint(r: Reader) -> JointSpec:
    """One ``[[joints]]`` entry."""
    r.only({"name", "min", "min_deg", "max", "max_deg", "max_velocity", "max_velocity_deg_s",
            "max_acceleration", "max_acceleration_deg_s2", "max_jerk", "max_jerk_deg_s3",
            "servo", "collision_current_a", "max_torque_nm", "in_position",
            "in_position_deg"})
    name = r.string("name")
    spec = servo(r.sub("servo"))
    model = SERVO_SPECS[spec.model]

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
             f"the {spec.model}'s no-load speed"),
            ("max_acceleration", "max_acceleration_deg_s2", acc, model.max_acceleration,
             "deg/s²", f"the {spec.model}'s largest profile acceleration"),
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
    torque = r.number("max_torque_nm") if r.has("max_torque_nm") else None
    if torque is not None and not 0.0 < torque <= model.stall_torque:
        raise r.fail("max_torque_nm", f"must be a torque within 0..{model.stall_torque:g} N·m "
                     f"(the {spec.model}'s stall torque)", torque)
    in_position = None
    if r.has("in_position") or r.has("in_position_deg"):
        in_position = r.angle("in_position", "in_position_deg")
        tick = 2.0 * math.pi / spec.ticks_per_turn
        if not tick <= in_position <= IN_POSITION_MAX:
            key = key_of("in_position", "in_position_deg")
            low, high = (in_deg("in_position", "in_position_deg", x, "°")
                         for x in (tick, IN_POSITION_MAX))
            raise r.fail(key, f"must be within {low} (one tick)..{high}", r.table[key])
    return JointSpec(name, lo, hi, vel, acc, spec, jerk, collision, torque, in_position)


def bus(r: Reader) -> BusSpec:
    """The ``[bus]`` table."""
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



#: Jaw widths accepted (m): from a millimetre to a metre.
WIDTH_RANGE = (1e-3, 1.0)


def gripper(r: Reader) -> GripperSpec:
    """The ``[gripper]`` table: the servo keys of ``[joints.servo]``, ``open`` | ``open_deg``
    and ``closed`` | ``closed_deg`` (servo angles), ``open_width_m`` | ``open_width_mm`` and
    ``closed_width_m`` | ``closed_width_mm`` (jaw widths), ``grip_current_a``. The servo's
    model must offer current-based position mode (the mode :mod:`robodcn.workflow.gripper`
    closes in), or the file is refused here rather than at the first gripper command."""
    keys = frozenset({"open", "open_deg", "closed", "closed_deg", "open_width_m",
                      "open_width_mm", "closed_width_m", "closed_width_mm", "grip_current_a"})
    r.only(SERVO_KEYS | keys)
    spec = servo(r, extra=keys)
    model = SERVO_SPECS[spec.model]
    if not model.offers(OPERATING_MODE_CURRENT_POSITION):
        raise r.fail("model", "a gripper closes in current-based position mode "
                     f"({OPERATING_MODE_CURRENT_POSITION}) with grip_current_a as its goal "
                     f"current, and the {spec.model} has no current-based position mode (no "
                     "current control); drive the gripper with a model that has it "
                     f"({', '.join(n for n, m in SERVO_SPECS.items() if m.current_control)})",
                     spec.model)
    angles = {}
    for si, deg in (("open", "open_deg"), ("closed", "closed_deg")):
        angle = r.angle(si, deg)
        tick = spec.zero_offset + spec.direction * angle * spec.ticks_per_turn / (2 * math.pi)
        if not spec.min_tick <= round(tick) <= spec.max_tick:
            key = deg if r.has(deg) else si
            raise r.fail(key, f"the servo angle lands on tick {round(tick)}, outside "
                         f"min_tick..max_tick = {spec.min_tick}..{spec.max_tick}", r.table[key])
        angles[si] = angle
    if angles["open"] == angles["closed"]:
        key = "closed_deg" if r.has("closed_deg") else "closed"
        raise r.fail(key, "must differ from the open position", r.table[key])
    widths = {}
    for name in ("open_width", "closed_width"):
        width = r.angle(f"{name}_m", f"{name}_mm", scale=1e-3)
        key = f"{name}_mm" if r.has(f"{name}_mm") else f"{name}_m"
        if not WIDTH_RANGE[0] <= width <= WIDTH_RANGE[1]:
            raise r.fail(key, f"a jaw width must be within {WIDTH_RANGE[0] * 1e3:g}.."
                         f"{WIDTH_RANGE[1] * 1e3:g} mm", r.table[key])
        widths[name] = width
    if widths["open_width"] <= widths["closed_width"]:
        key = "open_width_mm" if r.has("open_width_mm") else "open_width_m"
        raise r.fail(key, "the open jaws must be wider than the closed ones "
                     f"({widths['closed_width'] * 1e3:g} mm)", r.table[key])
    current = r.number("grip_current_a")
    if not 0.0 < current < model.stall_current:
        raise r.fail("grip_current_a", f"must be a current within 0..{model.stall_current:g} A "
                     f"(below the {spec.model}'s stall current)", current)
    return GripperSpec(spec, angles["open"], angles["closed"], widths["open_width"],
                       widths["closed_width"], current)
