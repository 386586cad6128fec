"""Servo admin jobs the service runs on its bus worker (:meth:`robodcn.controller.
ArmController.set_torque`, :meth:`~robodcn.controller.ArmController.gripper`): torque off
that would drop an arm under gravity needs confirmation, and the gripper.

* :func:`set_torque`: :func:`robodcn.workflow.admin.set_torque`, but torque off on an arm
  under gravity (a chain in a vertical plane, g ≠ 0) is refused without ``confirm`` —
  GravityReleaseError (409; CLI ``--yes``, HTTP ``"confirm": true``) naming the joints
  gravity loads and the torque each holds at the present pose
  (:func:`robodcn.workflow.release.check_release`) — unless the one joint switched is not
  loaded (an OM-X's base yaw). Confirmed, torque goes off where the arm is: lowering to a
  rest pose first is a release's (:func:`robodcn.workflow.release.release`).
* :func:`gripper`: :func:`robodcn.workflow.gripper.actuate` on the arm's ``[gripper]``.

Each ``check_*``/``*_goal`` function refuses bad arguments before the bus is touched.
"""

from __future__ import annotations

from robodcn import servo_units
from robodcn.bus import ServoBus
from robodcn.config import Arm, GripperSpec
from robodcn.errors import GravityReleaseError, InputError
from robodcn.workflow import admin
from robodcn.workflow import gripper as grip
from robodcn.workflow.float_teach import has_gravity
from robodcn.workflow.release import ReleaseCheck, check_release

#: Seconds a gripper command may take on the worker thread: the jaws' own settling timeout
#: (:func:`robodcn.workflow.gripper.actuate`, 3 s) and the reads around it.
GRIPPER_TIMEOUT = 5.0


def check_torque(arm: Arm, on: object, joint: str | None, confirm: object) -> None:
    """InputError for a non-boolean ``on`` or ``confirm`` or an unknown ``joint``."""
    for name, value in (("on", on), ("confirm", confirm)):
        if not isinstance(value, bool):
            raise InputError(f"{name} must be true or false, got {value!r}", field=name,
                             value=value)
    admin.joint_ids(arm, joint)


def refuse_falling(check: ReleaseCheck, joint: str | None) -> None:
    """GravityReleaseError when torque off on ``joint`` (None: every joint) drops the arm:
    it falls (``check.falls``) and ``joint`` is one gravity loads (or every joint goes)."""
    if not check.falls or (joint is not None and joint not in check.joints):
        return
    which = check.joints if joint is None else (joint,)
    if check.holding_torque_nm is None:
        held = "gravity loads " + ", ".join(which)
    else:
        torque = dict(zip(check.joint_names, check.holding_torque_nm, strict=True))
        held = "holding " + ", ".join(f"{name} {abs(torque[name]):.2f} N·m" for name in which)
    on = f"on {joint} " if joint is not None else ""
    raise GravityReleaseError(
        f"torque off {on}lets arm {check.arm!r} fall under gravity ({held}); confirm to "
        "switch it off where it is", arm=check.arm, joints=which,
        holding_torque_nm=check.holding_torque_nm, rest=check.rest)


def set_torque(bus: ServoBus, arm: Arm, on: bool, joint: str | None = None, *,
               confirm: bool = False) -> tuple[int, ...]:
    """Torque on or off for ``joint`` (default every joint), refusing a torque off that
    drops the arm unless ``confirm`` (module docstring); returns the ids written."""
    check_torque(arm, on, joint, confirm)
    if not on and not confirm and has_gravity(arm):
        ticks = bus.read_positions()
        q = servo_units.ticks_to_radians(ticks[None, :], arm.servos)[0]
        refuse_falling(check_release(arm, q), joint)
    return admin.set_torque(bus, arm, on, joint)


def _spec(arm: Arm) -> GripperSpec:
    if arm.gripper is None:
        raise InputError(f"arm {arm.name!r} has no [gripper]", field="gripper",
                         value=arm.name)
    return arm.gripper


def gripper_goal(arm: Arm, command: str | None, width_m: float | None) -> grip.GripperGoal:
    """The goal of a gripper command on ``arm`` (:func:`robodcn.workflow.gripper.
    gripper_goal`); InputError naming "gripper" on an arm without one."""
    return grip.gripper_goal(_spec(arm), command, width_m=width_m)


def gripper(bus: ServoBus, arm: Arm, command: str | None = None,
            width_m: float | None = None) -> grip.GripperResult:
    """Drive ``arm``'s gripper to ``command`` or ``width_m`` and wait until the jaws rest."""
    return grip.actuate(bus, _spec(arm), command, width_m=width_m)


__all__ = ["GRIPPER_TIMEOUT", "check_torque", "gripper", "gripper_goal", "refuse_falling",
           "set_torque"]
