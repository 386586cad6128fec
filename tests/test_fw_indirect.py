"""firmware_sim's per-servo ``indirect`` option (issue 17 §4): servos that acknowledge an
Indirect Address map without serving it, as an older firmware or a clone does.

Expected values are the X-series control table's (e-manual): Indirect Address k at
168 + 2(k−1) (k = 1..28) and 578 + 2(k−29) (k = 29..56), factory value = its own
Indirect Data address (224 + k−1, 634 + k−29).
"""

from __future__ import annotations

import socket
import subprocess
import sys
from pathlib import Path

import pytest
from dynamixel_sdk import COMM_SUCCESS
from fw_helpers import PH, open_port

from firmware_sim import control_table as ct
from firmware_sim.bus import SimBus
from firmware_sim.bus_config import SimBusConfig
from firmware_sim.clock import VirtualClock
from firmware_sim.control_socket import execute
from firmware_sim.servo import INDIRECT_MODES, Servo

ROOT = Path(__file__).resolve().parent.parent
#: Indirect Address 29..32 -> Present Position's 4 bytes (the streamer's style of map).
MAP = b"".join((ct.PRESENT_POSITION + k).to_bytes(2, "little") for k in range(4))
FACTORY = b"".join((ct.INDIRECT_DATA_29 + k).to_bytes(2, "little") for k in range(4))


def servo(indirect) -> Servo:
    return Servo(1, clock=VirtualClock(), position=1234, indirect=indirect)


@pytest.mark.parametrize("slot", [ct.INDIRECT_ADDRESS_1, ct.INDIRECT_ADDRESS_29])
def test_off_acknowledges_a_map_write_and_keeps_the_factory_map(slot):
    s = servo(False)
    assert s.indirect == "off"
    data_base = ct.INDIRECT_DATA_1 if slot == ct.INDIRECT_ADDRESS_1 else ct.INDIRECT_DATA_29
    factory = b"".join((data_base + k).to_bytes(2, "little") for k in range(4))
    assert s.read(slot, 8) == (0, factory)
    assert s.write(slot, MAP) == 0                     # answers OK ...
    assert s.read(slot, 8) == (0, factory)             # ... and stores nothing
    assert s.read(data_base, 4) == (0, bytes(4))       # the data bytes stay plain storage
    assert s.reg_write(slot, MAP) == 0 and s.action() == 0
    assert s.read(slot, 8) == (0, factory)
    # every other item is written as ever, also by a servo with the option
    assert s.write(ct.LED, b"\x01") == 0 and s.table.get(ct.LED) == 1
    # and a refused write is refused as ever (the range check comes first)
    assert s.write(slot, (63).to_bytes(2, "little")) == ct.ERR_DATA_RANGE


def test_on_serves_the_same_write():
    s = servo(True)
    assert s.indirect == "on"
    assert s.write(ct.INDIRECT_ADDRESS_29, MAP) == 0
    assert s.read(ct.INDIRECT_ADDRESS_29, 8) == (0, MAP)
    assert s.read(ct.INDIRECT_DATA_29, 4) == (0, (1234).to_bytes(4, "little"))


def test_unresolved_stores_the_map_but_the_data_does_not_follow_it():
    s = servo("unresolved")
    assert s.write(ct.INDIRECT_ADDRESS_29, MAP) == 0
    assert s.read(ct.INDIRECT_ADDRESS_29, 8) == (0, MAP)              # reads back
    assert s.read(ct.INDIRECT_DATA_29, 4) == (0, bytes(4))             # but reads zeros
    assert s.read(ct.PRESENT_POSITION, 4) == (0, (1234).to_bytes(4, "little"))
    # a write to the data bytes is plain storage, not Present Position's read-only bytes
    assert s.write(ct.INDIRECT_DATA_29, b"\x07") == 0
    assert s.read(ct.INDIRECT_DATA_29, 1) == (0, b"\x07")


