"""What a retarget asks for: the goals after the commanded state and the plan fields.

A replacement leaves from the commanded moving state and never visits its first waypoint
(issue 17 §2; as a new trajectory sent to ROS's joint_trajectory_controller replaces the
old one from where the controller is): with two or more waypoints the first is the
caller's view of where the arm is — by the time the switch comes the arm is past it — and
is dropped; a single waypoint is the goal from the present (commanded) state. Waypoints
given as a list whose first entry is None say the same (None: the switch pose).

Every plan field of a :class:`~robodcn.planner.PlanRequest` is honoured or refused
(InputError naming the field): the geometry's (method, β, turn, blend, elbow) by the
planner, ``duration`` by the time law (a number: the new motion takes that long from the
switch; "auto": as fast as the limits allow), ``profile`` "optimal" only (a uniform law
starts from rest, the replacement starts moving), ``rate_hz`` the running stream's,
``start_joints`` / ``start_state`` none (the start is the commanded state), ``payload_kg`` by
the torque limits of every law of the replacement (not told: the running move's payload),
``tool_speed``, ``tool_angular_speed``, ``tool_acceleration`` likewise by every law's tool
limits (not told: the running move's).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn.config import Arm, ToolSpec
from robodcn.contract import TOOL_FIELDS
from robodcn.errors import InputError
from robodcn.planner import PlanRequest, plan, plan_request

Target = PlanRequest | Sequence[Any]

#: the time law of a replacement (it starts from a moving state)
PROFILE = "optimal"
#: plan keywords a replacement takes its start from (refused when given)
START_FIELDS = ("start_joints", "start_state")


@dataclasses.dataclass(frozen=True)
class Replacement:
    """A retarget's goals and plan fields: ``goals`` (poses after the switch pose),
    ``duration`` (seconds from the switch, or "auto"), and either the ``request`` the
    geometry is planned from (its waypoints replaced) or plan keywords ``options``."""

    arm: Arm
    goals: tuple[tuple[float, ...], ...]
    duration: float | str = "auto"
    request: PlanRequest | None = None
    options: dict[str, Any] = dataclasses.field(default_factory=dict)

    @classmethod
    def of(cls, arm: Arm, target: Target, options: dict[str, Any],
           rate_hz: float) -> Replacement:
        """The replacement ``target`` asks for on a stream at ``rate_hz`` (module doc).

        Raises
        ------
        InputError
            a field a replacement cannot honour (``profile``, ``rate_hz``, ``start_joints``,
            ``start_state``), or no goal."""
        if isinstance(target, PlanRequest):
            _check_fields(target.profile, target.rate_hz, rate_hz,
                          {f: getattr(target, f) for f in START_FIELDS})
            wp = target.waypoints
            goals = wp[1:] if len(wp) > 1 else wp
            return cls(arm, tuple(tuple(p) for p in goals), target.duration, request=target)
        opts = dict(options)
        _check_fields(opts.pop("profile", PROFILE), opts.pop("rate_hz", rate_hz), rate_hz,
                      {f: opts.pop(f, None) for f in START_FIELDS})
        duration = opts.pop("duration", "auto")
        wp = list(target)
        goals = wp[1:] if wp and wp[0] is None else wp
        if not goals or any(g is None for g in goals):
            raise InputError("a retarget needs a goal pose after the present one (only the "
                             "first waypoint may be None)", field="waypoints", value=wp)
        return cls(arm, tuple(tuple(float(v) for v in g) for g in goals), duration,
                   options=opts)

    @property
    def tool(self) -> tuple[bool, dict[str, float | None]]:
        """(told, the tool fields): a request's ``tool_speed``, ``tool_angular_speed`` and
        ``tool_acceleration`` (told: what it asks, None = no such limit); keywords: those
        given (told when any is; the others None). Not told: the running move's stand."""
        if self.request is not None:
            return True, {f: getattr(self.request, f) for f in TOOL_FIELDS}
        told = any(f in self.options for f in TOOL_FIELDS)
        return told, {f: self.options.get(f) for f in TOOL_FIELDS}

    @property
    def payload_kg(self) -> float | None:
        """The payload the replacement says it carries (the request's ``payload_kg``, or the
        ``payload_kg`` keyword), None when not told: the running move's stands."""
        if self.request is not None:
            return self.request.payload_kg
        told = self.options.get("payload_kg")
        return None if told is None else float(told)

    def geometry(self, q: NDArray[np.float64], here: tuple[float, ...], rate_hz: float,
                 duration: float) -> NDArray[np.float64]:
        """Joint samples of the planner's path from joints ``q`` (at pose ``here``) through
        the goals: geometry only (a uniform quintic of ``duration`` at ``rate_hz``, re-timed
        afterwards). Raises the planner's errors."""
        start = tuple(float(v) for v in q)
        waypoints = (tuple(here), *self.goals)
        # geometry only: a tool limit is the time law's (the slow quintic need not keep it,
        # nor the arm's [tool] defaults)
        slow = {"profile": "quintic", "rate_hz": rate_hz, "duration": duration,
                **dict.fromkeys(TOOL_FIELDS)}
        arm = dataclasses.replace(self.arm, tool=ToolSpec()) if self.arm.tool.to_dict() \
            else self.arm
        if self.request is not None:
            request = dataclasses.replace(self.request, arm=arm, waypoints=waypoints,
                                          start_joints=start, start_state=None, **slow)
            return plan_request(request).joints
        return plan(arm, list(waypoints), start_joints=start,
                    **{**self.options, **slow}).joints


def _check_fields(profile: Any, rate: Any, stream_rate: float, starts: dict[str, Any]) -> None:
    if profile != PROFILE:
        raise InputError(f"a replacement leaves from the moving state and is timed by the "
                         f"profile {PROFILE!r}; profile {profile!r} starts from rest (stop the "
                         "move first, or use the optimal profile)", field="profile",
                         value=profile)
    if rate is not None and float(rate) != float(stream_rate):
        raise InputError(f"a replacement streams at the running move's rate "
                         f"({stream_rate:g} Hz), got rate_hz {rate!r}", field="rate_hz",
                         value=rate)
    for name, value in starts.items():
        if value is not None:
            raise InputError(f"a replacement starts from the running move's commanded state: "
                             f"{name} cannot be given", field=name, value=value)


__all__ = ["PROFILE", "START_FIELDS", "Replacement", "Target"]
