"""Before the first write: the refusals, the approach, the rate check and the configuration.

:func:`check_arguments` runs before the bus is claimed (types, ids, option lengths);
:func:`preflight` with the bus claimed: the servos that answer are the trajectory's (ids,
models: :meth:`ServoBus.verify`); every tick is inside the servo limits; no servo reports a
hardware error; the present positions (read here, or the ``present_ticks`` the caller just
read) are within ``start_tolerance`` of the first sample. Otherwise it raises
(ServoMismatchError, TickLimitError, HardwareAlertError, StartMismatchError), or, with
``approach=True``, plans the request again from the present joints (the planner prepends a
joint-space approach: :func:`robodcn.planner.plan_request` with ``start_joints``). A rate
that needs more wire time a sample than the bus has at its baud issues a
:class:`~robodcn.stream.rate.RateWarning`. Then the servos are configured when they need it;
:func:`arm_watchdog` arms the Bus Watchdog just before the loop.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn._checks import is_int
from robodcn.bus import FEEDBACK_LENGTH, ServoBus, describe_hardware_error
from robodcn.errors import (
    GravityReleaseError,
    HardwareAlertError,
    InputError,
    ServoMismatchError,
    StartMismatchError,
)
from robodcn.planner import Trajectory, plan_request
from robodcn.servo_units import radians_per_tick, ticks_to_radians
from robodcn.stream.options import ExecutionOptions
from robodcn.stream.rate import check_rate, check_steps
from robodcn.stream.report import Approach, approach_of

log = logging.getLogger("robodcn.stream")


@dataclass(frozen=True)
class Prepared:
    """What the checks leave the loop: the trajectory to stream (with an approach when one
    was planned), that approach, and the warnings issued (``{"code", "message", …}``)."""

    trajectory: Trajectory
    approach: Approach | None
    warnings: tuple[dict[str, Any], ...]
    #: the Present Position (k,) ticks the checks worked from (read once per execution)
    present: NDArray[np.int64] | None = None


def check_arguments(trajectory: Any, bus: Any, opts: ExecutionOptions,
                    present_ticks: ArrayLike | None = None) -> NDArray[np.int64] | None:
    """InputError/ServoMismatchError for arguments that cannot be streamed; the present
    ticks (k,) as an array (None when not given)."""
    if not isinstance(trajectory, Trajectory):
        raise InputError(f"trajectory must be a robodcn Trajectory, got "
                         f"{type(trajectory).__name__}", field="trajectory", value=trajectory)
    if not isinstance(bus, ServoBus):
        raise InputError(f"bus must be a robodcn ServoBus, got {type(bus).__name__}",
                         field="bus", value=bus)
    if tuple(trajectory.servo_ids) != bus.ids:
        raise ServoMismatchError(
            f"the trajectory drives servo ids {list(trajectory.servo_ids)}, the bus has "
            f"{list(bus.ids)} (same ids in the same order needed)", field="servo_ids",
            value=list(trajectory.servo_ids))
    _refuse_falling_release(trajectory, opts)
    if opts.collision_current is not None and len(opts.collision_current) != len(bus.ids):
        raise InputError(f"collision_current needs {len(bus.ids)} currents (A, one per "
                         f"joint), got {list(opts.collision_current)}",
                         field="collision_current", value=list(opts.collision_current))
    if present_ticks is None:
        return None
    values = list(np.asarray(present_ticks, dtype=object).ravel()) \
        if np.ndim(present_ticks) == 1 else None
    if values is None or len(values) != len(bus.ids) or not all(is_int(v) for v in values):
        raise InputError(f"present_ticks must be {len(bus.ids)} integer ticks (Present "
                         f"Position, bus order), got {present_ticks!r}",
                         field="present_ticks", value=present_ticks)
    return np.array([int(v) for v in values], dtype=np.int64)


def _refuse_falling_release(trajectory: Trajectory, opts: ExecutionOptions) -> None:
    """GravityReleaseError for ``release`` on an arm under gravity: torque off at the end of
    the stream would drop it; :func:`robodcn.workflow.release.release` (the gravity guard:
    it asks, and lowers the arm to its rest pose first) releases such an arm."""
    arm = None if trajectory.request is None else trajectory.request.arm
    if not opts.release or arm is None or arm.mass_properties.gravity_m_s2 <= 0.0:
        return
    chain = tuple(j.name for j in arm.chain_joints)
    raise GravityReleaseError(
        f"release=True would switch torque off at the end of the stream and let arm "
        f"{arm.name!r} fall under gravity ({', '.join(chain)}): stream without it and release "
        "with robodcn.workflow.release.release, which asks and lowers it to its rest pose "
        "first", arm=arm.name, joints=chain, holding_torque_nm=None, rest=arm.rest,
        field="release")


def _plan_approach(trajectory: Trajectory, bus: ServoBus,
                   present: NDArray[np.int64]) -> Trajectory:
    """The trajectory's request planned again from the present joints (an approach first)."""
    request = trajectory.request
    if request is None:
        raise InputError("approach=True needs a trajectory that carries its PlanRequest "
                         "(plan it with robodcn.plan or load it with its arm)",
                         field="approach", value=True)
    start = tuple(float(v) for v in ticks_to_radians(present, bus.servos))
    return plan_request(dataclasses.replace(request, start_joints=start))


