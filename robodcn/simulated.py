"""A simulated arm: firmware_sim servos on a pty, opened through robodcn's own ServoBus.

The dry-run back end shared by ``robodcn sim``, ``robodcn serve --sim``, the demo and the
tests. Everything above the pty is the real stack (dynamixel-sdk, robodcn.bus,
robodcn.stream), so a dry-run exercises exactly the code that drives hardware. By default
the servos run firmware_sim's physics model driving the arm's rigid-body dynamics (its own
``[dynamics]`` masses), so a dry run shows the tracking lag, velocities and currents the
real arm will have; ``dynamics=False`` keeps the kinematic model. This module and the tests
are the only places robodcn imports firmware_sim.

Time: the simulated servos read the host's monotonic clock, or, with ``clock=``, the
stream's own (:class:`robodcn.stream.VirtualClock`): their physics then advance exactly as
far as the stream's schedule does, whatever the host's load, and a reply that comes late in
wall time costs nothing, so the bus waits for it longer (:data:`VIRTUAL_RX_TIMEOUT_MS`).
firmware_sim never imports robodcn: it is handed a :class:`firmware_sim.clock.Clock` that
reads the stream clock's ``now`` (:class:`StreamTime`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from firmware_sim import control_table as fct
from firmware_sim.bus import SimBus
from firmware_sim.bus_config import SimBusConfig
from firmware_sim.clock import Clock as FirmwareClock
from robodcn import kinematics, servo_units
from robodcn.bus import ServoBus, StreamProfile
from robodcn.config import Arm
from robodcn.errors import InputError
from robodcn.planner import Trajectory
from robodcn.stream.clock import Clock, RealClock
from robodcn.stream.report import ExecutionReport

TIMINGS = ("fast", "realistic")
#: Status timeout of reads (ms). No USB adapter sits between host and pty, but the simulator
#: shares this process's interpreter lock with the streamer, the HTTP threads and tests: a
#: reply can be a few 5 ms GIL switch intervals late without being lost.
RX_TIMEOUT_MS = 50.0
#: Status timeout of reads (ms, wall time) when the servos run on a virtual stream clock:
#: the simulator thread, starved of the CPU on a loaded host, answers late, not wrongly,
#: and lateness in wall time does not move the schedule.
VIRTUAL_RX_TIMEOUT_MS = 2000.0
#: Extra attempts per read: a lost reply here means the simulator thread was starved of CPU
#: (a loaded machine), never a wire fault, so be patient (injected faults still surface).
RETRIES = 5
#: A seated servo reads its start tick to within this (the physics model's rounding).
PLACE_TOLERANCE_TICKS = 1


@dataclass(frozen=True)
class SimulatedArm:
    """What :func:`simulated_arm` yields: ``sim`` (started SimBus), ``bus`` (open, verified,
    configured ServoBus on ``sim.port_path``) and ``arm``; ``pinned_kg`` the payload the
    simulated arm carries whatever a move declares, or None (it carries what each move
    declares: :meth:`carry`)."""

    sim: SimBus
    bus: ServoBus
    arm: Arm
    pinned_kg: float | None = None

    def carry(self, payload_kg: float | None) -> float | None:
        """Let the simulated arm carry the payload a move declares (``payload_kg``, None:
        the arm file's), so a dry run predicts the real arm that carries it (issue 27 §2);
        a pinned payload stays. Returns the kg the simulated arm now carries (None on the
        kinematic model, which carries nothing)."""
        if self.sim.arm is None:
            return None
        if self.pinned_kg is None:
            kg = self.arm.payload_kg if payload_kg is None else float(payload_kg)
            if kg != self.sim.payload_kg:
                self.sim.set_payload(kg)
        return self.sim.payload_kg

    def reported(self, report: ExecutionReport, trajectory: Trajectory) -> ExecutionReport:
        """``report`` naming the payload the simulated arm carried (``sim_payload_kg``) and
        the one ``trajectory`` was planned for (``planned_payload_kg``)."""
        request = trajectory.request
        planned = self.arm.payload_kg if request is None or request.payload_kg is None \
            else float(request.payload_kg)
        return dataclasses.replace(report, sim_payload_kg=self.sim.payload_kg,
                                   planned_payload_kg=planned)


class StreamTime(FirmwareClock):
    """firmware_sim's time read from a stream clock's ``now`` (module docstring): the
    servos' motion and watchdog follow the stream's schedule, not the wall."""

    def __init__(self, now: Callable[[], float]) -> None:
        self._now = now

    def now(self) -> float:
        return self._now()


def rx_timeout_for(clock: Clock | None) -> float:
    """The bus's status timeout (ms) for servos on ``clock``: :data:`RX_TIMEOUT_MS` on real
    time (None or a :class:`~robodcn.stream.RealClock`), :data:`VIRTUAL_RX_TIMEOUT_MS` on
    any other (virtual) clock."""
    return RX_TIMEOUT_MS if clock is None or isinstance(clock, RealClock) \
        else VIRTUAL_RX_TIMEOUT_MS


def start_ticks(arm: Arm, start_joints: ArrayLike | None = None) -> NDArray[np.int64]:
    """Servo ticks (k,) of ``start_joints``, or of the IK of the arm's home pose on its
    preferred elbow branch; InputError naming ``start_joints`` outside the joint limits."""
    if start_joints is None:
        if arm.chain is not None:                    # a base yaw: x, y, z, pitch
            q = kinematics.ik_yawed(arm.chain, np.array([arm.home]), arm.elbow)[0]
        else:
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


def _check_placed(sim: SimBus, ids: Sequence[int], ticks: Sequence[int]) -> None:
    """Each simulated servo must rest at its start tick (seated through ``positions=``).

    The physics model seats the shaft (and the arm's joint angle) directly, like the
    kinematic one, so a fresh servo reads its start tick exactly; a model that did not
    would make every later start check fail obscurely, so say it here."""
    with sim.lock:
        for servo_id, tick in zip(ids, ticks, strict=True):
            present = sim.servo(servo_id).present_position
            if abs(present - int(tick)) > PLACE_TOLERANCE_TICKS:
                raise RuntimeError(f"simulated servo {servo_id} did not take its start tick "
                                   f"{int(tick)} (at {present})")


def _hold_under_gravity(sim: SimBus, ids: Sequence[int]) -> None:
    """An arm under gravity starts held where it was seated, as a real arm is left holding
    by its last session: torque on, Return Delay Time already what :meth:`ServoBus.configure`
    sets, so configure never switches the torque off (unheld, the physics model's arm
    would fall between seating and configure)."""
    if sim.arm is None or sim.arm.gravity == (0.0, 0.0):
        return
    rdt = StreamProfile().return_delay_us // 2
    with sim.lock:
        for servo_id in ids:
            servo = sim.servo(servo_id)
            for address, value in ((fct.RETURN_DELAY_TIME, rdt), (fct.TORQUE_ENABLE, 1)):
                code = servo.write(address, bytes([value]))
                if code:
                    raise RuntimeError(f"simulated servo {servo_id} refused item {address} = "
                                       f"{value} (error {code:#x})")


def sim_arm_document(arm: Arm) -> dict[str, Any]:
    """The arm as the servo simulator reads an arm file: links, joint→servo maps and the
    optional ``[dynamics]`` table (firmware_sim parses it itself, it never imports robodcn)."""
    return arm.to_dict()


@contextlib.contextmanager
def simulated_arm(arm: Arm, *, timing: str = "realistic", start_joints: ArrayLike | None = None,
                  firmware: int = 46, dynamics: bool = True,
                  clock: Clock | None = None,
                  carried_kg: float | None = None) -> Iterator[SimulatedArm]:
    """A started firmware_sim bus with ``arm``'s servos and a ServoBus ready to stream.

    Parameters
    ----------
    arm : Arm
    timing : "realistic" (wire and turnaround timing of a real bus) or "fast" (tests)
    start_joints : (k,) radians the servos start at; default the IK of ``arm.home`` on
        ``arm.elbow``
    firmware : firmware version of every servo (≥ 45: Fast Sync Read)
    dynamics : True (default): the servo physics model driving the arm's rigid-body
        dynamics from its ``[dynamics]`` table (masses default in firmware_sim), so the
        run shows real tracking lag and current; False: the kinematic model (each goal
        reached at once), for protocol tests.
    clock : the stream's clock (a :class:`robodcn.stream.VirtualClock`) the servos read
        their time from (module docstring); pass the same one to ``execute(clock=…)``.
        None (default): the host's monotonic clock. The bus's status timeout follows it
        (:func:`rx_timeout_for`).
    carried_kg : the payload (kg, at the tool point) the simulated arm carries whatever a
        move declares: a load the plan misdeclares, as on a real arm. None (default): it
        starts with the arm file's ``payload_kg`` and carries what each move declares
        (:meth:`SimulatedArm.carry`, which ``sim`` and ``serve --sim`` call per move).

    A ``[gripper]`` servo is simulated too (at its zero offset), beside the joints; an arm
    under gravity starts held (:func:`_hold_under_gravity`). The
    bus runs at the arm's baud rate and is opened, verified against the arm's servos
    and configured (position mode, Return Delay Time 0, torque on, holding). On exit the
    bus and the simulator are closed: no threads or file descriptors outlive the block.
    """
    if timing not in TIMINGS:
        raise InputError(f"timing must be one of {', '.join(map(repr, TIMINGS))}, got "
                         f"{timing!r}", field="timing", value=timing)
    if not isinstance(dynamics, bool):
        raise InputError(f"dynamics must be true or false, got {dynamics!r}", field="dynamics",
                         value=dynamics)
    if isinstance(firmware, bool) or not isinstance(firmware, int) or not 0 <= firmware <= 255:
        raise InputError(f"firmware must be a version number 0..255, got {firmware!r}",
                         field="firmware", value=firmware)
    if clock is not None and not callable(getattr(clock, "now", None)):
        raise InputError(f"clock must be a stream clock with now(), got {clock!r}",
                         field="clock", value=clock)
    if carried_kg is not None and (isinstance(carried_kg, bool) or not isinstance(
            carried_kg, int | float) or not math.isfinite(carried_kg) or carried_kg < 0):
        raise InputError(f"carried_kg must be a finite number of kg >= 0, got {carried_kg!r}",
                         field="carried_kg", value=carried_kg)
    ticks = start_ticks(arm, start_joints)
    servos = arm.servos if arm.gripper is None else (*arm.servos, arm.gripper.servo)
    models = {s.id: s.model for s in servos}
    with contextlib.ExitStack() as stack:
        positions = {i: int(t) for i, t in zip(arm.servo_ids, ticks, strict=True)}
        sim = SimBus(config=SimBusConfig(
            ids=tuple(s.id for s in servos), model=models, baud=arm.bus.baud, timing=timing,
            firmware=firmware, log=False, dynamics=dynamics,
            arm=sim_arm_document(arm) if dynamics else None, positions=positions,
            clock=None if clock is None else StreamTime(clock.now)))
        _check_placed(sim, arm.servo_ids, ticks)
        if carried_kg is not None and sim.arm is not None:
            sim.set_payload(float(carried_kg))
        _hold_under_gravity(sim, arm.servo_ids)
        sim.start()
        stack.callback(sim.close)
        bus = ServoBus(sim.port_path, arm.bus.baud, servos=arm.servos, retries=RETRIES,
                       rx_timeout_ms=rx_timeout_for(clock))
        bus.open()
        stack.callback(bus.close)
        bus.verify()
        bus.configure()
        yield SimulatedArm(sim=sim, bus=bus, arm=arm,
                           pinned_kg=None if carried_kg is None else float(carried_kg))
