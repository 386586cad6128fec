"""PING honours the bus's ``rx_timeout_ms`` (robodcn.bus.verification): a servo that answers
later than the SDK's own 34 ms status deadline but within the bus's timeout is found; one
that never answers is reported as before; ``scan`` keeps the SDK's short deadline."""

from __future__ import annotations

import time

import pytest

from firmware_sim.bus import SimBus
from firmware_sim.protocol import Instruction
from robodcn.bus import ServoBus, scan
from robodcn.config import ServoSpec
from robodcn.errors import ServoMismatchError

#: Later than the SDK's PING deadline (11 bytes at 1 Mbps + 2·16 ms + 2 ms = 34.1 ms),
#: well within the bus's RX_TIMEOUT_MS.
LATE_S = 0.060
RX_TIMEOUT_MS = 400.0


def specs(*ids: int) -> list[ServoSpec]:
    return [ServoSpec(i, "xm430-w350") for i in ids]


@pytest.fixture
def sim() -> SimBus:
    with SimBus((1, 2, 3), timing="fast") as bus:
        yield bus


def test_a_ping_answered_after_the_sdk_deadline_but_within_rx_timeout_is_found(sim):
    late = sim.faults.delay(LATE_S, servo_id=2, instructions=[Instruction.PING], times=None)
    with ServoBus(sim.port_path, servos=specs(1, 2, 3), retries=0,
                  rx_timeout_ms=RX_TIMEOUT_MS) as bus:
        info = bus.ping(2)
        assert info is not None and info.model_number == 1020 and info.firmware == 46
        found = bus.verify()        # the set-up path: every id, no ServoMismatchError
    assert sorted(found) == [1, 2, 3]
    assert late.fired >= 2          # both pings of servo 2 were answered late


def test_without_rx_timeout_the_sdk_deadline_misses_the_late_ping(sim):
    # the control: the same late servo through the SDK's own ping (rx_timeout_ms None)
    sim.faults.delay(LATE_S, servo_id=2, instructions=[Instruction.PING], times=None)
    with ServoBus(sim.port_path, servos=specs(1, 2, 3), retries=0) as bus:
        assert bus.ping(2) is None


def test_a_servo_that_never_answers_is_still_reported_missing(sim):
    sim.faults.drop(servo_id=3, instructions=[Instruction.PING], times=None)
    with ServoBus(sim.port_path, servos=specs(1, 2, 3), retries=1,
                  rx_timeout_ms=RX_TIMEOUT_MS) as bus:
        t0 = time.monotonic()
        assert bus.ping(3) is None
        # each of the two tries waited the bus's timeout, not the SDK's 34 ms
        assert time.monotonic() - t0 >= 2 * RX_TIMEOUT_MS / 1000
        with pytest.raises(ServoMismatchError, match=r"no reply from servo id\(s\) \[3\]") as exc:
            bus.verify()
    assert exc.value.value == {"missing": [3], "wrong_model": []}


def test_a_wrong_model_is_still_named(sim):
    with ServoBus(sim.port_path, servos=[*specs(1, 2), ServoSpec(3, "xl430-w250")],
                  rx_timeout_ms=RX_TIMEOUT_MS) as bus, \
            pytest.raises(ServoMismatchError, match="servo 3 is model") as exc:
        bus.verify()
    assert exc.value.value == {"missing": [], "wrong_model": [3]}


def test_scan_finds_the_servos_and_skips_silent_ids(sim):
    found = scan(sim.port_path, ids=[1, 3, 9])
    assert [(s.id, s.model_number, s.baud) for s in found] == [(1, 1020, 1_000_000),
                                                               (3, 1020, 1_000_000)]


def test_scan_keeps_the_sdk_deadline(sim):
    # scan probes with the SDK's own 34 ms deadline (robodcn.bus.scan): a servo slower
    # than that is not found by scan, though a bus with a longer rx_timeout_ms finds it
    # (late enough that the first try's reply misses the retry's window too)
    sim.faults.delay(0.25, servo_id=2, instructions=[Instruction.PING], times=None)
    assert [s.id for s in scan(sim.port_path, ids=[1, 2])] == [1]


def test_a_ping_with_an_alert_bit_still_names_the_servo_s_model(sim):
    """The status's alert bit is the servo's state (reported as a hardware alert), not a
    failed ping: the model number is read as the SDK's own ping reads it."""
    sim.faults.trip(3, bits=0x20)  # overload on servo 3: its status packets carry 0x80
    with ServoBus(sim.port_path, servos=specs(1, 2, 3), retries=0,
                  rx_timeout_ms=RX_TIMEOUT_MS) as bus:
        info = bus.ping(3)
        assert info is not None and info.model_number == 1020
        assert sorted(bus.verify()) == [1, 2, 3]  # no ServoMismatchError for servo 3
