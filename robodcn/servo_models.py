"""Servo models robodcn knows: one frozen :class:`ServoModel` record per Dynamixel model.

Every fact about a model that robodcn uses — its model number, the Operating Modes it offers,
its resolution, its current units, its torque–speed line, its rotor inertia, its body — sits
in that model's record (ROBOTIS e-manual of the XM430-W350 and XL430-W250;
shared/dynamixel-notes.md §2, shared/omx.md). The configuration checks a file against it,
the bus converts units and checks modes and model numbers with it, the stream's motor model
and compensation take their datasheet figures and gains from it; none keeps a table of its
own. (firmware_sim, the other side of the wire, keeps its own tables on purpose: it must
never import robodcn.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Operating Mode (address 11) values (e-manual "Operating Mode"): current control (torque),
#: velocity, position (one turn), extended position (multi-turn), current-based position, PWM.
OPERATING_MODE_CURRENT = 0
OPERATING_MODE_VELOCITY = 1
OPERATING_MODE_POSITION = 3
OPERATING_MODE_EXTENDED_POSITION = 4
OPERATING_MODE_CURRENT_POSITION = 5
OPERATING_MODE_PWM = 16
OPERATING_MODE_NAMES: dict[int, str] = {0: "current", 1: "velocity", 3: "position",
                                        4: "extended position", 5: "current-based position",
                                        16: "PWM"}

_RPM = 2.0 * math.pi / 60.0
#: The largest Profile Acceleration an X-series servo can express, rad/s²
#: (32 767 × 214.577 rev/min² ≈ 12 272 rad/s²).
PROFILE_ACCELERATION_MAX = 32_767 * 214.577 * 2.0 * math.pi / 3600.0


@dataclass(frozen=True)
class ServoModel:
    """What one Dynamixel model is and can do (ROBOTIS e-manual; dynamixel-notes.md §2).

    name : the model's name as configs spell it ("xm430-w350")
    model_number : the Model Number (address 0) the servo answers a PING with
    operating_modes : the Operating Mode (11) values the model offers
    ticks_per_turn : position resolution (pulse/rev) in position mode (Operating Mode 3)
    max_velocity : no-load speed at the highest rated voltage (rad/s): no joint driven by
        this servo can be faster
    max_acceleration : the largest Profile Acceleration the servo can express
        (32 767 × 214.577 rev/min², rad/s²)
    stall_torque : stall torque at 12 V (N·m)
    stall_current : stall current at 12 V (A): the largest goal current worth asking, and
        the current limit of a model without a Current Limit item
    rated_speed : no-load speed at 12 V (rad/s), the other end of the torque–speed line
    gear_ratio : the gear train's reduction N (output turns × N = motor turns)
    motor_inertia : the motor rotor's own inertia J_rotor (kg·m²; an estimate for the motor
        size, not on the datasheet)
    default_p_gain : the Position P Gain (84) at the factory (e-manual)
    goal_current_unit : amperes per unit of Goal Current (102) and Current Limit (38); None
        for a model without current control (no such items)
    present_current_unit : amperes per unit of Present Current (126), or of Present Load
        (0.1 % of the stall current) on a model without current sensing
    body : the case's width × length × height (m), the height along the horn axis (an
        X-series XM430 / XL430: 28.5 × 46.5 × 34 mm, ROBOTIS e-manual "Dimensions")
    axis_from_end : how far the horn axis lies from the near end of the case's length (m;
        11.25 mm: ROBOTIS's OpenMANIPULATOR-X base link frame, at the yaw servo's centre,
        sits 12 mm behind the yaw axis, 46.5/2 − 12; shared/omx.md)
    """

    name: str
    model_number: int
    operating_modes: frozenset[int]
    ticks_per_turn: int
    max_velocity: float
    max_acceleration: float
    stall_torque: float
    stall_current: float
    rated_speed: float
    gear_ratio: float
    motor_inertia: float
    default_p_gain: int
    goal_current_unit: float | None
    present_current_unit: float
    body: tuple[float, float, float] = (0.0285, 0.0465, 0.034)
    axis_from_end: float = 0.01125

    @property
    def rotor_inertia(self) -> float:
        """Reflected rotor inertia at the output shaft, J_rotor·N² (kg·m²)."""
        return self.motor_inertia * self.gear_ratio ** 2

    @property
    def current_control(self) -> bool:
        """Whether the model has Goal Current and Current Limit (modes 0 and 5)."""
        return self.goal_current_unit is not None

    def offers(self, mode: int) -> bool:
        """Whether the model offers Operating Mode ``mode``."""
        return mode in self.operating_modes

    def available_torque(self, velocity: float) -> float:
        """Torque (N·m) the servo delivers at ``velocity`` (rad/s) on its 12 V torque–speed
        line: τ_stall · (1 − |ω| / ω_no-load), 0 beyond the no-load speed."""
        return self.stall_torque * max(0.0, 1.0 - abs(velocity) / self.rated_speed)

    @property
    def torque_constant(self) -> float:
        """K_t = τ_stall / I_stall (N·m/A at the output shaft, 12 V datasheet): the torque
        a current stands for (ROBOTIS lists the same ratio, e.g. 1.659 N·m/A for the
        XM540-W150)."""
        return self.stall_torque / self.stall_current


#: XM430-W350: 57 rev/min no-load at 14.8 V; at 12 V 46 rev/min, stall 4.1 N·m at 2.3 A;
#: 2.69 mA a current unit; rotor 1.0e-7 kg·m² behind a 353.5:1 gear train.
XM430_W350 = ServoModel(
    name="xm430-w350", model_number=1020, operating_modes=frozenset({0, 1, 3, 4, 5, 16}),
    ticks_per_turn=4096, max_velocity=57 * _RPM, max_acceleration=PROFILE_ACCELERATION_MAX,
    stall_torque=4.1, stall_current=2.3, rated_speed=46 * _RPM,
    gear_ratio=353.5, motor_inertia=1.0e-7, default_p_gain=800, goal_current_unit=2.69e-3,
    present_current_unit=2.69e-3)
#: XL430-W250: 61 rev/min no-load at 12 V, stall 1.5 N·m at 1.4 A; no current sensing (no
#: modes 0 and 5; Present Load in 0.1 % of 1.4 A); rotor 6.0e-8 kg·m² behind 258.5:1.
XL430_W250 = ServoModel(
    name="xl430-w250", model_number=1060, operating_modes=frozenset({1, 3, 4, 16}),
    ticks_per_turn=4096, max_velocity=61 * _RPM, max_acceleration=PROFILE_ACCELERATION_MAX,
    stall_torque=1.5, stall_current=1.4, rated_speed=61 * _RPM,
    gear_ratio=258.5, motor_inertia=6.0e-8, default_p_gain=640, goal_current_unit=None,
    present_current_unit=1.4e-3)

#: The models a robodcn config may name: name → record.
SERVO_SPECS: dict[str, ServoModel] = {m.name: m for m in (XM430_W350, XL430_W250)}
SERVO_MODELS = tuple(SERVO_SPECS)
#: Model numbers (e-manual) of the models robodcn knows by name only, to tell a scan's or a
#: PING's answer: they cannot be named in a config.
OTHER_MODEL_NUMBERS: dict[str, int] = {"xm430-w210": 1030, "xl330-m077": 1190,
                                       "xl330-m288": 1200, "xc330-t288": 1220}
#: Model name → Model Number: the records' numbers, then the others'.
MODEL_NUMBERS: dict[str, int] = {**{m.name: m.model_number for m in SERVO_SPECS.values()},
                                 **OTHER_MODEL_NUMBERS}
#: Model Number → model name.
MODEL_NAMES: dict[int, str] = {number: name for name, number in MODEL_NUMBERS.items()}


__all__ = [
    "MODEL_NAMES",
    "MODEL_NUMBERS",
    "OPERATING_MODE_CURRENT",
    "OPERATING_MODE_CURRENT_POSITION",
    "OPERATING_MODE_EXTENDED_POSITION",
    "OPERATING_MODE_NAMES",
    "OPERATING_MODE_POSITION",
    "OPERATING_MODE_PWM",
    "OPERATING_MODE_VELOCITY",
    "OTHER_MODEL_NUMBERS",
    "PROFILE_ACCELERATION_MAX",
    "SERVO_MODELS",
    "SERVO_SPECS",
    "XL430_W250",
    "XM430_W350",
    "ServoModel",
]
