"""One admission path for a service move: admit → read the present state once → plan once →
start.

Every surface that starts a move through an :class:`~robodcn.controller.ArmController`
(``POST /v1/moves``, with or without ``replace``) hands it a :class:`MoveOrder` and calls
:func:`admit`:

1. **admit**: hold the arm for this request (:meth:`ArmController.admitting`): a second
   request meanwhile is BusyError (409) at once, not queued behind the first and then
   started from wherever that one ended;
2. **read** Present Position once, on the controller's bus thread;
3. **plan** once from it (:func:`robodcn.present.plan_from_present`, or a given trajectory
   behind a joint-space approach, :func:`robodcn.workflow.files.with_approach`), so an
   infeasible approach is refused now (422) and the record shows what will run; from a
   present state not acceptable as a start (a joint past its limit after a fall) the move
   is planned from where a slow joint-space recovery takes the arm, and the recovery goes
   first (:func:`robodcn.planner.recovery.with_recovery`: the record's ``recovery``, a
   warning in the log);
4. **start** it with the ticks read (the executor does not read them again).

A replacement (``replace`` while a move runs) skips 2–4: it is planned from the running
move's commanded state (:meth:`ArmController.replace_move`): it never visits its first
waypoint (the caller's view of where the arm is).

A body of one waypoint (``{"waypoints": [G]}``) means "from the present state", for a new
move and for a replacement alike: the surface hands a :data:`Parse` (``MoveOrder.parse``)
and admission parses the body once the present joints are known
(:func:`robodcn.contract.parse_request` with ``start_joints`` = the present; for a
replacement the present pose becomes the first waypoint, which a replacement never visits).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodcn import servo_units
from robodcn.config import Arm
from robodcn.controller import ArmController
from robodcn.errors import InputError
from robodcn.moves import MoveRecord
from robodcn.planner import PlanRequest, Trajectory
from robodcn.planner.path import user_pose
from robodcn.planner.recovery import recovery_target, start_problems, with_recovery
from robodcn.present import plan_from_present
from robodcn.workflow import files

log = logging.getLogger("robodcn.admission")

#: How a surface paces planning (the HTTP service takes turns on a lock per plan size):
#: a context manager for the request about to be planned.
Planning = Callable[[PlanRequest], AbstractContextManager[object]]
#: A move body parsed once the present is known: the present joints (k,) rad → the request
#: starting there (``start_joints`` = them; a body of one waypoint needs them).
Parse = Callable[[tuple[float, ...]], PlanRequest]


def _unpaced(request: PlanRequest) -> AbstractContextManager[object]:
    return contextlib.nullcontext()


@dataclass(frozen=True)
class MoveOrder:
    """What a surface asks the arm to do: plan ``request`` from where the arm is, plan the
    request ``parse`` gives once the present joints are read (a body of one waypoint: from
    the present state), or play a given ``trajectory`` (exactly one of the three);
    ``replace``: take over the running move in flight (waypoints only) instead of refusing
    while one runs; ``start_at``: UNIX time (s) the first sample is due (None: at once)."""

    request: PlanRequest | None = None
    trajectory: Trajectory | None = None
    replace: bool = False
    parse: Parse | None = None
    start_at: float | None = None

    def __post_init__(self) -> None:
        given = [v for v in (self.request, self.trajectory, self.parse) if v is not None]
        if len(given) != 1:
            raise InputError("a move order takes a plan request, a parse or a trajectory: "
                             "exactly one", field="order", value=None)

    def request_at(self, joints: NDArray[np.float64]) -> PlanRequest:
        """The plan request starting at the present ``joints`` (k,) rad: ``request``, or
        ``parse`` of them (InputError naming the body's field, nothing moves)."""
        if self.request is not None:
            return self.request
        assert self.parse is not None
        return self.parse(tuple(float(v) for v in joints))


def _replacement(controller: ArmController, order: MoveOrder) -> PlanRequest:
    """The request of a replacement: ``order.request``, or a one-waypoint body parsed at the
    running move's present joints with the pose there as its first waypoint (a replacement
    never visits its first waypoint: it leaves from the commanded moving state) and no
    start_joints (the start is the commanded state)."""
    if order.request is not None:
        return order.request
    joints = np.asarray(controller.state().joints, dtype=np.float64)
    request = order.request_at(joints)
    if request.start_joints is None:
        return request
    here = tuple(float(v) for v in user_pose(controller.arm, joints[None, :])[0])
    return dataclasses.replace(request, waypoints=(here, *request.waypoints),
                               start_joints=None)


def admit(controller: ArmController, order: MoveOrder, *,
          planning: Planning = _unpaced) -> MoveRecord:
    """Start ``order`` on ``controller``: the new move's record (queued or running).

    Raises BusyError (409) while another move runs or is being admitted (unless ``replace``),
    NoMoveError when a replacement finds nothing running any more (BusyError when
    another replacement is being planned a while longer: they take turns,
    :attr:`ArmController.replacements`), InputError for a given
    trajectory with ``replace`` while a move runs, the planner's errors (422, nothing
    moves) and BusError when the servos cannot be read.
    """
    if order.replace and controller.busy:
        if order.start_at is not None:
            raise InputError("start_at schedules a move from rest: a replacement takes over "
                             "the running move at once (drop start_at or replace)",
                             field="start_at", value=order.start_at)
        if order.trajectory is not None:
            raise InputError("replace takes waypoints: a given trajectory cannot take over a "
                             "running move in flight (stop it first)", field="replace",
                             value=True)
        asked = time.perf_counter()
        # replacements take turns before the planning lane: a queue of them there would
        # hold each answer for all the planning before it
        with controller.replacements.take():
            request = _replacement(controller, order)
            with planning(request):
                log.debug("replace: %.1f ms to its planning lane",
                          (time.perf_counter() - asked) * 1000)
                record = controller.replace_move(request)
        log.debug("replace: move %s in %.1f ms", record.id, (time.perf_counter() - asked) * 1000)
        return record
    arm = controller.arm
    with controller.admitting():
        ticks = controller.present_ticks()
        joints = servo_units.ticks_to_radians(ticks[None, :], arm.servos)[0]
        # the start the move is planned from: the present, or where a recovery takes it
        start = recovery_target(arm, joints, start_problems(arm, joints))
        if order.trajectory is None:
            request = order.request_at(start)
            with planning(request):
                trajectory, recovery = with_recovery(arm, joints, lambda q: plan_from_present(
                    arm, None, request, joints=q))
        else:
            given = order.trajectory
            assert given is not None
            trajectory, recovery = with_recovery(arm, joints,
                                                 lambda q: _approached(given, arm, q))
        if recovery is not None:
            log.warning("move from outside the limits: %s", recovery.line())
        return controller.start_move(trajectory,
                                     present_ticks=tuple(int(v) for v in ticks),
                                     start_at=order.start_at, recovery=recovery)


def _approached(given: Trajectory, arm: Arm, start: tuple[float, ...]) -> Trajectory:
    """``given`` behind a joint-space approach from the ``start`` joints (rad) to its first
    sample (:func:`robodcn.workflow.files.with_approach`), counted in approach_samples."""
    trajectory = files.with_approach(given, arm, np.asarray(start, dtype=np.float64))
    if trajectory is not given:  # the samples prepended are the approach
        trajectory.approach_samples = len(trajectory.t) - len(given.t)
    return trajectory


__all__ = ["MoveOrder", "Parse", "Planning", "admit"]
