"""What ``robodcn run`` plays, as a library: a waypoints file's plan request, checked before
any bus I/O, and the trajectory to stream from the arm's present joints.

A waypoints file (:func:`robodcn.workflow.files.load_waypoints`) is planned from the present
joints with the file's ``[plan]`` options overridden by :class:`PlanOverrides`; a saved
Trajectory or JointTrajectory plays as saved after a joint-space approach to its first
sample (:func:`robodcn.workflow.files.with_approach`). A planner error raised while a file's
request is checked or planned names the file (:func:`naming_file`).

A waypoints file whose waypoints act (``gripper = "open" | "close"``, ``payload_kg``) plays
as legs (:func:`legs`): it is split at each waypoint with an action, each leg carrying its
payload (the file's or ``--payload``'s at the start, then each waypoint's ``payload_kg``
from there on); the arm comes to rest at the end of each before the waypoint's gripper
action runs. Every leg is planned and checked before anything moves (:func:`plan_legs`):
the first from the arm's present joints, each next from where the one before ends (its
last planned joints, at rest). A leg that cannot be planned raises the planner's error in
the file's terms (:func:`in_file_terms`): the file's waypoint numbers, and the file's field
that set the payload or duration (``waypoints[4].payload_kg``), not the leg's own.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from robodcn import messages
from robodcn.config import Arm
from robodcn.errors import InputError, PlanError, RobodcnError
from robodcn.planner import PlanRequest, Trajectory, plan_request
from robodcn.planner.recovery import Recovered, Recovery, with_recovery
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
    #: the tool limits, SI (None: the file's [plan] ones, else the arm's [tool] defaults).
    tool_speed: float | None = None
    tool_angular_speed: float | None = None
    tool_acceleration: float | None = None

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
    defaults to the arm's. Every field, and the path of every leg (:func:`legs`) from rest
    at its first waypoint with its payload, is checked here, before the bus opens; an error
    is in the file's terms (:func:`in_file_terms`). The real plan starts from the present
    joints, with an approach (:func:`plan_legs`)."""
    fields = wp.plan_fields(**{name: getattr(overrides, name) for name in overrides.given()})
    fields.setdefault("rate_hz", arm.bus.rate_hz)
    for key in ("method", "turn", "beta"):
        if isinstance(fields.get(key), list):
            fields[key] = tuple(fields[key])
    with naming_file(wp.source):
        PlanRequest(arm=arm, **fields)
    leg_list = legs(wp, fields, arm)
    for k, leg in enumerate(leg_list, start=1):
        if leg.last == leg.first:           # an action at the first waypoint: no path
            continue
        leg_fields = dict(leg.fields)
        rows = [tuple(wp.waypoints[leg.first]), *leg_fields.pop("waypoints")[1:]]
        try:
            plan_request(PlanRequest(arm=arm, waypoints=rows, **leg_fields))
        except RobodcnError as exc:
            raise in_file_terms(exc, leg, k, len(leg_list), wp.source) from None
    if arm.gripper is None:
        acting = [i for i, a in enumerate(wp.actions) if "gripper" in a]
        if acting:
            where = f"waypoints[{acting[0]}].gripper"
            raise InputError(f"{wp.source}: {where}: arm {arm.name!r} has no gripper (no "
                             "[gripper] in its config)", field=where,
                             value=wp.actions[acting[0]]["gripper"])
    return fields


@dataclass(frozen=True)
class Leg:
    """One leg of a waypoints file that acts: waypoints ``first``..``last`` (indices into
    the file), the PlanRequest keyword fields that plan it from the present joints
    (``waypoints``: the file's first waypoint for the first leg, else None — the present
    pose, where the last leg came to rest — then the leg's other waypoints), the payload
    carried on it (kg) and the gripper command at its last waypoint (None: none).

    ``payload_field`` and ``duration_field`` name the file's field that set the leg's payload
    (``waypoints[j].payload_kg``, ``plan.payload_kg``) and duration (``plan.duration``, shared
    among the legs); None when an override or the arm's default did."""

    first: int
    last: int
    fields: dict[str, Any]
    payload_kg: float
    gripper: str | None
    payload_field: str | None = None
    duration_field: str | None = None

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
    payload_field = _file_field(wp, fields, "payload_kg")
    duration_field = _file_field(wp, fields, "duration")
    out: list[Leg] = []
    first = 0
    for last in ends:
        if "payload_kg" in actions[first]:          # carried from this waypoint on
            payload = float(actions[first]["payload_kg"])
            payload_field = f"waypoints[{first}].payload_kg"
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
        out.append(Leg(first, last, leg, payload, actions[last].get("gripper"),
                       payload_field, duration_field))
        first = last
    return out


def _file_field(wp: WaypointsPlan, fields: dict[str, Any], key: str) -> str | None:
    """``plan.<key>`` when the request's ``key`` is the file's ``[plan]`` value."""
    given = key in wp.options and fields.get(key) == wp.options[key]
    return f"plan.{key}" if given else None


def _leg_trajectory(arm: Arm, leg: Leg, present: ArrayLike) -> Trajectory:
    from robodcn import present as present_pose

    fields = dict(leg.fields)
    return present_pose.plan_from_present(arm, None, fields.pop("waypoints"),
                                          joints=np.asarray(present, dtype=np.float64),
                                          **fields)