def _refuse_hardware_errors(bus: ServoBus) -> None:
    errors = bus.hardware_errors()
    if any(errors.values()):
        bad = {i: describe_hardware_error(e) for i, e in errors.items() if e}
        raise HardwareAlertError(
            f"servo(s) report a hardware error: {bad}; fix the cause and reboot the servo "
            "(Hardware Error Status clears only on reboot)", field="servos", value=errors)


def _start(trajectory: Trajectory, bus: ServoBus, opts: ExecutionOptions,
           present: NDArray[np.int64]) -> tuple[Trajectory, Approach | None]:
    """The trajectory as given when the arm is at its start; else refused, or re-planned
    with an approach (``approach=True``)."""
    gap = np.abs(present - trajectory.ticks[0]) * radians_per_tick(bus.servos)
    if gap.max() <= opts.start_tolerance:
        return trajectory, None
    if not opts.approach:
        worst = int(np.argmax(gap))
        raise StartMismatchError(
            f"the arm is {math.degrees(gap[worst]):.1f}° from the trajectory's start "
            f"at joint {trajectory.joint_names[worst]!r} (present tick "
            f"{int(present[worst])}, first sample {int(trajectory.ticks[0, worst])}; "
            f"tolerance {math.degrees(opts.start_tolerance):.1f}°); move it there "
            "first or pass approach=True", field="start", value=gap.tolist())
    trajectory = _plan_approach(trajectory, bus, present)
    bus.check_ticks(trajectory.ticks)
    approach = approach_of(trajectory) or Approach(0, 0.0)
    log.info("approach inserted: %d samples, %.3f s", approach.samples, approach.duration_s)
    return trajectory, approach


def preflight(trajectory: Trajectory, bus: ServoBus, opts: ExecutionOptions,
              present_ticks: NDArray[np.int64] | None = None) -> Prepared:
    """The checks before any write, then the configuration (the bus claimed by the caller).

    ``present_ticks``: Present Position (k,) the caller has just read (bus order); None
    reads it here."""
    bus.verify()
    bus.check_ticks(trajectory.ticks)
    _refuse_hardware_errors(bus)
    present = bus.read_positions() if present_ticks is None else present_ticks
    trajectory, approach = _start(trajectory, bus, opts, present)
    issued = []
    profile_rdt = 0 if opts.profile is None else opts.profile.return_delay_us
    rate = check_rate(trajectory.rate_hz, len(bus.ids), bus.baud,
                      feedback_every=opts.feedback_every, fast_read=bus.fast_read,
                      return_delay_us=profile_rdt, item_bytes=FEEDBACK_LENGTH)
    if rate is not None:
        log.info("%s", rate.info.message)
        warnings.warn(rate, stacklevel=3)
        issued.append(rate.to_dict())
    coarse = check_steps(trajectory.joints, trajectory.rate_hz, trajectory.joint_names)
    if coarse is not None:
        log.info("%s", coarse.message)
        warnings.warn(coarse, stacklevel=3)
        issued.append(coarse.to_dict())
    # -- the first writes ------------------------------------------------------------------
    if not bus.configured or not all(bus.torque_enabled().values()):
        bus.configure(opts.profile)
    return Prepared(trajectory, approach, tuple(issued), present)


def arm_watchdog(bus: ServoBus, opts: ExecutionOptions, period: float) -> None:
    """Arm the Bus Watchdog for the execution: ``watchdog_ms``, default max(250 ms, 10
    periods); 0 leaves it off."""
    watchdog_ms = opts.watchdog_ms
    if watchdog_ms is None:
        watchdog_ms = max(250.0, 10_000.0 * period)
    if watchdog_ms:
        bus.arm_watchdog(watchdog_ms)


__all__ = ["Prepared", "arm_watchdog", "check_arguments", "preflight"]
