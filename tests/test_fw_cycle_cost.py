"""firmware_sim's cheaper cycle (issue 27 §2): what the dry run's 100 Hz cycle stopped paying
for must not change what the servos do.

* the drive's settings snapshot is rebuilt only when a setting changes
  (``servo.live.configure_drive``), and a written gain still reaches the drive;
* the bus's keep-up between packets advances the physics without rewriting the live items
  (``Servo.advance``); a read still sees the present state.
"""

from __future__ import annotations

import math

from firmware_sim import control_table as fct
from firmware_sim.bus import SimBus
from firmware_sim.bus_config import SimBusConfig
from firmware_sim.clock import VirtualClock
from robodcn.config import load_arm
from robodcn.simulated import sim_arm_document

OMX = load_arm("omx")


def _omx(clock: VirtualClock) -> SimBus:
    sim = SimBus(config=SimBusConfig(
        ids=OMX.servo_ids, model={s.id: s.model for s in OMX.servos}, timing="fast",
        log=False, dynamics=True, arm=sim_arm_document(OMX), clock=clock))
    for i in OMX.servo_ids:
        sim.servo(i).write(fct.TORQUE_ENABLE, bytes([1]))
    return sim


def _move(sim: SimBus, clock: VirtualClock, cycles: int, keep_up: bool) -> list[int]:
    """A 1 Hz sine of ±300 ticks on every joint, a goal every 10 ms; with ``keep_up`` the
    bus's keep-up runs twice between goals as its server thread would. The final present
    positions."""
    servos = [sim.servo(i) for i in OMX.servo_ids]
    base = [s.get(fct.PRESENT_POSITION) for s in servos]
    for k in range(cycles):
        for _ in range(2):
            clock.advance(0.005)
            if keep_up:
                sim.keep_up()
        for s, b in zip(servos, base, strict=True):
            goal = int(b + 300 * math.sin(2 * math.pi * k / 100))
            s.write(fct.GOAL_POSITION, goal.to_bytes(4, "little", signed=True))
    return [s.present_position for s in servos]


def test_keep_up_advances_the_physics_and_a_read_sees_it():
    """Keep-ups between the goals change nothing the servos do (the steps are the same);
    the live items wait for the read, which refreshes them."""
    lazy = _move(_omx(c := VirtualClock()), c, 120, keep_up=False)
    kept = _move(_omx(c := VirtualClock()), c, 120, keep_up=True)
    assert kept == lazy
    clock = VirtualClock()
    sim = _omx(clock)
    servo = sim.servo(OMX.servo_ids[1])
    before = servo.table.get(fct.REALTIME_TICK)
    clock.advance(0.05)
    sim.keep_up()
    assert servo.motion.plant.t >= 0.05 - 1e-9          # stepped to now
    assert servo.table.get(fct.REALTIME_TICK) == before   # not refreshed
    assert servo.get(fct.REALTIME_TICK) != before         # a read refreshes


def test_a_written_setting_reaches_the_drive_and_nothing_else_rebuilds_it():
    clock = VirtualClock()
    sim = _omx(clock)
    servo = sim.servo(OMX.servo_ids[1])
    servo.update()
    clock.advance(0.01)
    servo.update()
    drive = servo.motion.drive
    first = drive.settings
    clock.advance(0.01)
    servo.update()
    assert drive.settings is first                        # nothing changed: kept
    p_gain = first.kpp * 128.0
    servo.write(fct.POSITION_P_GAIN, int(p_gain + 100).to_bytes(2, "little"))
    clock.advance(0.01)
    servo.update()
    assert drive.settings is not first
    assert drive.settings.kpp == (p_gain + 100) / 128.0
    servo.write(fct.TORQUE_ENABLE, bytes([0]))
    clock.advance(0.01)
    servo.update()
    assert drive.settings.torque_on is False