def test_the_mode_can_change_and_bad_modes_are_refused():
    s = servo(True)
    s.indirect = "off"
    assert s.write(ct.INDIRECT_ADDRESS_29, MAP) == 0
    assert s.read(ct.INDIRECT_ADDRESS_29, 8) == (0, FACTORY)
    s.indirect = "ON"
    assert s.write(ct.INDIRECT_ADDRESS_29, MAP) == 0
    assert s.read(ct.INDIRECT_ADDRESS_29, 8) == (0, MAP)
    assert INDIRECT_MODES == ("on", "off", "unresolved")
    for bad in ("maybe", 0, None):
        with pytest.raises(ValueError, match="indirect must be one of"):
            s.indirect = bad
        with pytest.raises(ValueError, match="indirect must be one of"):
            Servo(1, indirect=bad)


def test_bus_config_sets_the_mode_per_servo():
    cfg = SimBusConfig(ids=(1, 2, 3), indirect={2: False, 3: "unresolved"})
    assert dict(cfg.indirect) == {2: "off", 3: "unresolved"}
    bus = SimBus(config=cfg)
    assert [s.indirect for s in bus.servos] == ["on", "off", "unresolved"]
    assert [s.indirect for s in SimBus((1, 2), indirect=False).servos] == ["off", "off"]
    with pytest.raises(ValueError, match="indirect: no servo 9"):
        SimBus((1, 2), indirect={9: False})
    with pytest.raises(ValueError, match="indirect must be one of"):
        SimBusConfig(indirect="sometimes")


def test_console_command_sets_the_mode():
    bus = SimBus((1, 2))
    assert execute(bus, "indirect 2 off") == "ok"
    assert bus.servo(2).indirect == "off" and bus.servo(1).indirect == "on"
    assert execute(bus, "indirect 2 unresolved") == "ok"
    assert bus.servo(2).indirect == "unresolved"
    assert execute(bus, "indirect 2 on") == "ok" and bus.servo(2).indirect == "on"
    assert execute(bus, "indirect 2 maybe").startswith("error indirect must be one of")
    assert execute(bus, "indirect 7 off").startswith("error no servo 7")


def test_cli_flag_and_control_socket(tmp_path):
    path = str(tmp_path / "ctl")
    proc = subprocess.Popen([sys.executable, "-m", "firmware_sim", "--ids", "1,2",
                             "--indirect", "2:off", "--control", path], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        device = proc.stdout.readline().strip()
        assert device.startswith("/dev/")
        with socket.socket(socket.AF_UNIX) as s:
            s.connect(path)
            f = s.makefile("rw")
            f.write("indirect 1 unresolved\n")
            f.flush()
            assert f.readline().strip() == "ok"
        port = open_port(device)
        try:          # on the wire, through the SDK: both acknowledge the map write
            for servo_id, readback in ((2, ct.INDIRECT_DATA_29), (1, ct.PRESENT_POSITION)):
                assert PH.write2ByteTxRx(port, servo_id, ct.INDIRECT_ADDRESS_29,
                                         ct.PRESENT_POSITION)[:2] == (COMM_SUCCESS, 0)
                assert PH.read2ByteTxRx(port, servo_id, ct.INDIRECT_ADDRESS_29) \
                    == (readback, COMM_SUCCESS, 0)
            # servo 1 keeps the map (unresolved) but its Indirect Data reads 0, not 2048
            assert PH.read4ByteTxRx(port, 1, ct.INDIRECT_DATA_29) == (0, COMM_SUCCESS, 0)
            assert PH.read4ByteTxRx(port, 1, ct.PRESENT_POSITION) == (2048, COMM_SUCCESS, 0)
        finally:
            port.closePort()
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    bad = subprocess.run([sys.executable, "-m", "firmware_sim", "--ids", "1",
                          "--indirect", "4:off"], cwd=ROOT, capture_output=True, text=True,
                         timeout=20)
    assert bad.returncode == 2 and "indirect: no servo 4" in bad.stderr
