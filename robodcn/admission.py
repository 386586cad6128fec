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
   infeasible approach is refused now (422) and the record shows what will run;
4. **start** it with the ticks read (the executor does not read them again).

A replacement (``replace`` while a move runs) skips 2–4: it is planned from the running
move's commanded state (:meth:`ArmController.replace_move`).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass

from robodcn import servo_units
from robodcn.controller import ArmController
from robodcn.errors import InputError
from robodcn.moves import MoveRecord
from robodcn.planner import PlanRequest, Trajectory
from robodcn.present import plan_from_present
from robodcn.workflow import files

#: How a surface paces planning (the HTTP service takes turns on a lock per plan size):
#: a context manager for the request about to be planned.
Planning = Callable[[PlanRequest], AbstractContextManager[object]]


def _unpaced(request: PlanRequest) -> AbstractContextManager[object]:
    return contextlib.nullcontext()


@dataclass(frozen=True)
class MoveOrder:
    """What a surface asks the arm to do: plan ``request`` from where the arm is, or play a
    given ``trajectory`` (exactly one of the two); ``replace``: take over the running move
    in flight (waypoints only) instead of refusing while one runs."""

    request: PlanRequest | None = None
    trajectory: Trajectory | None = None
    replace: bool = False

    def __post_init__(self) -> None:
        if (self.request is None) == (self.trajectory is None):
            raise InputError("a move order takes a plan request or a trajectory, not both "
                             "or neither", field="order", value=None)


def admit(controller: ArmController, order: MoveOrder, *,
          planning: Planning = _unpaced) -> MoveRecord:
    """Start ``order`` on ``controller``: the new move's record (queued or running).

    Raises BusyError (409) while another move runs or is being admitted (unless ``replace``),
    NoMoveError when a replacement finds nothing running any more, InputError for a given
    trajectory with ``replace`` while a move runs, the planner's errors (422, nothing
    moves) and BusError when the servos cannot be read.
    """
    if order.replace and controller.busy:
        if order.request is None:
            raise InputError("replace takes waypoints: a given trajectory cannot take over a "
                             "running move in flight (stop it first)", field="replace",
                             value=True)
        with planning(order.request):
            return controller.replace_move(order.request)
    arm = controller.arm
    with controller.admitting():
        ticks = controller.present_ticks()
        joints = servo_units.ticks_to_radians(ticks[None, :], arm.servos)[0]
        if order.request is not None:
            with planning(order.request):
                trajectory = plan_from_present(arm, None, order.request, joints=joints)
        else:
            given = order.trajectory
            assert given is not None
            trajectory = files.with_approach(given, arm, joints)
            if trajectory is not given:  # the samples prepended are the approach
                trajectory.approach_samples = len(trajectory.t) - len(given.t)
        return controller.start_move(trajectory,
                                     present_ticks=tuple(int(v) for v in ticks))


__all__ = ["MoveOrder", "Planning", "admit"]
