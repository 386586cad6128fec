"""Arm and bus configuration: frozen dataclasses loaded from TOML (stdlib ``tomllib``).

Inside robodcn everything is SI: metres, radians, rad/s, rad/s², N·m, A. A TOML file may
give angles in degrees and widths in millimetres instead, through keys with an explicit
unit suffix (``min_deg``, ``max_velocity_deg_s``, ``theta_deg``, ``open_width_mm`` ...); a
quantity given twice (``min`` and ``min_deg``) is an error. Unknown keys, missing keys and
impossible values raise :class:`robodcn.errors.ConfigError` naming the file, the dotted key
(``joints[1].servo.id``) and the value.

File layout (see ``configs/arm3r.toml`` for a planar arm, ``configs/omx.toml`` for a yawed
one)::

    [arm]      name, links = [l1, l2(, l3)] metres, elbow = "up" | "down",
               optional plane = "horizontal" | "vertical";
               a yawed arm: base_yaw = true, plane = "vertical", shoulder_height (m),
               links = [[r, z], …] vectors from each joint to the next at zero (m)
    [arm.home] x, y (metres), theta | theta_deg; a yawed arm x, y, z, pitch | pitch_deg
    [arm.rest] optional, the same keys: a pose to lower to before torque goes off
    [bus]      port, baud, protocol = 2.0, rate_hz
    [[joints]] name, min | min_deg, max | max_deg, max_velocity | max_velocity_deg_s,
               max_acceleration | max_acceleration_deg_s2,
               optional max_jerk | max_jerk_deg_s3 (absent: no jerk limit),
               optional max_torque_nm, optional collision_current_a,
               optional in_position | in_position_deg (how far from a move's goal the
               joint may rest and be in position; default 3 ticks)
    [joints.servo] id, model, ticks_per_turn, zero_offset, direction, min_tick, max_tick
    [dynamics] optional: link_masses, link_com, link_inertias, payload_kg,
               rotor_inertia_kg_m2; a planar arm gravity = [gx, gy]; a yawed arm
               gravity_m_s2 (along −z), yaw_body_mass, yaw_body_com, yaw_body_inertia
    [workspace] optional keep-out zones (robodcn.config._workspace): floor_z | floor_y,
               base_radius, base_height, [[workspace.keep_out]] name, min, max; a yawed
               arm's defaults: the floor at z = 0 and a cylinder about the yaw axis
    [gripper]  optional: the servo keys (id, model, …), open | open_deg, closed |
               closed_deg, open_width_m | open_width_mm, closed_width_m |
               closed_width_mm, grip_current_a
    [tool]     optional: the tool point's default limits speed (m/s), angular_speed |
               angular_speed_deg_s, acceleration (m/s², along the path) and the largest a
               request may ask, max_speed, max_angular_speed | max_angular_speed_deg_s,
               max_acceleration (absent: no tool limit, no ceiling)

Two chain joints make a position-only arm (θ or pitch free), three a full-pose arm; a
yawed arm has the yaw joint first (``[[joints]]`` in order: yaw, then the chain).

Values are checked against the servo model (:data:`SERVO_SPECS`: ticks a turn, no-load
speed, largest profile acceleration, stall torque and current) and physical sense (link
lengths in :data:`LINK_RANGE`, joint limits within one turn, the home pose reachable);
messages stay one short line. :func:`load_arm` takes a path, or the name of a packaged
example (:data:`EXAMPLES`: ``"arm3r"``, ``"arm2r"``, ``"omx"``; :mod:`._examples`).
"""

from robodcn.config._body import (
    DEPTH_SLACK,
    Body,
    Intrusion,
    body_of,
    body_points,
    clear_of_zones,
    first_intrusion,
)
from robodcn.config._examples import EXAMPLES, example_path
from robodcn.config._load import arm_from_dict, load_arm
from robodcn.config._rigid import rigid_chain, rotor_inertias
from robodcn.config._specs import (
    BAUD_RATES,
    ELBOWS,
    IN_POSITION_TICKS,
    LINK_RANGE,
    MAX_JERK,
    MAX_SERVO_ID,
    PLANAR_POSE,
    PLANES,
    RATE_RANGE,
    YAWED_POSE,
    Arm,
    BusSpec,
    GripperSpec,
    JointSpec,
    MassProperties,
    ServoSpec,
    ToolSpec,
)
from robodcn.config._workspace import base_radius_of
from robodcn.config._zones import BASE, FLOOR, KeepOutBox, Workspace
from robodcn.servo_models import SERVO_MODELS, SERVO_SPECS, ServoModel

__all__ = [
    "BASE",
    "BAUD_RATES",
    "DEPTH_SLACK",
    "ELBOWS",
    "EXAMPLES",
    "FLOOR",
    "IN_POSITION_TICKS",
    "LINK_RANGE",
    "MAX_JERK",
    "MAX_SERVO_ID",
    "PLANAR_POSE",
    "PLANES",
    "RATE_RANGE",
    "SERVO_MODELS",
    "SERVO_SPECS",
    "YAWED_POSE",
    "Arm",
    "Body",
    "BusSpec",
    "GripperSpec",
    "Intrusion",
    "JointSpec",
    "KeepOutBox",
    "MassProperties",
    "ServoModel",
    "ServoSpec",
    "ToolSpec",
    "Workspace",
    "arm_from_dict",
    "base_radius_of",
    "body_of",
    "body_points",
    "clear_of_zones",
    "example_path",
    "first_intrusion",
    "load_arm",
    "rigid_chain",
    "rotor_inertias",
]
