"""A simulated arm: firmware_sim servos on a pty, opened through robodcn's own ServoBus.

The dry-run back end shared by ``robodcn sim``, ``robodcn serve --sim``, the demo and the
tests. Everything above the pty is the real stack (dynamixel-sdk, robodcn.bus,
robodcn.stream), so a dry-run exercises exactly the code that drives hardware. This module
and the tests are the only places robodcn imports firmware_sim.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from firmware_sim.bus import SimBus
from robodcn import kinematics, servo_units
from robodcn.bus import ADDR_GOAL_POSITION, ADDR_TORQUE_ENABLE, ServoBus
from robodcn.config import Arm
from robodcn.errors import InputError

TIMINGS = ("fast", "realistic")
#: Status timeout of reads (ms). No USB adapter sits between host and pty, but the simulator
#: shares this process's interpreter lock with the streamer, the HTTP threads and tests: a
#: reply can be a few 5 ms GIL switch intervals late without being lost.
RX_TIMEOUT_MS = 50.0
#: Extra attempts per read: a lost reply here means the simulator thread was starved of CPU
#: (a loaded machine), never a wire fault, so be patient (injected faults still surface).
RETRIES = 5


@dataclass(frozen=True)
class SimulatedArm:
    """What :func:`simulated_arm` yields: ``sim`` (started SimBus), ``bus`` (open, verified,
    configured ServoBus on ``sim.port_path``) and ``arm``."""

    sim: SimBus
    bus: ServoBus
    arm: Arm


def start_ticks(arm: Arm, start_joints: ArrayLike | None = None) -> NDArray[np.int64]:
    """Servo ticks (k,) of ``start_joints``, or of the IK of the arm's home pose on its
    preferred elbow branch; InputError naming ``start_joints`` outside the joint limits."""
    if start_joints is None:
        q = kinematics.ik(arm.links, [arm.home], arm.elbow)[0]
        field = "arm.home"
    else:
        try:
            q = np.asarray(start_joints, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(f"start_joints must be {arm.dof} numbers (rad), got "
                             f"{start_joints!r}", field="start_joints",
                             value=start_joints) from exc
        if q.shape != (arm.dof,) or not np.isfinite(q).all():
            raise InputError(f"start_joints must be {arm.dof} finite numbers (rad) for arm "
                             f"{arm.name!r}, got {start_joints!r}", field="start_joints",
                             value=start_joints)
        field = "start_joints"
    for j, (angle, spec) in enumerate(zip(q, arm.joints, strict=True)):
        if not spec.min_angle <= angle <= spec.max_angle:
            raise InputError(f"{field}: joint {spec.name!r} at {math.degrees(angle):.1f}° is "
                             f"outside its limits {math.degrees(spec.min_angle):.1f}.."
                             f"{math.degrees(spec.max_angle):.1f}°", field=field,
                             value=float(q[j]))
    return servo_units.radians_to_ticks(q[None, :], arm.servos)[0]


def _place(sim: SimBus, ids: Sequence[int], ticks: Sequence[int]) -> None:
    """Put each simulated servo at rest at its start tick, before any client talks to it.

    Through the servo's own control table: torque on, Goal Position (with the factory
    Profile Velocity 0 the goal is a step, taken at once), torque off again as at power-up.
    """
    with sim.lock:
        for servo_id, tick in zip(ids, ticks, strict=True):
            servo = sim.servo(servo_id)
            for address, data in ((ADDR_TORQUE_ENABLE, b"\x01"),
                                  (ADDR_GOAL_POSITION, int(tick).to_bytes(4, "little",
                                                                          signed=True)),
                                  (ADDR_TORQUE_ENABLE, b"\x00")):
                code = servo.write(address, data)
                if code:
                    raise InputError(f"servo {servo_id} refused start tick {int(tick)} "
                                     f"(error {code})", field="start_joints", value=int(tick))
            if servo.present_position != int(tick):
                raise RuntimeError(f"simulated servo {servo_id} did not take its start tick "
                                   f"{int(tick)} (at {servo.present_position})")


@contextlib.contextmanager
def simulated_arm(arm: Arm, *, timing: str = "realistic", start_joints: ArrayLike | None = None,
                  firmware: int = 46) -> Iterator[SimulatedArm]:
    """A started firmware_sim bus with ``arm``'s servos and a ServoBus ready to stream.

    Parameters
    ----------
    arm : Arm
    timing : "realistic" (wire and turnaround timing of a real bus) or "fast" (tests)
    start_joints : (k,) radians the servos start at; default the IK of ``arm.home`` on
        ``arm.elbow``
    firmware : firmware version of every servo (≥ 45: Fast Sync Read)

    The bus runs at the arm's baud rate and is opened, verified against the arm's servos
    and configured (position mode, Return Delay Time 0, torque on, holding). On exit the
    bus and the simulator are closed: no threads or file descriptors outlive the block.
    """
    if timing not in TIMINGS:
        raise InputError(f"timing must be one of {', '.join(map(repr, TIMINGS))}, got "
                         f"{timing!r}", field="timing", value=timing)
    if isinstance(firmware, bool) or not isinstance(firmware, int) or not 0 <= firmware <= 255:
        raise InputError(f"firmware must be a version number 0..255, got {firmware!r}",
                         field="firmware", value=firmware)
    ticks = start_ticks(arm, start_joints)
    models = {s.id: s.model for s in arm.servos}
    with contextlib.ExitStack() as stack:
        sim = SimBus(arm.servo_ids, models, baud=arm.bus.baud, timing=timing,
                     firmware=firmware, log=False)
        _place(sim, arm.servo_ids, ticks)
        sim.start()
        stack.callback(sim.close)
        bus = ServoBus(sim.port_path, arm.bus.baud, servos=arm.servos, retries=RETRIES,
                       rx_timeout_ms=RX_TIMEOUT_MS)
        bus.open()
        stack.callback(bus.close)
        bus.verify()
        bus.configure()
        yield SimulatedArm(sim=sim, bus=bus, arm=arm)
