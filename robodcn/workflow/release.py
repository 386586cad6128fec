"""Releasing an arm: torque off, which drops an arm under gravity unless it is lowered first.

Switching torque off leaves a vertical arm (the OpenMANIPULATOR-X) to fall — the classic
end-of-run drop its users report (shared/omx.md). So on an arm with gravity (a chain in a
vertical plane, ``[dynamics]`` g ≠ 0) :func:`release` refuses without confirmation: a
:class:`~robodcn.errors.GravityReleaseError` carrying the joints gravity loads and the
torque each holds at the present pose (:func:`check_release`; surfaces ask ``--yes`` /
``"confirm": true``). Confirmed, and when the arm has a rest pose (``[arm.rest]``), the arm
is first lowered there — planned from the present joints (:func:`robodcn.plan`) and
streamed (:func:`robodcn.execute`) — and torque goes off only once it has arrived; if the
lowering stops short (a collision, a fault, a stop request), torque stays on and the result
says so. An arm without gravity (a horizontal planar arm) is released at once.

Intended surfaces: ``robodcn torque off [--yes]``, ``robodcn move … --release [--yes]``,
the end of ``teach``, HTTP ``POST /v1/torque`` {"on": false, "confirm": true} — each maps
GravityReleaseError to its warning (exit 2 / HTTP 409) and shows :class:`ReleaseResult`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

from numpy.typing import ArrayLike

from robodcn import _checks
from robodcn.bus import ServoBus
from robodcn.config import Arm
from robodcn.errors import GravityReleaseError, InputError
from robodcn.planner import plan
from robodcn.present import present_joints
from robodcn.stream import ExecutionReport, execute
from robodcn.workflow.float_teach import gravity_torques, has_gravity
from robodcn.workflow.poses import tool_pose

log = logging.getLogger("robodcn.workflow")

#: A joint holding less than this against gravity does not count as loaded (N·m).
LOADED_NM = 1e-3
#: Lowering outcomes after which the arm is at rest on the rest pose.
ARRIVED = ("done", "degraded")


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
    released (torque went off); released_ids."""

    check: ReleaseCheck
    lowered: bool
    lowering: ExecutionReport | None
    released: bool
    released_ids: tuple[int, ...]

    def to_dict(self) -> dict[str, Any]:
        return {"check": self.check.to_dict(), "lowered": self.lowered,
                "lowering": None if self.lowering is None else self.lowering.to_dict(),
                "released": self.released, "released_ids": list(self.released_ids)}


def check_release(arm: Arm, joints: ArrayLike) -> ReleaseCheck:
    """Whether torque off would drop ``arm`` at ``joints`` (rad, joint order), and why."""
    q = _checks.as_float_array("joints", joints)
    if q.shape != (arm.dof,):
        raise InputError(f"joints must have shape ({arm.dof},), got {q.shape}",
                         field="joints", value=q)
    chain = tuple(j.name for j in arm.chain_joints)
    if not has_gravity(arm):
        return ReleaseCheck(arm.name, False, (), arm.joint_names, None, arm.rest)
    try:
        torques = tuple(float(t) for t in gravity_torques(arm, q))
    except InputError:                 # no masses: it falls, by how much is unknown
        return ReleaseCheck(arm.name, True, chain, arm.joint_names, None, arm.rest)
    loaded = tuple(name for name, t in zip(arm.joint_names, torques, strict=True)
                   if abs(t) >= LOADED_NM)
    return ReleaseCheck(arm.name, True, loaded or chain, arm.joint_names, torques, arm.rest)


def refusal(check: ReleaseCheck) -> GravityReleaseError:
    """The error that asks for confirmation, naming what holds how much."""
    if check.holding_torque_nm is None:
        held = "gravity loads " + ", ".join(check.joints)
    else:
        torque = dict(zip(check.joint_names, check.holding_torque_nm, strict=True))
        held = "holding " + ", ".join(f"{name} {abs(torque[name]):.2f} N·m"
                                      for name in check.joints)
    then = ("it is lowered to its rest pose first" if check.rest is not None
            else "it has no rest pose ([arm.rest]) to be lowered to first")
    return GravityReleaseError(
        f"torque off lets arm {check.arm!r} fall under gravity ({held}); confirm to release "
        f"it ({then})", arm=check.arm, joints=check.joints,
        holding_torque_nm=check.holding_torque_nm, rest=check.rest)


def release(bus: ServoBus, arm: Arm, *, confirm: bool = False, lower: bool = True,
            verify: bool = True, plan_options: dict[str, Any] | None = None,
            execute_options: dict[str, Any] | None = None) -> ReleaseResult:
    """Torque off on ``arm``'s servos, lowering it to its rest pose first (module docstring).

    Parameters
    ----------
    bus : an open bus driving the arm's servos in joint order
    arm : the arm
    confirm : the user accepts that an arm under gravity is let go
    lower : lower a confirmed arm to ``arm.rest`` (when it has one) before torque off
    verify : check the servos before reading the present joints (:func:`present_joints`)
    plan_options, execute_options : keyword options of :func:`robodcn.plan` and
        :func:`robodcn.execute` for the lowering (e.g. ``duration``, ``stop``)

    Raises
    ------
    GravityReleaseError (nothing moved, torque stays on) when the arm would fall and
    ``confirm`` is False; whatever planning the lowering raises (nothing moved either).
    """
    if not isinstance(confirm, bool) or not isinstance(lower, bool):
        bad, value = ("confirm", confirm) if not isinstance(confirm, bool) else ("lower", lower)
        raise InputError(f"{bad} must be true or false, got {value!r}", field=bad, value=value)
    q = present_joints(arm, bus, verify=verify)
    check = check_release(arm, q)
    if check.falls and not confirm:
        raise refusal(check)
    lowering = None
    if check.falls and lower and arm.rest is not None:
        trajectory = plan(arm, [tool_pose(arm, q), arm.rest], start_joints=q,
                          **(plan_options or {}))
        lowering = execute(trajectory, bus, **(execute_options or {}))
        if lowering.outcome not in ARRIVED:
            log.warning("release: the lowering to the rest pose ended %s; torque stays on",
                        lowering.outcome)
            return ReleaseResult(check, False, lowering, False, ())
    bus.torque(False)
    log.info("release: torque off on %s%s", ", ".join(map(str, bus.ids)),
             " after lowering to the rest pose" if lowering is not None else "")
    return ReleaseResult(check, lowering is not None, lowering, True, tuple(bus.ids))


__all__ = ["ARRIVED", "LOADED_NM", "ReleaseCheck", "ReleaseResult", "check_release", "refusal",
           "release"]
