"""Servo admin jobs the service runs on its bus worker (:meth:`robodcn.controller.
ArmController.set_torque`, :meth:`~robodcn.controller.ArmController.reboot`,
:meth:`~robodcn.controller.ArmController.gripper`).

* :func:`set_torque`: on holds where the arm is (:func:`robodcn.workflow.admin.set_torque`);
  off, and :func:`reboot` (a servo comes back from a REBOOT with torque off), go through the
  gravity guard :func:`robodcn.workflow.release.release`: on an arm under gravity (a chain
  in a vertical plane, g ≠ 0) refused without ``confirm`` — GravityReleaseError (409; CLI
  ``--yes``, HTTP ``"confirm": true``) naming the joints gravity loads and the torque each
  holds at the present pose — unless the joints switched are not loaded (an OM-X's base
  yaw, a joint whose torque is off already). Confirmed, the arm is lowered to its rest pose
  first where it can be, and the user told to hold it where it cannot.
* :func:`gripper`: :func:`robodcn.workflow.gripper.actuate` on the arm's ``[gripper]``,
  halted by a stop through its :class:`Halt` (the jaws' goal := where they are).

Each ``check_*``/``*_goal`` function refuses bad arguments before the bus is touched.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Any

from robodcn.bus import ServoBus
from robodcn.config import Arm, GripperSpec
from robodcn.errors import InputError
from robodcn.results import RebootAnswer, TorqueAnswer
from robodcn.workflow import admin
from robodcn.workflow import gripper as grip
from robodcn.workflow.release import release, released

#: Seconds a gripper command may take on the worker thread: the jaws' own settling timeout
#: (:func:`robodcn.workflow.gripper.actuate`, 3 s) and the reads around it.
GRIPPER_TIMEOUT = 5.0
#: Seconds a torque off or a reboot may take on the worker thread: the lowering to the rest
#: pose first (a few seconds at the arm's limits) and the reboot's own wait.
RELEASE_TIMEOUT = 60.0


def check_torque(arm: Arm, on: object, joint: str | None, confirm: object) -> None:
    """InputError for a non-boolean ``on`` or ``confirm`` or an unknown ``joint``."""
    for name, value in (("on", on), ("confirm", confirm)):
        if not isinstance(value, bool):
            raise InputError(f"{name} must be true or false, got {value!r}", field=name,
                             value=value)
    admin.joint_ids(arm, joint)


def set_torque(bus: ServoBus, arm: Arm, on: bool, joint: str | None = None, *,
               confirm: bool = False, execute_options: dict[str, Any] | None = None
               ) -> TorqueAnswer:
    """Torque on (holding where the arm is) or off for ``joint`` (default every joint).

    Off goes through the gravity guard (module docstring): GravityReleaseError without
    ``confirm`` when it drops the arm; confirmed, lowered to the rest pose first.
    ``execute_options`` go to the lowering's :func:`robodcn.execute`."""
    check_torque(arm, on, joint, confirm)
    if on:
        return TorqueAnswer(on=True, joint=joint,
                            servo_ids=list(admin.set_torque(bus, arm, True, joint)))
    result = released(release(bus, arm, confirm=confirm, ids=admin.joint_ids(arm, joint),
                           verify=False, execute_options=execute_options,
                           switch_off=lambda: admin.set_torque(bus, arm, False, joint)),
                   "torque off")
    return TorqueAnswer(on=False, joint=joint, servo_ids=list(result.released_ids),
                        lowered=result.lowered, hold=result.hold)


def reboot(bus: ServoBus, arm: Arm, joint: str | None = None, *, confirm: bool = False,
           execute_options: dict[str, Any] | None = None) -> RebootAnswer:
    """REBOOT ``joint``'s servo (default every joint's): it comes back with torque off, so
    it goes through the gravity guard like a torque off (:func:`set_torque`)."""
    check_torque(arm, False, joint, confirm)
    result = released(release(bus, arm, confirm=confirm, ids=admin.joint_ids(arm, joint),
                           verify=False, what="reboot", execute_options=execute_options,
                           switch_off=lambda: admin.reboot(bus, arm, joint)), "reboot")
    return RebootAnswer(joint=joint, servo_ids=list(result.released_ids),
                        lowered=result.lowered, hold=result.hold)


def _spec(arm: Arm) -> GripperSpec:
    if arm.gripper is None:
        raise InputError(f"arm {arm.name!r} has no [gripper]", field="gripper",
                         value=arm.name)
    return arm.gripper


def gripper_goal(arm: Arm, command: str | None, width_m: float | None) -> grip.GripperGoal:
    """The goal of a gripper command on ``arm`` (:func:`robodcn.workflow.gripper.
    gripper_goal`); InputError naming "gripper" on an arm without one."""
    return grip.gripper_goal(_spec(arm), command, width_m=width_m)


@dataclass(eq=False)
class Halt:
    """An admin action that a stop halts (the gripper's): a stop sets ``requested``; the
    action, on the worker thread, halts at its next poll, sets ``halted`` when it did and
    ``ended`` once it has returned (or failed)."""

    requested: threading.Event = field(default_factory=threading.Event)
    ended: threading.Event = field(default_factory=threading.Event)
    halted: bool = False


def gripper(bus: ServoBus, arm: Arm, command: str | None = None,
            width_m: float | None = None, halt: Halt | None = None) -> grip.GripperResult:
    """Drive ``arm``'s gripper to ``command`` or ``width_m`` and wait until the jaws rest;
    ``halt.requested`` (a stop) halts them where they are."""
    try:
        result = grip.actuate(bus, _spec(arm), command, width_m=width_m,
                              stop=None if halt is None else halt.requested.is_set)
        if halt is not None:
            halt.halted = result.stopped
        return result
    finally:
        if halt is not None:
            halt.ended.set()


__all__ = ["GRIPPER_TIMEOUT", "RELEASE_TIMEOUT", "Halt", "check_torque", "gripper",
           "gripper_goal", "reboot", "set_torque"]
