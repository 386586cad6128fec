"""Moving from the present pose: read where the arm is, plan from there.

The one place robodcn turns the servos' present positions into a start for a plan, shared
by ``robodcn move``/``sim`` (CLI) and ``POST /v1/moves`` (HTTP):

* :func:`present_joints` reads Present Position and converts ticks to joint angles
  (θ = direction·(tick − zero_offset)·2π/ticks_per_turn, robodcn.servo_units), after
  checking that the bus drives the arm's servos (same ids, same order; with ``verify``, the
  default, also that each answers with its configured model).
* :func:`plan_from_present` plans a :class:`~robodcn.planner.PlanRequest` or a list of
  waypoints with ``start_joints`` = the present joints; a waypoint list whose first entry is
  None starts at the present pose (FK of the present joints). The planner prepends a
  joint-space approach when the arm is not at the IK of the first waypoint.
* :func:`plan_recovering` is :func:`plan_from_present` with a way back: from a present
  state not acceptable as a start (a joint past its limit after a fall) a slow joint-space
  recovery comes first and the move is planned from the recovered joints
  (:func:`robodcn.planner.recovery.with_recovery`; its :class:`Recovery` says what it does).
  Every surface that moves the arm from where it is plans through it.
* :func:`approach_of` gives that approach (samples and duration, as the planner recorded it
  in ``Trajectory.approach_samples``), for reports (:mod:`robodcn.stream.report`, re-exported
  here). The streamer's own ``approach`` option plans through the planner directly.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import servo_units
from robodcn.bus import ServoBus
from robodcn.config import Arm
from robodcn.errors import InputError, ServoMismatchError
from robodcn.planner import PlanRequest, Trajectory, plan, plan_request
from robodcn.planner.path import user_pose
from robodcn.planner.recovery import Recovered, Recovery, with_recovery
from robodcn.stream.report import Approach, approach_of  # re-export: the report's types


def check_servos(arm: Arm, bus: ServoBus) -> None:
    """ServoMismatchError unless ``bus`` drives ``arm``'s servo ids in joint order."""
    if tuple(bus.ids) != tuple(arm.servo_ids):
        raise ServoMismatchError(
            f"arm {arm.name!r} drives servo ids {list(arm.servo_ids)}, the bus has "
            f"{list(bus.ids)} (same ids in the same order needed)", field="servo_ids",
            value=list(bus.ids))


def present_joints(arm: Arm, bus: ServoBus, *, verify: bool = True) -> NDArray[np.float64]:
    """The arm's present joint angles (k,) in radians, read from the servos.

    Parameters
    ----------
    arm : the arm whose servos ``bus`` drives
    bus : an open ServoBus
    verify : also check that every servo answers with its configured model (and read its
        limits, :meth:`ServoBus.verify`); False when the caller has just verified the bus

    Raises
    ------
    ServoMismatchError when the bus's ids are not the arm's (or, with ``verify``, a servo
    is missing or of another model); CommError when the servos do not answer.
    """
    check_servos(arm, bus)
    if verify:
        bus.verify(arm.servos)
    ticks = bus.read_positions()
    return servo_units.ticks_to_radians(ticks, arm.servos)


def _given_or_read(arm: Arm, bus: ServoBus | None, joints: ArrayLike | None, verify: bool,
                   caller: str) -> NDArray[np.float64]:
    """``joints`` (k,) rad as given, else read from ``bus`` (:func:`present_joints`)."""
    if joints is not None:
        return np.asarray(joints, dtype=np.float64)
    if bus is None:
        raise InputError(f"{caller} needs a bus or the present joints", field="bus",
                         value=None)
    return present_joints(arm, bus, verify=verify)


def plan_from_present(arm: Arm, bus: ServoBus | None,
                      target: PlanRequest | Sequence[ArrayLike | None], *,
                      joints: ArrayLike | None = None, verify: bool = True,
                      **plan_options: Any) -> Trajectory:
    """Plan ``target`` starting from the arm's present joints.

    Parameters
    ----------
    arm : Arm
    bus : the open bus to read the present joints from (None when ``joints`` is given)
    target : a PlanRequest (its start_joints are replaced) or waypoints (x, y, θ); a first
        waypoint None means "the present pose" (FK of the present joints)
    joints : present joints (k,) rad already read (e.g. on a controller's worker thread);
        None reads them with :func:`present_joints`
    verify : passed to :func:`present_joints`
    plan_options : keyword options of :func:`robodcn.plan` (waypoint targets only)

    Raises whatever :func:`present_joints` and the planner raise (nothing moves).
    """
    q = _given_or_read(arm, bus, joints, verify, "plan_from_present")
    start = tuple(float(v) for v in q)
    if isinstance(target, PlanRequest):
        if plan_options:
            name = next(iter(plan_options))
            raise InputError(f"{name} cannot be given with a PlanRequest (set it in the "
                             "request)", field=name, value=plan_options[name])
        return plan_request(dataclasses.replace(target, start_joints=start))
    waypoints = list(target)
    if waypoints and waypoints[0] is None:
        waypoints[0] = tuple(user_pose(arm, q[None, :])[0])
    return plan(arm, waypoints, start_joints=start, **plan_options)


def plan_recovering(arm: Arm, bus: ServoBus | None,
                    target: PlanRequest | Sequence[ArrayLike | None], *,
                    joints: ArrayLike | None = None, verify: bool = True,
                    **plan_options: Any) -> Recovered:
    """:func:`plan_from_present` behind a recovery when the present joints are not
    acceptable as a start (module docstring): (the trajectory, its Recovery or None).

    The move is planned from the recovered joints before anything moves; a first waypoint
    None is the pose there. Raises what :func:`plan_from_present` raises.
    """
    q = _given_or_read(arm, bus, joints, verify, "plan_recovering")
    return with_recovery(arm, q, lambda start: plan_from_present(
        arm, None, target, joints=start, **plan_options))


__all__ = ["Approach", "Recovered", "Recovery", "approach_of", "check_servos",
           "plan_from_present", "plan_recovering", "present_joints"]