def plan_leg(arm: Arm, leg: Leg, present: ArrayLike, *, source: str) -> Trajectory:
    """The trajectory of ``leg`` from the ``present`` joints (k,) rad."""
    with naming_file(source):
        return _leg_trajectory(arm, leg, present)


def plan_legs(arm: Arm, leg_list: Sequence[Leg], present: ArrayLike, *, source: str,
              on_recovery: Callable[[Recovery], None] | None = None) -> list[Trajectory]:
    """Every leg's trajectory, planned before anything moves: the first from the
    ``present`` joints (k,) rad — behind a recovery when they are not acceptable as a
    start (:mod:`robodcn.planner.recovery`; ``on_recovery`` is told of it) — each next
    from the end of the one before (its last planned joints, at rest: where the arm will
    be, its goal already there).

    Every check the planner makes (reach, joint and tick limits, speed, acceleration, jerk,
    torque with the leg's payload) holds on every leg, or nothing is returned.

    Raises
    ------
    RobodcnError
        The first leg's planner error that fails, in the file's terms
        (:func:`in_file_terms`).
    """
    q = np.asarray(present, dtype=np.float64)
    out: list[Trajectory] = []
    recovery = None
    for k, leg in enumerate(leg_list, start=1):
        try:
            if k == 1:
                traj, recovery = with_recovery(
                    arm, q, lambda start, leg=leg: _leg_trajectory(arm, leg, start))
            else:
                traj = _leg_trajectory(arm, leg, q)
        except RobodcnError as exc:
            raise in_file_terms(exc, leg, k, len(leg_list), source) from None
        out.append(traj)
        q = traj.joints[-1]
    if recovery is not None and on_recovery is not None:
        on_recovery(recovery)
    return out


def leg_context(exc: RobodcnError) -> str:
    """Which leg an error of :func:`in_file_terms` is about: "leg 2 of 3 (waypoints 1..3)",
    or "" (a file played as one leg, or an error of no leg)."""
    k, count, first, last = getattr(exc, "leg", (1, 1, 0, 0))
    return "" if count == 1 else f"leg {k} of {count} (waypoints {first}..{last})"


def in_file_terms(exc: RobodcnError, leg: Leg, k: int, count: int,
                  source: str) -> RobodcnError:
    """``exc``, raised while planning leg ``k`` of ``count``, in the waypoints file's terms.

    A leg's waypoint i is the file's ``leg.first + i``: segments, waypoints and
    ``waypoints[i]`` fields are renumbered; the request's ``payload_kg`` and ``duration``
    become the file's field that set them (``Leg.payload_field``, ``Leg.duration_field``)
    when one did. ``leg`` is set on the error to ``(k, count, leg.first, leg.last)``; the
    message starts with the file and, for a file of several legs, the leg
    (:func:`leg_context`).
    """
    def renamed(path: str | None) -> str | None:
        if path == "payload_kg" and leg.payload_field is not None:
            return leg.payload_field
        if path == "duration" and leg.duration_field is not None:
            return leg.duration_field
        match = re.fullmatch(r"waypoints\[(\d+)\](.*)", path or "")
        return f"waypoints[{int(match[1]) + leg.first}]{match[2]}" if match else path

    def shifted(i: int | None) -> int | None:
        return None if i is None else i + leg.first

    exc.leg = (k, count, leg.first, leg.last)      # type: ignore[attr-defined]
    where = ": ".join(part for part in (source, leg_context(exc)) if part)
    if isinstance(exc, PlanError):
        v = exc.violation
        if v is not None:
            v = dataclasses.replace(
                v, field=renamed(v.field) or v.field, waypoint=shifted(v.waypoint),
                segment=None if v.segment is None else (v.segment[0] + leg.first,
                                                        v.segment[1] + leg.first))
            text = messages.describe_violation(v)
        else:
            text = exc.message
        new: RobodcnError = type(exc)(
            f"{where}: {text}", field=renamed(exc.field), value=exc.value, sample=exc.sample,
            t=exc.t, pose=exc.pose, joint=exc.joint, violation=v,
            waypoint=shifted(exc.waypoint))
    else:
        new = exc
        exc.message = f"{where}: {exc.message}"
        exc.args = (exc.message,)
        exc.field = renamed(exc.field)
    new.leg = exc.leg           # type: ignore[attr-defined]
    return new


def trajectory_to_run(arm: Arm, kind: str, loaded: dict[str, Any] | Trajectory,
                      present: ArrayLike, *, source: str) -> Recovered:
    """The trajectory ``run`` streams from the ``present`` joints (k,) rad: the waypoints
    file's fields (:func:`waypoints_fields`) planned from there, or a saved trajectory
    after a joint-space approach to its first sample; either behind a recovery when the
    present is not acceptable as a start (:mod:`robodcn.planner.recovery`)."""
    from robodcn import present as present_pose

    q = np.asarray(present, dtype=np.float64)
    if kind == "waypoints":
        assert isinstance(loaded, dict)
        fields = dict(loaded)
        with naming_file(source):
            return present_pose.plan_recovering(arm, None, fields.pop("waypoints"),
                                                joints=q, **fields)
    assert isinstance(loaded, Trajectory)
    given = loaded
    return with_recovery(arm, q, lambda start: with_approach(given, arm, np.asarray(start)))


__all__ = ["KINDS", "Leg", "PlanOverrides", "in_file_terms", "leg_context", "legs",
           "naming_file", "plan_leg", "plan_legs", "trajectory_to_run", "waypoints_fields"]
