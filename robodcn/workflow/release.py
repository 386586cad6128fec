"""The gravity guard: every path that switches torque off on an arm under gravity.

Switching torque off leaves a vertical arm (the OpenMANIPULATOR-X) to fall — the classic
end-of-run drop its users report (shared/omx.md). Torque goes off in many ways: ``torque
off``, a servo REBOOT (the servo comes back with torque off), the start of a calibration or
of a teach session without float (a hand moves the arm), the EEPROM writes of ``servo
set-id``/``set-baud`` (the servo refuses them while torque is on). Every one of them goes
through :func:`release`, with the action itself as ``switch_off``:

1. :func:`check_release`: whether the action drops the arm — gravity (a chain in a vertical
   plane, ``[dynamics]`` g ≠ 0) loads one of the joints whose torque goes off (one holding
   at least :data:`LOADED_NM` at the present pose; a joint whose torque is off already, the
   base yaw, a gripper or a horizontal arm drop nothing);
2. without confirmation (``--yes`` / ``"confirm": true``) a
   :class:`~robodcn.errors.GravityReleaseError` (:func:`refusal`: exit 2 / HTTP 409
   ``gravity_release``) naming those joints, the torque each holds, and whether the arm is
   lowered first or must be held — before anything moves or torque changes;
3. confirmed, the arm is first lowered to its rest pose (``[arm.rest]``), planned from the
   present joints (:func:`robodcn.plan`) and streamed (:func:`robodcn.execute`), and torque
   goes off only once it has arrived; a lowering that stops short (a collision, a fault, a
   stop request) leaves torque on and the result says so. Where it cannot be lowered (no
   rest pose, a lowering the planner or the streamer refuses, e.g. from outside the joint
   limits or with a servo in alert) the user is told to hold it (``warn``) and torque goes
   off: a confirmed release always releases.

:func:`hold` is the way back: torque on in position mode with Goal Position = Present
Position, where the arm is — how a calibration or a teach session ends on an arm under
gravity, finished, aborted or failed.

Surfaces: ``robodcn torque off|reboot|calibrate|teach|servo set-id|set-baud`` and
``--release`` (:mod:`robodcn.cli.releasing`), HTTP ``POST /v1/torque`` and ``POST
/v1/reboot`` (:mod:`robodcn.servo_admin`) — each maps GravityReleaseError to its warning
and shows :class:`ReleaseResult`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn.bus import OPERATING_MODE_POSITION, ServoBus, describe_hardware_error
from robodcn.config import Arm
from robodcn.errors import (
    BusError,
    GravityReleaseError,
    HardwareAlertError,
    InputError,
    PlanError,
    StartMismatchError,
    StoppedError,
)
from robodcn.planner import Trajectory, plan
from robodcn.planner.recovery import Recovery, with_recovery
from robodcn.present import present_joints
from robodcn.stream import ExecutionReport, execute
from robodcn.workflow.float_teach import gravity_torques, has_gravity
from robodcn.workflow.poses import tool_pose

log = logging.getLogger("robodcn.workflow")

#: A joint holding less than this against gravity does not count as loaded (N·m).
LOADED_NM = 1e-3
#: Lowering outcomes after which the arm is at rest on the rest pose (every sample sent).
ARRIVED = ("done", "degraded")
#: How long the lowering waits, after its last sample, for the arm to arrive on the rest
#: pose before torque goes off (s; the streamer's ``settle``): a stream that fell behind
#: on a loaded host would otherwise let go of an arm still above its support.
SETTLE_S = 1.0


@dataclass(frozen=True)
class ReleaseCheck:
    """What torque off would do to the arm at the present joints.

    falls : gravity loads the arm (it would fall: even a balanced pose is unstable);
    joints : the joints that hold a torque there (the chain's when unknown);
    joint_names, holding_torque_nm : every joint (joint order) and the torque it holds
    there, N·m (None when the arm has no masses to compute it from); rest : the rest pose,
    if the arm has one.
    """

    arm: str
    falls: bool
    joints: tuple[str, ...]
    joint_names: tuple[str, ...]
    holding_torque_nm: tuple[float, ...] | None
    rest: tuple[float, ...] | None

    def to_dict(self) -> dict[str, Any]:
        return {"arm": self.arm, "falls": self.falls, "joints": list(self.joints),
                "joint_names": list(self.joint_names),
                "holding_torque_nm": None if self.holding_torque_nm is None
                else list(self.holding_torque_nm),
                "rest": None if self.rest is None else list(self.rest)}


@dataclass(frozen=True)
class ReleaseResult:
    """What :func:`release` did: check (before anything moved); lowered (the arm was
    lowered to its rest pose first); lowering (that move's report, None if none);
    released (torque went off); released_ids; hold (why an arm that falls could not be
    lowered first, so the user had to hold it; None otherwise)."""

    check: ReleaseCheck
    lowered: bool
    lowering: ExecutionReport | None
    released: bool
    released_ids: tuple[int, ...]
    hold: str | None = None
    #: The recovery that opened the lowering, from outside the joint limits
    #: (:mod:`robodcn.planner.recovery`); None without one.
    recovery: Recovery | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"check": self.check.to_dict(), "lowered": self.lowered,
                "lowering": None if self.lowering is None else self.lowering.to_dict(),
                "released": self.released, "released_ids": list(self.released_ids),
                "hold": self.hold,
                "recovery": None if self.recovery is None else self.recovery.to_dict()}


def _released_joints(arm: Arm, ids: Collection[int] | None) -> tuple[str, ...]:
    """The arm's joints whose servos are among ``ids`` (None: every joint)."""
    if ids is None:
        return arm.joint_names
    chosen = set(ids)
    return tuple(j.name for j in arm.joints if j.servo.id in chosen)


def check_release(arm: Arm, joints: ArrayLike, ids: Collection[int] | None = None
                  ) -> ReleaseCheck:
    """Whether torque off on the servos ``ids`` (None: every joint's) drops ``arm`` at
    ``joints`` (rad, joint order), and why: it falls when gravity loads one of those
    joints (one holding at least :data:`LOADED_NM`, or any chain joint when the arm has
    no masses to tell). Servos that are no joint of the arm (a gripper) load nothing."""
    q = _checks.as_float_array("joints", joints)
    if q.shape != (arm.dof,):
        raise InputError(f"joints must have shape ({arm.dof},), got {q.shape}",
                         field="joints", value=q)
    released = _released_joints(arm, ids)
    chain = tuple(j.name for j in arm.chain_joints if j.name in released)
    if not has_gravity(arm) or not released:
        return ReleaseCheck(arm.name, False, (), arm.joint_names, None, arm.rest)
    try:
        torques = tuple(float(t) for t in gravity_torques(arm, q))
    except InputError:                 # no masses: it falls, by how much is unknown
        return ReleaseCheck(arm.name, bool(chain), chain, arm.joint_names, None, arm.rest)
    loaded = tuple(name for name, t in zip(arm.joint_names, torques, strict=True)
                   if abs(t) >= LOADED_NM and name in released)
    if not loaded and set(released) == set(arm.joint_names):
        loaded = chain                 # a balanced pose is unstable: the whole chain falls
    return ReleaseCheck(arm.name, bool(loaded), loaded, arm.joint_names, torques, arm.rest)


def rest_here(arm: Arm, q: NDArray[np.float64]) -> tuple[float, ...]:
    """The rest pose to lower to from joints ``q``: ``[arm.rest]`` itself, or on an arm with
    a base yaw turned about the yaw axis into the present vertical plane, so the lowering
    does not swing the base around (the chain's rest is the same in any plane).

    The turn is the yaw joint's: the tool's azimuth at ``q`` less its azimuth with the yaw
    at zero (whatever the joint's direction); none when the tool is on the yaw axis.
    """
    rest = arm.rest
    assert rest is not None
    if not arm.yawed:
        return tuple(rest)
    q = np.asarray(q, dtype=np.float64)
    at_zero = q.copy()
    at_zero[0] = 0.0
    here, zero = tool_pose(arm, q), tool_pose(arm, at_zero)
    if min(np.hypot(*here[:2]), np.hypot(*zero[:2])) < 1e-6:
        return tuple(rest)
    turn = math.atan2(here[1], here[0]) - math.atan2(zero[1], zero[0])
    c, s = math.cos(turn), math.sin(turn)
    x, y = rest[0], rest[1]
    return (c * x - s * y, s * x + c * y, *rest[2:])


def _lowering_plan(arm: Arm, q: NDArray[np.float64], check: ReleaseCheck, lower: bool,
                   plan_options: dict[str, Any] | None
                   ) -> tuple[Trajectory | None, str | None, Recovery | None]:
    """The lowering to the rest pose from ``q`` (None when none is due), when the arm
    falls but cannot be lowered why (the user must hold it), and the recovery that opens
    the lowering from outside the joint limits (:mod:`robodcn.planner.recovery`)."""
    if not check.falls:
        return None, None, None
    if not lower:
        return None, "the lowering was not asked for", None
    if arm.rest is None:
        return None, "it has no rest pose ([arm.rest]) to be lowered to", None
    try:
        trajectory, recovery = with_recovery(arm, q, lambda start: plan(
            arm, [tool_pose(arm, np.asarray(start)), rest_here(arm, np.asarray(start))],
            start_joints=start, **(plan_options or {})))
        return trajectory, None, recovery
    except (InputError, PlanError) as exc:
        return None, f"the lowering to its rest pose cannot be planned: {exc.message}", None


def refusal(check: ReleaseCheck, *, what: str = "torque off", hold: str | None = None
            ) -> GravityReleaseError:
    """The error that asks for confirmation of ``what`` (an action that switches torque
    off), naming what holds how much and whether the arm is lowered first (``hold``: why it
    cannot be, so the user must hold it)."""
    if check.holding_torque_nm is None:
        held = "gravity loads " + ", ".join(check.joints)
    else:
        torque = dict(zip(check.joint_names, check.holding_torque_nm, strict=True))
        held = "holding " + ", ".join(f"{name} {abs(torque[name]):.2f} N·m"
                                      for name in check.joints)
    then = "it is lowered to its rest pose first" if hold is None else f"{hold}: hold it"
    return GravityReleaseError(
        f"{what} switches torque off and lets arm {check.arm!r} fall under gravity "
        f"({held}); confirm to go on ({then})",
        arm=check.arm, joints=check.joints, holding_torque_nm=check.holding_torque_nm,
        rest=check.rest)


def arrived(report: ExecutionReport) -> bool:
    """Whether a lowering left the arm on its rest pose: every sample sent (outcome in
    :data:`ARRIVED`) and the arm in position there (no ``out_of_position`` joint)."""
    return report.outcome in ARRIVED and not report.out_of_position


def _lower(bus: ServoBus, arm: Arm, trajectory: Trajectory,
           plan_options: dict[str, Any] | None,
           execute_options: dict[str, Any] | None) -> ExecutionReport:
    """Stream the lowering, waiting up to :data:`SETTLE_S` for the arm to arrive; a
    lowering that completed out of position (its last goals lost on a loaded bus) is planned
    again from where the arm is and streamed once more."""
    options = {"settle": SETTLE_S, **(execute_options or {})}
    report = execute(trajectory, bus, **options)
    if report.outcome in ARRIVED and report.out_of_position:
        log.warning("the lowering ended out of position (%s): lowering again",
                    ", ".join(miss.joint for miss in report.out_of_position))
        q = present_joints(arm, bus, verify=False)
        report = execute(plan(arm, [tool_pose(arm, q), rest_here(arm, q)], start_joints=q,
                              **(plan_options or {})), bus, **options)
    return report


def _torque_off(bus: ServoBus, ids: Collection[int] | None) -> None:
    bus.torque(False, None if ids is None else tuple(ids))


def release(bus: ServoBus, arm: Arm, *, confirm: bool = False, lower: bool = True,
            ids: Collection[int] | None = None, what: str = "torque off",
            switch_off: Callable[[], Any] | None = None, verify: bool = True,
            warn: Callable[[str], None] | None = None,
            plan_options: dict[str, Any] | None = None,
            execute_options: dict[str, Any] | None = None) -> ReleaseResult:
    """The gravity guard: switch torque off on ``ids`` (``switch_off``: a torque off, a
    reboot, a calibration's start …), lowering the arm to its rest pose first when it would
    fall (module docstring). Every path that switches torque off calls this.

    Parameters
    ----------
    bus : an open bus driving the arm's servos in joint order
    arm : the arm
    confirm : the user accepts that an arm under gravity is let go
    lower : lower a confirmed arm to ``arm.rest`` (when it has one) before torque off
    ids : the servos whose torque goes off (default every servo of the bus); a servo whose
        torque is off already drops nothing
    what : the action, as the refusal names it ("reboot", "calibration" …)
    switch_off : what switches torque off (default Torque Enable = 0 on ``ids``); its
        result is ignored
    verify : check the servos before reading the present joints (:func:`present_joints`)
    warn : told, when a confirmed action drops the arm, before anything moves: that it is
        lowered to its rest pose first, or why it cannot be (hold it) before torque goes
        off; default a log warning
    plan_options, execute_options : keyword options of :func:`robodcn.plan` and
        :func:`robodcn.execute` for the lowering (e.g. ``duration``, ``stop``)

    Raises
    ------
    GravityReleaseError (nothing moved, torque stays on) when the arm would fall and
    ``confirm`` is False.
    """
    if not isinstance(confirm, bool) or not isinstance(lower, bool):
        bad, value = ("confirm", confirm) if not isinstance(confirm, bool) else ("lower", lower)
        raise InputError(f"{bad} must be true or false, got {value!r}", field=bad, value=value)
    q = present_joints(arm, bus, verify=verify)
    enabled = bus.torque_enabled()
    check = check_release(arm, q, [i for i in (bus.ids if ids is None else ids)
                                   if enabled.get(i, True)])    # off already: nothing drops
    trajectory, hold, recovery = _lowering_plan(arm, q, check, lower, plan_options)
    if trajectory is not None:           # the streamer refuses to move servos in alert
        alerts = {i: describe_hardware_error(e) for i, e in bus.hardware_errors().items()
                  if e}
        if alerts:
            trajectory, recovery = None, None
            hold = (f"servo(s) in alert ({alerts}): the streamer cannot lower it before a "
                    "reboot clears that")
    if check.falls and not confirm:
        raise refusal(check, what=what, hold=hold)
    tell = warn or log.warning
    lowering = None
    if trajectory is not None:
        tell(f"{what} lets arm {arm.name!r} fall under gravity (confirmed): lowering it to "
             "its rest pose first" + ("" if recovery is None else f"; {recovery.line()}"))
        try:
            lowering = _lower(bus, arm, trajectory, plan_options, execute_options)
        except (InputError, PlanError, HardwareAlertError, StartMismatchError) as exc:
            hold = f"the lowering to its rest pose was refused: {exc.message}"
        if lowering is not None and not arrived(lowering):
            log.warning("%s: the lowering to the rest pose ended %s; torque stays on", what,
                        lowering.outcome)
            return ReleaseResult(check, False, lowering, False, (), None, recovery)
    if check.falls and hold is not None:
        tell(f"{what} lets arm {arm.name!r} fall under gravity (confirmed) and it cannot be "
             f"lowered first ({hold}): hold it, torque goes off on {', '.join(check.joints)}")
    (switch_off or (lambda: _torque_off(bus, ids)))()
    released = tuple(bus.ids) if ids is None else tuple(ids)
    log.info("%s: torque off on %s%s", what, ", ".join(map(str, released)),
             " after lowering to the rest pose" if lowering is not None else "")
    return ReleaseResult(check, lowering is not None, lowering, True, released,
                         hold if check.falls else None, recovery)


def released(result: ReleaseResult, what: str = "torque off") -> ReleaseResult:
    """``result`` when torque went off; else (a lowering that stopped short: torque stays
    on, the arm holds) StoppedError for a stop request, BusError for a fault or a
    collision — for a caller that must not go on with the arm held (a reboot, a
    calibration, a teach session)."""
    if result.released:
        return result
    lowering = result.lowering
    outcome = lowering.outcome if lowering is not None else "?"
    if lowering is not None and lowering.out_of_position:
        outcome += " out of position (" + ", ".join(m.joint for m in lowering.out_of_position) + ")"
    error = StoppedError if outcome == "stopped" else BusError
    raise error(f"{what} not done: the lowering to the rest pose ended {outcome}; torque "
                "stays on", field="confirm", value=outcome)


def hold(bus: ServoBus, ids: Collection[int] | None = None) -> None:
    """Torque on in position mode with Goal Position = Present Position on ``ids`` (default
    every servo): the arm holds where it is (the way a calibration or a teach session ends,
    however it ends, on an arm under gravity)."""
    bus.set_operating_mode(OPERATING_MODE_POSITION, None if ids is None else tuple(ids),
                           torque=True)
    log.info("holding where the arm is: torque on, position mode, on %s",
             ", ".join(map(str, bus.ids if ids is None else ids)))


__all__ = ["ARRIVED", "LOADED_NM", "SETTLE_S", "ReleaseCheck", "ReleaseResult", "arrived",
           "check_release", "hold", "refusal", "release", "released"]
