"""PlanRequest and StartState: a plan's input, typed, frozen and validated on construction.

Every range, choice and default comes from the contract (:mod:`.fields`, :mod:`.checks`):
one source for the Python API, the HTTP body and the CLI; errors name the field path
(``waypoints[2][1]``, ``start_joints[0]``). Construction accepts lists and arrays where the
fields hold tuples (waypoints, per-segment lists, joints) and stores them as tuples of floats.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn._checks import is_real
from robodcn.config import Arm, arm_from_dict
from robodcn.contract import checks
from robodcn.contract.checks import fail
from robodcn.contract.fields import BETA_METHODS, DEFAULTS
from robodcn.errors import BetaIgnoredWarning

__all__ = ["PlanRequest", "StartState"]


def _floats(value: object) -> tuple[float, ...] | None:
    """None, or a list/array/tuple as a tuple of Python floats (anything else unchanged: the
    contract's checks name it)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, list | tuple):
        return tuple(float(v) if is_real(v) else v for v in value)
    return value  # type: ignore[return-value]


@dataclass(frozen=True)
class StartState:
    """A moving joint state to plan from (a retarget's switch sample), SI units.

    Attributes
    ----------
    joints : (k,) joint angles, rad, each within its joint's limits
    velocities : (k,) joint velocities, rad/s, each within its joint's velocity limit
        (None: at rest)
    accelerations : (k,) joint accelerations, rad/s², each within its acceleration limit
        (None: zero)

    Checked against an arm by :func:`robodcn.contract.check_start_state` (PlanRequest does
    that); lists and arrays are stored as tuples of floats.
    """

    joints: tuple[float, ...]
    velocities: tuple[float, ...] | None = None
    accelerations: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        for name in ("joints", "velocities", "accelerations"):
            object.__setattr__(self, name, _floats(getattr(self, name)))

    @property
    def moving(self) -> bool:
        """Whether any velocity or acceleration is non-zero."""
        return any(v != 0.0 for v in (*(self.velocities or ()), *(self.accelerations or ())))

    def arrays(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """(q, q̇, q̈) as float arrays (zeros where not given)."""
        q = np.asarray(self.joints, dtype=np.float64)
        zero = np.zeros_like(q)
        v = zero if self.velocities is None else np.asarray(self.velocities, dtype=np.float64)
        a = zero if self.accelerations is None else np.asarray(self.accelerations,
                                                               dtype=np.float64)
        return q, v, a

    def to_dict(self) -> dict[str, list[float]]:
        q, v, a = self.arrays()
        return {"joints": q.tolist(), "velocities": v.tolist(), "accelerations": a.tolist()}


#: A waypoint: (x, y, θ), or (x, y, z, pitch) for an arm with a base yaw.
Pose = tuple[float, ...]


@dataclass(frozen=True)
class PlanRequest:
    """Everything a plan depends on; validated on construction (Ruckig-style input data).

    Attributes
    ----------
    arm : Arm
    waypoints : 2 ≤ m ≤ MAX_WAYPOINTS poses (x, y, θ), metres and radians (m = 1 with
        start_joints or start_state: the path runs from the pose there); on a 2-joint
        (position-only) arm (x, y) is accepted too (stored with θ = 0) and θ plays no part
        in the plan; an arm with a base yaw (``arm.yawed``) takes (x, y, z, pitch) in its
        base frame (the interpolation runs in the arm's plane, robodcn.planner.yawed)
    method : "sclerp" | "kenlerp" | "seplerp" | "dlb", or one per segment
    beta : KenLERP bias within contract.BETA_RANGE (0 SEP-LERP, 1 ScLERP, > 1 extrapolates),
        or one per segment (each segment interpolated with its own β). One β other than 1
        with no KenLERP segment warns (BetaIgnoredWarning); so does, per segment, a β other
        than 1 on a segment whose method does not use it
    turn : "shortest" | "ccw" | "cw", or one per segment
    duration : total seconds (> 0) or "auto"
    profile : "optimal" (default: the time-optimal law along the path within the velocity,
        acceleration and — where set — jerk limits, robodcn.path_timing) | "linear" |
        "quintic" | "trapezoid" (uniform laws)
    rate_hz : sample rate, 1..1000 Hz; None (the default) is the arm's ``[bus] rate_hz``
        (a float once constructed)
    blend : pass through via points with continuous velocity instead of stopping
    start_joints : the arm's present joints (k,), each within its joint limits, or None
        (then the plan starts at the IK of waypoints[0])
    elbow : "up" | "down" IK branch, or None for the arm's configured one
    start_state : a moving :class:`StartState` (joints, velocities, accelerations) to start
        from, or None. The path then runs from the pose FK(start_state.joints) through every
        waypoint (waypoints[0] is not repeated when it is that pose, within 0.1 mm and
        0.01°), and is timed from the moving state (profile "optimal" only; exclusive with
        start_joints). A dict {"joints": …, "velocities": …, "accelerations": …} is accepted.
    payload_kg : mass (kg, ≥ 0) at the tool point, for the torque limits the timing keeps;
        None (the default) is the arm's ``[dynamics] payload_kg`` (a float once constructed)
    tool_speed, tool_angular_speed, tool_acceleration : the tool point's largest linear
        speed (m/s), orientation rate (rad/s: θ's, or pitch's and yaw's) and acceleration
        along its path (m/s²), each > 0 and at most the arm's ``[tool]`` ceiling; None (the
        default) is the arm's ``[tool]`` default (None there too: no such limit)

    Defaults: :data:`robodcn.contract.DEFAULTS`. Lists given for method, beta, turn,
    waypoints and start_joints are stored as tuples.
    """

    arm: Arm
    waypoints: tuple[Pose, ...]
    method: str | tuple[str, ...] = DEFAULTS.method
    beta: float | tuple[float, ...] = DEFAULTS.beta
    turn: str | tuple[str, ...] = DEFAULTS.turn
    duration: float | str = DEFAULTS.duration
    profile: str = DEFAULTS.profile
    rate_hz: float | None = DEFAULTS.rate_hz
    blend: bool = DEFAULTS.blend
    start_joints: tuple[float, ...] | None = DEFAULTS.start_joints
    elbow: str | None = DEFAULTS.elbow
    start_state: StartState | None = DEFAULTS.start_state
    payload_kg: float | None = DEFAULTS.payload_kg
    tool_speed: float | None = DEFAULTS.tool_speed
    tool_angular_speed: float | None = DEFAULTS.tool_angular_speed
    tool_acceleration: float | None = DEFAULTS.tool_acceleration

    def __post_init__(self) -> None:
        # frozen: the checked values go straight into the instance dict (what
        # object.__setattr__ does for a dataclass without slots, ~15 times per request)
        values = self.__dict__
        if not isinstance(self.arm, Arm):
            raise fail("arm", f"must be an Arm (robodcn.load_arm), got {type(self.arm)!r}",
                       self.arm)
        # a lone waypoint needs a start: checked last, once the start fields are
        wp = checks.check_waypoints(self.waypoints, self.arm, start=True)
        values["waypoints"] = wp
        segments = max(1, len(wp) - 1)
        values["method"] = checks.check_per_segment("method", self.method, segments)
        values["turn"] = checks.check_per_segment("turn", self.turn, segments)
        values["beta"] = checks.check_per_segment("beta", self.beta, segments)
        if self.rate_hz is None:
            values["rate_hz"] = self.arm.bus.rate_hz
        if self.payload_kg is None:
            values["payload_kg"] = self.arm.payload_kg
        for name in ("profile", "rate_hz", "blend", "elbow", "payload_kg"):
            values[name] = checks.check_field(name, values[name])
        tool = self.arm.tool
        for name, default in (("tool_speed", tool.speed),
                              ("tool_angular_speed", tool.angular_speed),
                              ("tool_acceleration", tool.acceleration)):
            if values[name] is None:  # the usual case: the arm's default (none: no limit)
                values[name] = default
                continue
            value = checks.check_field(name, values[name])
            values[name] = checks.check_tool_ceiling(name, value, self.arm)
        values["duration"] = checks.check_duration(self.duration, self.rate_hz, segments)
        values["start_joints"] = checks.check_start_joints(self.start_joints, self.arm)
        state = checks.check_start_state(self.start_state, self.arm)
        values["start_state"] = None if state is None else StartState(*state)
        if self.start_state is not None:
            if self.start_joints is not None:
                raise fail("start_state", "cannot be given with start_joints (both say where "
                           "the plan starts): give one", "start_state")
            if self.profile != "optimal" and self.start_state.moving:
                raise fail("start_state", f"a moving start needs profile \"optimal\" (the "
                           f"uniform law {self.profile!r} starts from rest)", self.profile)
        checks.check_waypoint_count(wp, self.start_joints is not None
                                    or self.start_state is not None)
        self._warn_ignored_beta()

    def _warn_ignored_beta(self) -> None:
        """BetaIgnoredWarning: one β ≠ 1 that no segment reads, or per-segment β ≠ 1 on
        segments whose method does not read it (``segments`` on the warning)."""
        if type(self.beta) is float and self.beta == 1.0:
            return  # the default: no segment has a β ≠ 1 to ignore
        ignored = [j for j in range(self.segments) if self.segment_beta(j) != 1.0
                   and self.segment_method(j) not in BETA_METHODS]
        if isinstance(self.beta, float):
            if len(ignored) < self.segments:
                return  # one β for the plan: it is used if any segment is KenLERP
            used = ", ".join(sorted({self.segment_method(j) for j in ignored}))
            text = (f"beta = {self.beta:g} has no effect: method {used} does not use it (only "
                    "kenlerp does)")
        elif ignored:
            which = ", ".join(f"{j} (β = {self.beta[j]:g}, method {self.segment_method(j)})"
                              for j in ignored[:5])
            if len(ignored) > 5:  # a long plan: name the first few
                which += f", … ({len(ignored)} segments)"
            text = (f"beta has no effect on segment{'s' if len(ignored) > 1 else ''} {which}: "
                    "only kenlerp uses it")
        else:
            return
        warnings.warn(BetaIgnoredWarning(text, method=self.method, segments=tuple(ignored)),
                      stacklevel=4)

    @property
    def tool_limited(self) -> bool:
        """Whether any tool limit (speed, angular speed, acceleration) applies."""
        return (self.tool_speed is not None or self.tool_angular_speed is not None
                or self.tool_acceleration is not None)

    @property
    def waypoints_array(self) -> NDArray[np.float64]:
        """Waypoints as an (m, 3) array ((m, 4) for an arm with a base yaw)."""
        return np.array(self.waypoints, dtype=np.float64)

    @property
    def segments(self) -> int:
        """Path segments: one per pair of waypoints; a lone waypoint's one from the start."""
        return max(1, len(self.waypoints) - 1)

    @property
    def branch(self) -> str:
        """The IK branch this plan uses: ``elbow``, or the arm's configured one."""
        return self.elbow if self.elbow is not None else self.arm.elbow

    @property
    def position_only(self) -> bool:
        """A 2-joint arm: θ plays no part."""
        return self.arm.dof == 2

    def segment_method(self, j: int) -> str:
        return self.method if isinstance(self.method, str) else self.method[j]

    def segment_turn(self, j: int) -> str:
        return self.turn if isinstance(self.turn, str) else self.turn[j]

    def segment_beta(self, j: int) -> float:
        return self.beta if isinstance(self.beta, float) else self.beta[j]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (the arm embedded in SI keys, see Arm.to_dict)."""
        return {"arm": self.arm.to_dict(), "arm_source": self.arm.source,
                "waypoints": [list(w) for w in self.waypoints],
                "method": self.method if isinstance(self.method, str) else list(self.method),
                "beta": self.beta if isinstance(self.beta, float) else list(self.beta),
                "turn": self.turn if isinstance(self.turn, str) else list(self.turn),
                "duration": self.duration, "profile": self.profile, "rate_hz": self.rate_hz,
                "blend": self.blend,
                "start_joints": None if self.start_joints is None else list(self.start_joints),
                "elbow": self.elbow,
                "start_state": None if self.start_state is None else self.start_state.to_dict(),
                "payload_kg": self.payload_kg, "tool_speed": self.tool_speed,
                "tool_angular_speed": self.tool_angular_speed,
                "tool_acceleration": self.tool_acceleration}

    @classmethod
    def from_dict(cls, data: dict[str, Any], arm: Arm | None = None) -> PlanRequest:
        """Inverse of :meth:`to_dict`; ``arm`` overrides the embedded arm.

        The request fields are parsed as an HTTP body is
        (:func:`robodcn.contract.parse_request`); an absent ``rate_hz`` or ``payload_kg`` is
        the arm's.
        """
        if not isinstance(data, dict):
            raise fail("request", "must be an object", data)
        data = dict(data)
        embedded = data.pop("arm", None)
        source = data.pop("arm_source", "<json>")
        if arm is None:
            if embedded is None:
                raise fail("request.arm", "is missing: pass arm=", None)
            arm = arm_from_dict(embedded, source=str(source))
        with warnings.catch_warnings():
            # The warning was given when the request was made; a round trip repeats nothing.
            warnings.simplefilter("ignore", BetaIgnoredWarning)
            return cls(arm=arm, **checks.check_body(data))
