"""What ``robodcn run`` plays, as a library: a waypoints file's plan request, checked before
any bus I/O, and the trajectory to stream from the arm's present joints.

A waypoints file (:func:`robodcn.workflow.files.load_waypoints`) is planned from the present
joints with the file's ``[plan]`` options overridden by :class:`PlanOverrides`; a saved
Trajectory or JointTrajectory plays as saved after a joint-space approach to its first
sample (:func:`robodcn.workflow.files.with_approach`). A planner error raised while a file's
request is checked or planned names the file (:func:`naming_file`).

A waypoints file whose waypoints act (``gripper = "open" | "close"``, ``payload_kg``) plays
as legs (:func:`legs`): it is split at each waypoint with an action; each leg is planned
from the arm's present joints when it starts (the first from wherever the arm is, the
next from rest at the waypoint the last one ended on) with the payload carried on it
(the file's or ``--payload``'s at the start, then each waypoint's ``payload_kg`` from there
on), streamed, and the arm comes to rest before the waypoint's gripper action runs.
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


@dataclass(frozen=True)
class Leg:
    """One leg of a waypoints file that acts: waypoints ``first``..``last`` (indices into
    the file), the PlanRequest keyword fields that plan it from the present joints
    (``waypoints``: the file's first waypoint for the first leg, else None — the present
    pose, where the last leg came to rest — then the leg's other waypoints), the payload
    carried on it (kg) and the gripper command at its last waypoint (None: none)."""

    first: int
    last: int
    fields: dict[str, Any]
    payload_kg: float
    gripper: str | None

    def to_dict(self) -> dict[str, Any]:
        return {"waypoints": [self.first, self.last], "payload_kg": self.payload_kg,
                "gripper": self.gripper}


def _segment_slice(value: Any, first: int, last: int) -> Any:
    """A per-segment tuple cut to segments first..last-1; one value as it is."""
    return tuple(value[first:last]) if isinstance(value, tuple | list) else value


def legs(wp: WaypointsPlan, fields: dict[str, Any], arm: Arm) -> list[Leg]:
    """The legs of ``wp`` (module docstring), planned with ``fields`` (the file's checked
    request fields, :func:`waypoints_fields`). A file without actions is one leg. A numeric
    duration is shared among the legs in proportion to their segments."""
    n = len(wp.waypoints)
    actions = list(wp.actions) or [{} for _ in range(n)]
    ends = [i for i, a in enumerate(actions) if a and i < n - 1] + [n - 1]
    payload = float(fields.get("payload_kg", arm.payload_kg))
    duration = fields.get("duration")
    out: list[Leg] = []
    first = 0
    for last in ends:
        if "payload_kg" in actions[first]:          # carried from this waypoint on
            payload = float(actions[first]["payload_kg"])
        leg = dict(fields)
        for key in ("method", "turn", "beta"):
            if key in leg:
                leg[key] = _segment_slice(leg[key], first, last)
                if leg[key] == ():                  # the approach to waypoint 0 alone
                    del leg[key]
        rows = [tuple(float(v) for v in row) for row in wp.waypoints[first:last + 1]]
        leg["waypoints"] = rows if first == 0 else [None, *rows[1:]]
        if last == first:
            leg.pop("duration", None)
        elif isinstance(duration, int | float) and not isinstance(duration, bool):
            leg["duration"] = float(duration) * (last - first) / (n - 1)
        leg["payload_kg"] = payload
        out.append(Leg(first, last, leg, payload, actions[last].get("gripper")))
        first = last
    return out


def plan_leg(arm: Arm, leg: Leg, present: ArrayLike, *, source: str) -> Trajectory:
    """The trajectory of ``leg`` from the ``present`` joints (k,) rad."""
    from robodcn import present as present_pose

    fields = dict(leg.fields)
    with naming_file(source):
        return present_pose.plan_from_present(arm, None, fields.pop("waypoints"),
                                              joints=np.asarray(present, dtype=np.float64),
                                              **fields)


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


__all__ = ["KINDS", "Leg", "PlanOverrides", "legs", "naming_file", "plan_leg",
           "trajectory_to_run", "waypoints_fields"]
