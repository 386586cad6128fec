"""``python -m firmware_sim --arm omx`` as a user starts it, through the real dynamixel-sdk
over the pty: every servo answers the first ping of a client, also one that took a second
to start (the physics is kept up with the clock between packets, so the first packet after
a pause does not integrate the whole pause before it can answer). An arm under gravity
starts at its ``[arm.rest]`` pose lying on its support, and its chain joints have inelastic
mechanical end stops just beyond their limits; planar horizontal arms have neither."""

from __future__ import annotations

import math
import subprocess
import sys
import time
from pathlib import Path

import pytest
from dynamixel_sdk import COMM_SUCCESS
from fw_helpers import PH, open_port, s32, sdk_port

from firmware_sim import control_table as ct
from firmware_sim.arm_model import END_STOP_MARGIN_DEG, load_arm
from firmware_sim.bus import SimBus
from firmware_sim.clock import VirtualClock

ROOT = Path(__file__).resolve().parent.parent
OMX_IDS = (11, 12, 13, 14, 15)


@pytest.fixture
def omx_cli():
    """The CLI's omx bus in its own process; yields its pty path."""
    proc = subprocess.Popen([sys.executable, "-m", "firmware_sim", "--arm", "omx"], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/"), proc.stderr.read() if proc.poll() is not None else path
        yield path
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err


def _first_pings(port) -> dict[int, str]:
    """Each id pinged once: the SDK's result text per id."""
    return {i: PH.getTxRxResult(PH.ping(port, i)[1]) for i in OMX_IDS}


@pytest.mark.parametrize("pause_s", [0.0, 1.5])
def test_every_servo_answers_the_first_ping(omx_cli, pause_s):
    time.sleep(pause_s)                  # a client starting up (robodcn's imports) …
    port = open_port(omx_cli)
    try:
        answers = _first_pings(port)     # … then its first command: one ping each
    finally:
        port.closePort()
    ok = PH.getTxRxResult(COMM_SUCCESS)
    assert answers == dict.fromkeys(OMX_IDS, ok), answers


# -- mechanical end stops and the rest pose ------------------------------------------------

#: The omx's rest pose (omx.toml comment: joints ≈ 0, -1.40, 1.30, 0.80 rad) in ticks.
REST = {11: 2048, **{i: round(2048 + q * 4096 / (2 * math.pi))
                    for i, q in ((12, -1.40), (13, 1.30), (14, 0.80))}}
#: The configured joint limits (omx.toml), rad.
LIMITS = {12: (-1.5, 1.5), 13: (-1.5, 1.4), 14: (-1.7, 1.97)}


def _angle(tick: int) -> float:
    return (tick - 2048) * 2 * math.pi / 4096


def _positions(port) -> dict[int, int]:
    out = {}
    for i in OMX_IDS[:4]:
        value, result, _ = PH.read4ByteTxRx(port, i, ct.PRESENT_POSITION)
        assert result == COMM_SUCCESS, (i, PH.getTxRxResult(result))
        out[i] = s32(value)
    return out


def _advance(bus: SimBus, clock: VirtualClock, seconds: float) -> None:
    """Move the virtual clock in 50 ms strides, stepping the arm's physics after each (one
    read after a long jump would integrate it all while the SDK waits 34 ms)."""
    for _ in range(round(seconds / 0.05)):
        clock.advance(0.05)
        with bus.lock:
            bus.servo(12).update()


def test_the_cli_omx_starts_resting_and_stays_there_unpowered(omx_cli):
    port = open_port(omx_cli)
    try:
        first = _positions(port)
        time.sleep(1.0)                                     # torque off, under gravity
        later = _positions(port)
        torque = {i: PH.read1ByteTxRx(port, i, ct.TORQUE_ENABLE)[0] for i in OMX_IDS}
    finally:
        port.closePort()
    assert torque == dict.fromkeys(OMX_IDS, 0)
    assert all(abs(first[i] - REST[i]) <= 2 for i in REST), first
    assert later == first                                   # lying on its support
    for i, (lo, hi) in LIMITS.items():                      # robodcn's move accepts it
        assert lo < _angle(later[i]) < hi, (i, later[i])


def test_a_falling_arm_stops_at_its_end_stop_and_a_powered_one_holds():
    clock = VirtualClock()
    bus = SimBus(arm="omx", dynamics=True, clock=clock, positions={12: 2048, 13: 2048})
    margin = math.radians(END_STOP_MARGIN_DEG)
    with bus, sdk_port(bus) as port:
        _advance(bus, clock, 3.0)                           # unpowered upright: it falls
        fallen = _positions(port)
        _advance(bus, clock, 1.0)
        assert _positions(port) == fallen                   # resting on the stop
        shoulder = _angle(fallen[12])
        # forward and down, onto the shoulder's stop just beyond its limit (not 152°)
        assert shoulder == pytest.approx(LIMITS[12][1] + margin, abs=0.002), fallen
        assert bus.servo(12).present_velocity == 0
        for i in (11, 12, 13, 14):
            assert PH.write1ByteTxRx(port, i, ct.TORQUE_ENABLE, 1)[0] == COMM_SUCCESS
        before = _positions(port)
        _advance(bus, clock, 1.0)
        held = _positions(port)
        assert all(abs(held[i] - before[i]) <= 1 for i in held), (before, held)
    assert not bus.errors, bus.errors


def test_the_omx_at_rest_holds_powered_and_the_library_starts_it_there():
    clock = VirtualClock()
    bus = SimBus(arm="omx", dynamics=True, clock=clock)
    assert {i: bus.servo(i).present_position for i in REST} == pytest.approx(REST, abs=2)
    with bus, sdk_port(bus) as port:
        for i in (11, 12, 13, 14):
            assert PH.write1ByteTxRx(port, i, ct.TORQUE_ENABLE, 1)[0] == COMM_SUCCESS
        before = _positions(port)
        _advance(bus, clock, 2.0)
        assert _positions(port) == before
    assert not bus.errors, bus.errors


@pytest.mark.parametrize("name", ["arm2r", "arm3r"])
def test_planar_horizontal_arms_have_no_stops_and_start_at_zero(name):
    arm = load_arm(name)
    assert arm.stops is None and arm.rest is None
    bus = SimBus(arm=name, dynamics=True, clock=VirtualClock())
    assert all(s.present_position == 2048 for s in bus.servos)
