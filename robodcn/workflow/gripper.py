"""The gripper: open, close or a jaw width, in current-based position mode.

A ``[gripper]`` (:class:`~robodcn.config.GripperSpec`) is one servo beside the arm's joints,
on the same wire (the OpenMANIPULATOR-X's id 15). Its jaw width maps linearly onto the
servo's angle between ``closed`` and ``open`` (:meth:`GripperSpec.angle_of_width`); a width
outside that stroke is refused, in millimetres.

Every command runs the servo in current-based position control (Operating Mode 5) with
Goal Current = ``grip_current`` (below the servo's Current Limit): the position loop drives
the jaws toward the goal, but never with more than that current. When an object stops the
jaws short of the goal the servo keeps squeezing with ``grip_current`` — a hold, not a
stall at full current, so no overload alert (the classic failure of a gripper squeezing in
position mode, shared/omx.md). The result tells whether an object stopped the jaws: they
came to rest farther than ``tolerance_ticks`` from the goal. A stop (``stop()`` true, e.g.
``POST /v1/stop``) halts the jaws within one poll: the goal becomes where they are.

Intended surfaces: ``robodcn gripper open|close|WIDTH_MM --arm … --device …`` and HTTP
``POST /v1/gripper`` ({"command": "open" | "close"} or {"width_m": w}) answer
:meth:`GripperResult.to_dict`.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any, Literal

from robodcn import _checks, servo_units
from robodcn.bus import OPERATING_MODE_CURRENT_POSITION, ServoBus
from robodcn.config import GripperSpec
from robodcn.errors import InputError

log = logging.getLogger("robodcn.workflow")

Command = Literal["open", "close", "width"]
COMMANDS = ("open", "close")
#: Jaws at rest farther than this from the goal were stopped by an object (ticks, ≈ 2°).
TOLERANCE_TICKS = 23
#: Present Position moving by at most this between polls counts as still (ticks).
STILL_TICKS = 2
#: Polls in a row the jaws must be still to count as at rest.
STILL_POLLS = 3


@dataclass(frozen=True)
class GripperGoal:
    """Where a command sends the jaws: command ("open", "close" or "width"), the servo
    angle (rad, tick ``zero_offset`` = 0), its goal tick and the jaw width (m)."""

    command: Command
    angle: float
    tick: int
    width_m: float


@dataclass(frozen=True)
class GripperResult:
    """What a gripper command did.

    command; goal_tick and goal_width_m (where the jaws were sent); final_tick and
    final_width_m (where they came to rest); present_current_a (signed, A, at rest);
    grip_current_a (the Goal Current they pushed with); blocked: an object stopped the jaws
    farther than ``tolerance_ticks`` short of the goal (it is held with grip_current_a);
    settled: the jaws came to rest within the timeout; stopped: a stop halted them (their
    goal set to where they were, within one poll); elapsed_s.
    """

    command: Command
    goal_tick: int
    goal_width_m: float
    final_tick: int
    final_width_m: float
    present_current_a: float
    grip_current_a: float
    blocked: bool
    settled: bool
    elapsed_s: float
    stopped: bool = False

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _stroke_mm(gripper: GripperSpec) -> tuple[float, float]:
    low, high = sorted((gripper.closed_width, gripper.open_width))
    return low * 1e3, high * 1e3


def gripper_goal(gripper: GripperSpec, command: str | None = None, *,
                 width_m: float | None = None) -> GripperGoal:
    """The goal of ``command`` ("open" | "close") or of a jaw width ``width_m`` (m).

    Raises InputError: neither or both given (field "command"), an unknown command
    (field "command"), a width that is not a number or lies outside the stroke (field
    "width_m", the message in mm).
    """
    if (command is None) == (width_m is None):
        raise InputError("give a gripper command (open, close) or a width, not "
                         f"{'both' if command is not None else 'neither'}", field="command",
                         value=command)
    if command is not None:
        if command not in COMMANDS:
            raise InputError(f"gripper command must be open or close (or a width), got "
                             f"{command!r}", field="command", value=command)
        angle = gripper.open_angle if command == "open" else gripper.closed_angle
        width = gripper.open_width if command == "open" else gripper.closed_width
        kind: Command = command  # type: ignore[assignment]
    else:
        low, high = _stroke_mm(gripper)
        if not _checks.is_finite_real(width_m):
            raise InputError(f"gripper width must be a number of metres, got "
                             f"{_checks.show(width_m)}", field="width_m", value=width_m)
        width = float(width_m)  # type: ignore[arg-type]
        if not low - 1e-9 <= width * 1e3 <= high + 1e-9:
            mm = width * 1e3       # 0.04 (metres typed as mm) shows as 0.04, not 0.0
            shown = f"{mm:.1f}" if abs(mm) >= 0.1 or mm == 0 else f"{mm:.3g}"
            raise InputError(f"gripper width {shown} mm is outside the stroke "
                             f"{low:.1f}–{high:.1f} mm", field="width_m", value=width)
        angle = gripper.angle_of_width(width)
        kind = "width"
    tick = int(servo_units.radians_to_ticks([angle], [gripper.servo])[0])
    return GripperGoal(kind, float(angle), tick, float(width))


def actuate(bus: ServoBus, gripper: GripperSpec, command: str | None = None, *,
            width_m: float | None = None, timeout_s: float = 3.0, poll_s: float = 0.02,
            tolerance_ticks: int = TOLERANCE_TICKS,
            clock: Callable[[], float] = time.monotonic,
            sleep: Callable[[float], None] = time.sleep,
            stop: Callable[[], bool] | None = None) -> GripperResult:
    """Send the jaws to ``command`` or ``width_m`` and wait until they come to rest.

    Parameters
    ----------
    bus : an open bus on the gripper's wire (the arm's: the gripper need not be one of its
        joints)
    gripper : the arm's ``[gripper]``
    command, width_m : as :func:`gripper_goal`
    timeout_s : longest wait for the jaws to come to rest (still for :data:`STILL_POLLS`
        polls ``poll_s`` apart, or at the goal)
    tolerance_ticks : at rest farther than this from the goal: an object stopped them
    clock, sleep : time source and wait (injectable for tests)
    stop : asked before the goal is written and at every poll: once true, the jaws are
        halted where they are (Goal Position := Present Position) and the result says
        ``stopped`` (a stop that comes before the goal is written moves nothing)

    Raises InputError (bad command or width, before anything is written), CommError.
    """
    goal = gripper_goal(gripper, command, width_m=width_m)
    if not _checks.is_finite_real(timeout_s) or timeout_s <= 0:
        raise InputError(f"timeout_s must be a positive number, got {timeout_s!r}",
                         field="timeout_s", value=timeout_s)
    servo = gripper.servo
    start = clock()
    stopped = stop is not None and stop()
    if not stopped:
        bus.set_operating_mode(OPERATING_MODE_CURRENT_POSITION, [servo], torque=True,
                               goal_current_a=gripper.grip_current)
        bus.write_goal_position(servo, goal.tick)
    last = bus.read_position(servo)
    still = 0
    settled = False
    while not stopped:
        if stop is not None and stop():
            last = bus.read_position(servo)
            bus.write_goal_position(servo, last)
            stopped = True
            break
        if abs(goal.tick - last) <= STILL_TICKS:
            settled = True
            break
        if clock() - start >= timeout_s:
            break
        sleep(poll_s)
        now = bus.read_position(servo)
        still = still + 1 if abs(now - last) <= STILL_TICKS else 0
        last = now
        if still >= STILL_POLLS:
            settled = True
            break
    current = bus.read_present_current(servo)
    blocked = settled and abs(goal.tick - last) > tolerance_ticks
    angle = servo_units.ticks_to_radians([last], [servo])[0]
    result = GripperResult(goal.command, goal.tick, goal.width_m, int(last),
                           float(gripper.width_of_angle(float(angle))), float(current),
                           gripper.grip_current, blocked, settled, clock() - start, stopped)
    if stopped:
        log.info("gripper %d: stopped at tick %d (goal was %d)", servo.id, last, goal.tick)
    elif not settled:
        log.warning("gripper %d: still moving after %.1f s (at tick %d, goal %d)", servo.id,
                    timeout_s, last, goal.tick)
    elif blocked:
        log.info("gripper %d: an object stopped the jaws at %.1f mm (goal %.1f mm), held "
                 "with %.2f A", servo.id, result.final_width_m * 1e3, goal.width_m * 1e3,
                 current)
    return result


@dataclass(frozen=True)
class GripperState:
    """Where the jaws are: ``width_m`` (m, from Present Position), ``holding`` (torque on and
    the jaws at rest short of their goal by more than :data:`TOLERANCE_TICKS`, pushing with
    at least half the grip current: an object is between them), ``current_a`` (signed, A)."""

    width_m: float
    holding: bool
    current_a: float

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def read_gripper_state(bus: ServoBus, gripper: GripperSpec) -> GripperState:
    """The jaws' :class:`GripperState`: four reads of the gripper's servo."""
    servo = gripper.servo
    present = bus.read_position(servo)
    goal = bus.read_goal_position(servo)
    current = float(bus.read_present_current(servo))
    torque = bus.read_torque_enabled(servo)
    angle = servo_units.ticks_to_radians([present], [servo])[0]
    holding = torque and abs(goal - present) > TOLERANCE_TICKS \
        and abs(current) >= 0.5 * gripper.grip_current
    return GripperState(float(gripper.width_of_angle(float(angle))), bool(holding), current)


def open_gripper(bus: ServoBus, gripper: GripperSpec, **options: Any) -> GripperResult:
    """:func:`actuate` with "open"."""
    return actuate(bus, gripper, "open", **options)


def close_gripper(bus: ServoBus, gripper: GripperSpec, **options: Any) -> GripperResult:
    """:func:`actuate` with "close": an object in the jaws is held with ``grip_current``."""
    return actuate(bus, gripper, "close", **options)


def set_width(bus: ServoBus, gripper: GripperSpec, width_m: float,
              **options: Any) -> GripperResult:
    """:func:`actuate` to a jaw width (m)."""
    return actuate(bus, gripper, width_m=width_m, **options)


__all__ = ["COMMANDS", "STILL_POLLS", "STILL_TICKS", "TOLERANCE_TICKS", "GripperGoal",
           "GripperResult", "actuate", "close_gripper", "gripper_goal", "open_gripper",
           "set_width"]
