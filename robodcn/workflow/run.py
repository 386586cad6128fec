"""What ``robodcn run`` plays, as a library: a waypoints file's plan request, checked before
any bus I/O, and the trajectory to stream from the arm's present joints.

A waypoints file (:func:`robodcn.workflow.files.load_waypoints`) is planned from the present
joints with the file's ``[plan]`` options overridden by :class:`PlanOverrides`; a saved
Trajectory or JointTrajectory plays as saved after a joint-space approach to its first
sample (:func:`robodcn.workflow.files.with_approach`). A planner error raised while a file's
request is checked or planned names the file (:func:`naming_file`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from robodcn.config import Arm
from robodcn.errors import RobodcnError
from robodcn.planner import PlanRequest, Trajectory, plan_request
from robodcn.workflow.files import WaypointsPlan, with_approach

#: The kinds of file ``run`` plays (:func:`robodcn.workflow.files.file_kind`).
KINDS = ("waypoints", "trajectory", "joint_trajectory")


@dataclass(frozen=True)
class PlanOverrides:
    """Plan fields that override a waypoints file's ``[plan]`` (None: the file's, else the
    contract's default). ``method``/``turn``/``beta`` are one value or one per segment."""

    method: str | tuple[str, ...] | None = None
    turn: str | tuple[str, ...] | None = None
    beta: float | tuple[float, ...] | None = None
    duration: float | str | None = None
    profile: str | None = None
    blend: bool | None = None
    rate_hz: float | None = None
    #: kg at the tool point (None: the file's [plan] payload_kg, else the arm's).
    payload_kg: float | None = None

    def given(self) -> tuple[str, ...]:
        """The names of the fields that are set."""
        return tuple(f.name for f in dataclasses.fields(self)
                     if getattr(self, f.name) is not None)


@contextmanager
def naming_file(path: str) -> Iterator[None]:
    """Prefix a planner error (which names waypoints[i]) with the waypoints file."""
    try:
        yield
    except RobodcnError as exc:
        if not exc.message.startswith(path):
            exc.message = f"{path}: {exc.message}"
        raise


def waypoints_fields(wp: WaypointsPlan, arm: Arm, overrides: PlanOverrides
                     ) -> dict[str, Any]:
    """The PlanRequest keyword fields of a waypoints file with ``overrides``; the rate
    defaults to the arm's. Every field, and the path through the waypoints, is checked here
    (the real plan starts from the present joints, with an approach)."""
    fields = wp.plan_fields(**{name: getattr(overrides, name) for name in overrides.given()})
    fields.setdefault("rate_hz", arm.bus.rate_hz)
    for key in ("method", "turn", "beta"):
        if isinstance(fields.get(key), list):
            fields[key] = tuple(fields[key])
    with naming_file(wp.source):
        plan_request(PlanRequest(arm=arm, **fields))
    return fields


def trajectory_to_run(arm: Arm, kind: str, loaded: dict[str, Any] | Trajectory,
                      present: ArrayLike, *, source: str) -> Trajectory:
    """The trajectory ``run`` streams from the ``present`` joints (k,) rad: the waypoints
    file's fields (:func:`waypoints_fields`) planned from there, or a saved trajectory
    after a joint-space approach to its first sample."""
    from robodcn import present as present_pose

    q = np.asarray(present, dtype=np.float64)
    if kind == "waypoints":
        assert isinstance(loaded, dict)
        fields = dict(loaded)
        with naming_file(source):
            return present_pose.plan_from_present(arm, None, fields.pop("waypoints"),
                                                  joints=q, **fields)
    assert isinstance(loaded, Trajectory)
    return with_approach(loaded, arm, q)


__all__ = ["KINDS", "PlanOverrides", "naming_file", "trajectory_to_run", "waypoints_fields"]
