"""Servo admin and state: present pose, torque, reboot, servo info, set id / baud.

Everything goes through :class:`robodcn.bus.ServoBus`'s public methods (``read``, ``write``,
``ping``, ``torque``, ``reboot``, ``read_positions``); control-table addresses are the
X-series ones (shared/dynamixel-notes.md §2). ID and Baud Rate are EEPROM items: a servo
refuses them while its torque is on, so :func:`set_id` and :func:`set_baud` switch torque off
first. Each function checks its arguments before the first write.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn import servo_units
from robodcn.bus import (
    BAUD_INDEX,
    ServoBus,
    describe_hardware_error,
)
from robodcn.config import MAX_SERVO_ID, Arm, ServoSpec
from robodcn.errors import CommError, InputError
from robodcn.servo_models import MODEL_NAMES, MODEL_NUMBERS, OPERATING_MODE_NAMES
from robodcn.workflow.gripper import GripperState, read_gripper_state
from robodcn.workflow.poses import tool_pose

log = logging.getLogger(__name__)



# -- present state -----------------------------------------------------------------------------

@dataclass(frozen=True)
class ArmState:
    """Present ticks (k,), joints (k,) rad and tool pose of an arm: (x, y, θ), or (x, y, z,
    pitch) for an arm with a base yaw (m, rad; :func:`robodcn.workflow.poses.tool_poses`);
    the gripper's jaws (:class:`~robodcn.workflow.gripper.GripperState`) on an arm with a
    ``[gripper]``, else None."""

    ticks: NDArray[np.int64]
    joints: NDArray[np.float64]
    pose: NDArray[np.float64]
    gripper: GripperState | None = None

    def to_dict(self, arm: Arm) -> dict[str, Any]:
        """SI JSON body (the HTTP service's units)."""
        body = {"joint_names": list(arm.joint_names), "ticks": self.ticks.tolist(),
                "joints": self.joints.tolist(), "pose": self.pose.tolist()}
        if self.gripper is not None:
            body.update(gripper_width_m=self.gripper.width_m, holding=self.gripper.holding)
        return body


def present_state(bus: ServoBus, arm: Arm) -> ArmState:
    """Read Present Position of every servo; joints by the arm's calibration, pose by FK;
    the gripper's jaws where the arm has one."""
    ticks = bus.read_positions()
    joints = servo_units.ticks_to_radians(ticks, arm.servos)
    pose = tool_pose(arm, joints)
    jaws = None if arm.gripper is None else read_gripper_state(bus, arm.gripper)
    return ArmState(ticks, joints, pose, jaws)


def joint_ids(arm: Arm, joint: str | None) -> tuple[int, ...]:
    """Servo ids of ``joint`` (a joint name), or of every joint when None."""
    if joint is None:
        return arm.servo_ids
    if joint not in arm.joint_names:
        raise InputError(f"--joint {joint!r} is not a joint of arm {arm.name!r} (joints: "
                         f"{', '.join(arm.joint_names)})", field="joint", value=joint)
    return (arm.joints[arm.joint_names.index(joint)].servo.id,)


def set_torque(bus: ServoBus, arm: Arm, on: bool, joint: str | None = None) -> tuple[int, ...]:
    """Torque Enable on or off for ``joint`` (default every joint); returns the ids written.

    Torque on holds the arm where it is: Goal Position is set to Present Position first, so
    a stale goal from before a torque-off cannot make the joint jump.
    """
    ids = joint_ids(arm, joint)
    if on:
        for servo_id in ids:
            bus.hold_in_place(servo_id)
    bus.torque(on, None if ids == bus.ids else ids)
    log.info("torque %s on servo(s) %s", "on" if on else "off", list(ids))
    return ids


def reboot(bus: ServoBus, arm: Arm, joint: str | None = None) -> tuple[int, ...]:
    """REBOOT ``joint``'s servo (default all) and wait for it; clears hardware errors."""
    ids = joint_ids(arm, joint)
    bus.reboot(ids)
    return ids


# -- servo info ---------------------------------------------------------------------------------

def servo_info(bus: ServoBus) -> list[dict[str, Any]]:
    """Per servo on ``bus``: id, answered, model, firmware, baud, operating mode, torque,
    hardware error (bits and names), input voltage (V) and temperature (°C)."""
    out: list[dict[str, Any]] = []
    for servo_id in bus.ids:
        info = bus.ping(servo_id)
        if info is None:
            out.append({"id": servo_id, "answered": False})
            continue
        mode = bus.read_operating_mode(servo_id)
        errors = bus.read_hardware_error(servo_id)
        out.append({
            "id": servo_id, "answered": True, "model": info.model,
            "model_number": info.model_number, "firmware": info.firmware,
            "baud": bus.baud, "operating_mode": mode,
            "operating_mode_name": OPERATING_MODE_NAMES.get(mode, f"mode {mode}"),
            "torque": bus.read_torque_enabled(servo_id),
            "hardware_error": errors,
            "hardware_error_names": describe_hardware_error(errors) if errors else "",
            "voltage_v": bus.read_input_voltage(servo_id),
            "temperature_c": bus.read_temperature(servo_id),
        })
    return out


# -- models --------------------------------------------------------------------------------------

@dataclass(frozen=True)
class ModelMismatch:
    """A servo that answers as another model than the arm's config says."""

    servo_id: int
    joint: str
    configured: str
    configured_number: int | None
    found: str | None
    found_number: int


def model_mismatches(arm: Arm, found: Mapping[int, int]) -> list[ModelMismatch]:
    """The servos of ``arm`` whose model number in ``found`` (id → model number, of the
    servos that answered) is not their configured model's."""
    out = []
    for joint in arm.joints:
        number = found.get(joint.servo.id)
        want = MODEL_NUMBERS.get(joint.servo.model)
        if number is not None and number != want:
            out.append(ModelMismatch(joint.servo.id, joint.name, joint.servo.model, want,
                                     MODEL_NAMES.get(number), number))
    return out


def bus_model_mismatches(bus: ServoBus, arm: Arm) -> list[ModelMismatch]:
    """:func:`model_mismatches` of the servos that answer a PING on ``bus``."""
    found = {i: info.model_number for i, info in bus.ping_all().items()}
    return model_mismatches(arm, found)


# -- id and baud ---------------------------------------------------------------------------------

def _probe(port: str, baud: int, ids: Sequence[int]) -> ServoBus:
    return ServoBus(port, baud, servos=[ServoSpec(i, "xm430-w350") for i in ids], retries=2)


def check_id(value: int, option: str) -> int:
    """``value`` as a servo id 0..252, InputError naming ``option`` otherwise."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_SERVO_ID:
        raise InputError(f"{option} must be a servo id 0..{MAX_SERVO_ID}, got {value!r}",
                         field=option.strip("-").lower(), value=value)
    return value


def set_id(port: str, baud: int, old: int, new: int) -> None:
    """Give the servo at id ``old`` the id ``new``.

    Refuses (InputError, nothing written) when ``old`` == ``new``, when no servo answers at
    ``old``, or when ``new`` is taken: two servos with one id garble every reply. Torque is
    switched off first (ID is an EEPROM item); afterwards the servo must answer at ``new``.
    """
    check_id(old, "OLD")
    check_id(new, "NEW")
    if old == new:
        raise InputError(f"NEW must differ from OLD, both are {old}", field="new", value=new)
    with _probe(port, baud, [old, new]) as bus:
        if bus.ping(old) is None:
            raise InputError(f"OLD: no servo answers at id {old} on {port} at {baud} baud "
                             "(robodcn scan lists the bus)", field="old", value=old)
        if bus.ping(new) is not None:
            raise InputError(f"NEW: id {new} is already taken on {port}: pick a free id",
                             field="new", value=new)
        bus.write_torque_enabled(old, False)
        bus.write_id(old, new)
        if bus.ping(new) is None:
            raise CommError(f"servo {old} took id {new} but does not answer at it",
                            field="new", value=new)
    log.info("servo id %d → %d on %s", old, new, port)


def baud_index(baud: int, option: str = "BAUD") -> int:
    """Baud Rate item value for ``baud`` bits/s; InputError naming ``option`` otherwise."""
    by_rate = {rate: index for index, rate in BAUD_INDEX.items() if rate != 4_500_000}
    if baud not in by_rate:
        raise InputError(f"{option} must be one of {', '.join(map(str, sorted(by_rate)))}, got "
                         f"{baud!r}", field=option.strip("-").lower(), value=baud)
    return by_rate[baud]


def set_baud(port: str, baud: int, new_baud: int, ids: Sequence[int]) -> None:
    """Switch the servos ``ids`` (answering at ``baud``) to ``new_baud``.

    Refuses (nothing written) when ``new_baud`` is the present rate, when a servo in ``ids``
    does not answer, or when a servo already answers at ``new_baud`` with one of those ids
    (the two would share an id there). Afterwards every servo must answer at ``new_baud``.
    """
    index = baud_index(new_baud)
    baud_index(baud, "--baud")
    if new_baud == baud:
        raise InputError(f"BAUD {new_baud} is the present baud rate already", field="baud",
                         value=new_baud)
    with _probe(port, new_baud, ids) as probe:
        taken = [i for i in ids if probe.ping(i) is not None]
    if taken:
        raise InputError(f"BAUD: id(s) {taken} already answer on {port} at {new_baud} baud; "
                         "changing would put two servos on one id", field="baud", value=new_baud)
    with _probe(port, baud, ids) as bus:
        missing = [i for i in ids if bus.ping(i) is None]
        if missing:
            raise InputError(f"servo id(s) {missing} do not answer on {port} at {baud} baud",
                             field="ids", value=missing)
        for servo_id in ids:
            bus.write_torque_enabled(servo_id, False)
            bus.write_baud_index(servo_id, index)
    with _probe(port, new_baud, ids) as probe:
        silent = [i for i in ids if probe.ping(i) is None]
    if silent:
        raise CommError(f"servo id(s) {silent} do not answer at {new_baud} baud after the "
                        "change", field="baud", value=new_baud)
    log.info("servos %s: %d → %d baud on %s", list(ids), baud, new_baud, port)
