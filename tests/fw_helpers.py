"""Shared helpers for the firmware_sim tests that drive SimBus through the real dynamixel-sdk;
fixtures (``bus``, ``port``) for ``pytest_plugins = ["fw_helpers"]``."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from dynamixel_sdk import COMM_SUCCESS, PacketHandler, PortHandler

from firmware_sim import control_table as ct
from firmware_sim.bus import SimBus
from firmware_sim.clock import VirtualClock
from firmware_sim.protocol import build_packet
from firmware_sim.servo import Servo

PH = PacketHandler(2.0)
READ_TIMEOUT_S = 0.001
#: Added to the SDK's own packet timeout (≈ 34 ms at 1 Mbps: twice its 16 ms latency timer).
#: A real servo answers within it; the simulator is a thread of a loaded test process, which
#: a CPU hog beside two pytest workers can starve for longer than that (seen once: a read
#: after a reboot answered -3001). Tests that expect silence just wait this much longer.
LOADED_MARGIN_MS = 150.0
#: One control period of the simulated firmware, s (Realtime Tick resolution).
PERIOD = 0.001


def make(model: str = "xm430-w350", **kw) -> tuple[Servo, VirtualClock]:
    clock = VirtualClock(100.0)
    return Servo(1, model, clock=clock, **kw), clock


def put(servo: Servo, address: int, value: int) -> None:
    it = servo.spec.item(address)
    code = servo.write(address, value.to_bytes(it.size, "little", signed=it.signed))
    assert code == 0, f"write {it.name}={value} -> error {code:#x}"


def setup_move(servo: Servo, velocity: int, acceleration: int, drive_mode: int = 0,
               mode: int = ct.MODE_POSITION) -> None:
    put(servo, ct.TORQUE_ENABLE, 0)
    put(servo, ct.OPERATING_MODE, mode)
    put(servo, ct.DRIVE_MODE, drive_mode)
    put(servo, ct.PROFILE_VELOCITY, velocity)
    put(servo, ct.PROFILE_ACCELERATION, acceleration)
    put(servo, ct.TORQUE_ENABLE, 1)


class LoadedPort(PortHandler):
    """The SDK's PortHandler with :data:`LOADED_MARGIN_MS` more on every packet timeout it
    computes from a packet length; its packet logic is the SDK's own."""

    margin_ms = LOADED_MARGIN_MS

    def setPacketTimeout(self, packet_length):
        super().setPacketTimeout(packet_length)
        self.packet_timeout += self.margin_ms


def open_port(path: str, baud: int = 1_000_000,
              margin_ms: float = LOADED_MARGIN_MS) -> PortHandler:
    """An SDK PortHandler opened on ``path`` at ``baud`` (see the read-timeout and
    :data:`LOADED_MARGIN_MS` notes; ``margin_ms=0``: the SDK's own packet timeout, for the
    tests of that timeout itself)."""
    port = LoadedPort(path)
    port.margin_ms = margin_ms
    assert port.openPort(), f"SDK could not open {path}"
    assert port.setBaudRate(baud), f"SDK refused baud {baud}"
    # The SDK polls pyserial with timeout=0 and spins at 100 % CPU holding the GIL; with
    # the simulator in the same interpreter (and pytest -n 2 on two cores) that spinning
    # starves the server thread. A 1 ms read timeout makes the same SDK code wait in
    # select() instead; its packet logic and its own timeouts are unchanged.
    port.ser.timeout = READ_TIMEOUT_S
    return port


@contextmanager
def sdk_port(bus: SimBus, baud: int = 1_000_000,
             margin_ms: float = LOADED_MARGIN_MS) -> Iterator[PortHandler]:
    """An SDK PortHandler opened on the bus's pty at ``baud`` (:func:`open_port`); closed
    afterwards."""
    port = open_port(bus.port_path, baud, margin_ms)
    try:
        yield port
    finally:
        port.closePort()


@pytest.fixture
def bus() -> Iterator[SimBus]:
    """A started SimBus with servos 1, 2, 3 that must end without protocol errors; a module
    overrides it for other servos or options (``fault_seed``, …), and ``port`` follows."""
    with SimBus(ids=[1, 2, 3]) as b:
        yield b
        assert b.errors == []


@pytest.fixture
def port(bus: SimBus) -> Iterator[PortHandler]:
    """:func:`sdk_port` on the ``bus`` fixture."""
    with sdk_port(bus) as p:
        yield p


def raw_txrx(port: PortHandler, packet: bytes, reply_len: int = 11) -> tuple[list[int], int]:
    """Send hand-made bytes, then let the SDK receive one status packet."""
    port.clearPort()
    port.writePort(list(packet))
    port.setPacketTimeout(reply_len)
    return PH.rxPacket(port, False)


def raw_instruction(port: PortHandler, servo_id: int, instruction: int, params: bytes = b"",
                    reply_len: int = 11) -> tuple[list[int], int]:
    return raw_txrx(port, build_packet(servo_id, instruction, params), reply_len)


def wait_ping(port: PortHandler, servo_id: int, timeout: float = 3.0) -> int:
    """Ping until the servo answers (it may be booting); returns its model number."""
    deadline = time.monotonic() + timeout
    while True:
        model, result, _ = PH.ping(port, servo_id)
        if result == COMM_SUCCESS:
            return model
        if time.monotonic() > deadline:
            raise AssertionError(f"servo {servo_id} did not answer within {timeout} s: "
                                 f"{PH.getTxRxResult(result)}")
        time.sleep(0.01)


def settle(port: PortHandler, servo_id: int) -> None:
    """Wait out stray status packets (e.g. ACTION's, which the SDK never reads), flush
    them, then ping: once the ping answers, every earlier packet has been processed."""
    time.sleep(0.02)
    port.clearPort()
    wait_ping(port, servo_id)


def wait_until(condition, timeout: float = 2.0) -> None:
    """Poll ``condition()`` until true (e.g. the server thread has seen a packet)."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"condition not met within {timeout} s")
        time.sleep(0.0005)


def s32(value: int) -> int:
    """Unsigned 32-bit SDK value as signed."""
    return value - (1 << 32) if value & 0x8000_0000 else value
