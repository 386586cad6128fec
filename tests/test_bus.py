"""robodcn.bus through the real dynamixel-sdk against firmware_sim's SimBus (timing "fast")."""

from __future__ import annotations

import json
import logging
import os
import threading
import time
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from firmware_sim.bus import SimBus
from robodcn import cli
from robodcn.bus import (
    ADDR_GOAL_POSITION,
    ADDR_POSITION_D_GAIN,
    ADDR_POSITION_I_GAIN,
    ADDR_POSITION_P_GAIN,
    ADDR_PRESENT_POSITION,
    MODEL_NUMBERS,
    LatencyTimerWarning,
    ServoBus,
    StreamProfile,
    check_latency_timer,
    latency_timer_ms,
    scan,
)
from robodcn.config import ServoSpec
from robodcn.errors import BusyError, CommError, InputError, ServoMismatchError, TickLimitError

WRITES = ("WRITE", "SYNC_WRITE", "REG_WRITE", "BULK_WRITE")


def specs(ids=(1, 2, 3), model="xm430-w350", **kw) -> list[ServoSpec]:
    return [ServoSpec(i, model, **kw) for i in ids]


@pytest.fixture
def sim(sim3):
    return sim3


@pytest.fixture
def bus(sim):
    # Generous reply timeout and extra retries: on a loaded machine the in-process simulator
    # thread can answer late (it shares the CPU and the GIL with the test); real servos do not.
    with ServoBus(sim.port_path, servos=specs(), retries=3, rx_timeout_ms=150) as b:
        yield b


def write_count(sim: SimBus) -> int:
    return sum(len(sim.packets("rx", name)) for name in WRITES)


# -- pure parts (no port) ----------------------------------------------------------------------

@settings(max_examples=50, deadline=None)
@given(hnp.arrays(np.int64, st.tuples(st.integers(1, 6), st.just(3)),
                  elements=st.integers(0, 4095)))
def test_encode_goals_is_little_endian_int32(ticks):
    b = ServoBus("/dev/null-not-opened", servos=specs())
    rows = b.encode_goals(ticks)
    decoded = np.frombuffer(bytes(np.array(rows, dtype=np.uint8).ravel()), dtype="<i4")
    assert np.array_equal(decoded.reshape(ticks.shape), ticks)
    # Same bytes as the SDK's own 4-byte split (DXL_LOBYTE/HIBYTE of LOWORD/HIWORD).
    for row, values in zip(rows, ticks, strict=True):
        for data, v in zip(row, values, strict=True):
            assert data == [v & 0xFF, (v >> 8) & 0xFF, (v >> 16) & 0xFF, (v >> 24) & 0xFF]


def test_check_ticks_names_sample_and_servo():
    b = ServoBus("/dev/null-not-opened", servos=specs(min_tick=100, max_tick=4000))
    good = np.array([[100, 2000, 4000], [150, 2100, 3900]])
    assert np.array_equal(b.check_ticks(good), good)
    bad = good.copy()
    bad[1, 2] = 4001
    with pytest.raises(TickLimitError) as err:
        b.check_ticks(bad)
    assert err.value.sample == 1 and "servo 3" in err.value.message and "4001" in err.value.message
    with pytest.raises(InputError, match="shape"):
        b.check_ticks(np.zeros((2, 2), dtype=int))
    with pytest.raises(InputError, match="integers"):
        b.check_ticks(good.astype(float))


@pytest.mark.parametrize("kwargs, field", [
    ({"baud": 123}, "baud"), ({"retries": -1}, "retries"), ({"rx_timeout_ms": 0}, "rx_timeout_ms"),
    ({"servos": []}, "servos"), ({"servos": specs((1, 1))}, "servos"),
])
def test_bad_bus_arguments_name_the_field(kwargs, field):
    args = {"servos": specs(), **kwargs}
    with pytest.raises(InputError) as err:
        ServoBus("/dev/ttyX", **args)
    assert err.value.field == field


@pytest.mark.parametrize("kwargs", [{"velocity": -1}, {"acceleration": 40000},
                                    {"return_delay_us": 600}, {"velocity": 1.5}])
def test_bad_profile_is_refused(kwargs):
    with pytest.raises(InputError):
        StreamProfile(**kwargs)


def test_latency_timer_warning_gives_the_fix(tmp_path):
    (tmp_path / "ttyUSB7").mkdir()
    (tmp_path / "ttyUSB7" / "latency_timer").write_text("16\n")
    with pytest.warns(LatencyTimerWarning, match=r"echo 1 \| sudo tee .*ttyUSB7/latency_timer"):
        assert check_latency_timer("/dev/ttyUSB7", sysfs=tmp_path) == 16
    (tmp_path / "ttyUSB7" / "latency_timer").write_text("1\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert check_latency_timer("/dev/ttyUSB7", sysfs=tmp_path) == 1
    # A symlink (like /dev/serial/by-id/...) is followed to the tty name.
    link = tmp_path / "by-id"
    link.symlink_to("/dev/ttyUSB7")
    assert latency_timer_ms(str(link), sysfs=tmp_path) == 1
    assert latency_timer_ms("/dev/pts/3", sysfs=tmp_path) is None
    assert latency_timer_ms("/dev/ttyUSB9", sysfs=tmp_path) is None


def test_open_missing_device_is_a_comm_error(tmp_path):
    with pytest.raises(CommError, match="cannot open"):
        ServoBus(str(tmp_path / "nope"), servos=specs()).open()


# -- against the simulator ---------------------------------------------------------------------

def test_verify_reports_models_and_firmware(sim, bus):
    found = bus.verify()
    assert sorted(found) == [1, 2, 3]
    for info in found.values():
        assert info.model == "xm430-w350"
        assert info.model_number == sim.servo(info.id).model_number == MODEL_NUMBERS["xm430-w350"]
        assert info.firmware == sim.servo(info.id).firmware_version
    assert bus.fast_read is True


def test_verify_names_missing_and_wrong_servos():
    with SimBus((1, 3), model={1: "xm430-w350", 3: "xl430-w250"}, timing="fast") as sim:
        with ServoBus(sim.port_path, servos=specs(), retries=3) as b:
            with pytest.raises(ServoMismatchError) as err:
                b.verify()
        assert err.value.value == {"missing": [2], "wrong_model": [3]}
        assert "[2]" in err.value.message and "servo 3 is model xl430-w250" in err.value.message
        assert write_count(sim) == 0


def test_configure_sets_streaming_state_without_moving(sim, bus):
    bus.verify()
    for i in (1, 2, 3):
        assert sim.servo(i).write(9, bytes([250])) == 0       # factory RDT 500 µs
        assert sim.servo(i).write(11, bytes([4])) == 0        # extended position mode
    before = bus.read_positions()
    bus.configure(StreamProfile(velocity=120, acceleration=30))
    for i, present in zip((1, 2, 3), before, strict=True):
        servo = sim.servo(i)
        assert servo.torque_enabled
        assert servo.return_delay_us == 0
        assert servo.read(11, 1) == (0, bytes([3]))
        assert servo.read(112, 4) == (0, (120).to_bytes(4, "little"))
        assert servo.read(108, 4) == (0, (30).to_bytes(4, "little"))
        assert servo.goal_position == present
        assert sim.goal_history(i)[-1] == present
    assert np.array_equal(bus.read_positions(), before)
    assert all(bus.torque_enabled().values())


def test_configure_leaves_torque_on_when_eeprom_is_already_right(sim, bus):
    bus.verify()
    bus.configure()
    sim.clear_log()
    bus.configure()
    writes = [(e.id, int.from_bytes(e.params[:2], "little"), e.params[2:])
              for e in sim.packets("rx", "WRITE")]
    assert writes, "configure wrote nothing"
    assert (1, 64, b"\x00") not in writes and all(a != 64 or d == b"\x01" for _, a, d in writes)
    assert all(a >= 64 for _, a, _ in writes)       # no EEPROM write either
    assert all(sim.servo(i).torque_enabled for i in (1, 2, 3))


def test_configure_reads_each_servos_position_gains(sim, bus):
    """The Position P, I and D Gains (84, 82, 80) are read per servo, in bus order: the
    stream's lead takes the I gain from ``bus.position_i_gains`` (no read of its own)."""
    bus.verify()
    assert bus.position_i_gains is None             # not read before configure
    for i, (p, i_gain, d) in zip((1, 2, 3), [(800, 0, 0), (640, 300, 10), (900, 1200, 0)],
                                 strict=True):
        servo = sim.servo(i)
        assert servo.write(ADDR_POSITION_P_GAIN, p.to_bytes(2, "little")) == 0
        assert servo.write(ADDR_POSITION_I_GAIN, i_gain.to_bytes(2, "little")) == 0
        assert servo.write(ADDR_POSITION_D_GAIN, d.to_bytes(2, "little")) == 0
    bus.configure()
    assert bus.position_p_gains == (800, 640, 900)
    assert bus.position_i_gains == (0, 300, 1200)
    assert bus.position_d_gains == (0, 10, 0)


def test_positions_round_trip_through_goals(sim, bus):
    bus.verify()
    bus.configure()
    goals = np.array([1000, 2048, 3000])
    bus.write_goals(goals)
    bus.read(1, ADDR_GOAL_POSITION, 4)        # a round trip: the sim has handled the write
    assert [sim.goal_history(i)[-1] for i in (1, 2, 3)] == goals.tolist()
    assert [sim.servo(i).goal_position for i in (1, 2, 3)] == goals.tolist()
    present = bus.read_positions()
    assert present.tolist() == [sim.servo(i).present_position for i in (1, 2, 3)]
    with pytest.raises(TickLimitError):
        bus.write_goals([1000, 2048, 5000])
    assert [sim.goal_history(i)[-1] for i in (1, 2, 3)] == goals.tolist()


@pytest.mark.parametrize("firmware, instruction", [(46, "FAST_SYNC_READ"), (44, "SYNC_READ")])
def test_group_read_falls_back_to_plain_sync_read(firmware, instruction):
    with SimBus((1, 2, 3), firmware={1: 46, 2: firmware, 3: 46}, timing="fast") as sim:
        with ServoBus(sim.port_path, servos=specs(), retries=3, rx_timeout_ms=150) as b:
            b.verify()
            assert b.fast_read is (firmware >= 45)
            sim.clear_log()
            positions = b.read_positions()
        assert positions.tolist() == [sim.servo(i).present_position for i in (1, 2, 3)]
        assert len(sim.packets("rx", instruction)) == 1


def test_error_status_is_not_decoded_as_data(sim, bus):
    # An undefined address answers with an error status and no data: the SDK would hand
    # back the CRC bytes as "data".
    with pytest.raises(CommError, match="status error"):
        bus.read(1, 700, 4)
    assert bus.read(1, ADDR_PRESENT_POSITION, 4) == \
        sim.servo(1).present_position.to_bytes(4, "little", signed=True)


@pytest.mark.parametrize("firmware", [46, 44])
def test_hardware_alert_is_seen_in_group_reads(firmware):
    with SimBus((1, 2, 3), firmware=firmware, timing="fast") as sim:
        with ServoBus(sim.port_path, servos=specs(), retries=3, rx_timeout_ms=150) as b:
            b.verify()
            b.configure()
            b.read_positions()
            assert b.last_alert_ids == ()
            assert b.hardware_errors() == {1: 0, 2: 0, 3: 0}
            sim.faults.trip(2, 0x20)
            b.read_positions()
            assert b.last_alert_ids == (2,)
            assert b.hardware_errors() == {1: 0, 2: 0x20, 3: 0}
            assert not sim.servo(2).torque_enabled


def test_reboot_clears_a_hardware_error(sim, bus):
    bus.verify()
    bus.configure()
    sim.faults.trip(3, 0x20)
    assert bus.hardware_errors()[3] == 0x20
    bus.reboot([3])
    assert bus.hardware_errors() == {1: 0, 2: 0, 3: 0}
    assert bus.last_alert_ids == ()
    assert not bus.configured and not sim.servo(3).torque_enabled


def test_rx_timeout_applies_to_unicast_reads_and_writes(sim):
    late = 0.06                        # past the SDK's own 34 ms, well inside 150 ms
    with ServoBus(sim.port_path, servos=specs(), retries=0) as sdk_timeout:
        sim.faults.delay(late, 1)
        with pytest.raises(CommError, match="no status packet"):
            sdk_timeout.read(1, ADDR_PRESENT_POSITION, 4)
        # Let the late reply land and be flushed: status packets carry no sequence number,
        # so a stale one would pass for the next reply from the same id.
        time.sleep(3 * late)
    with ServoBus(sim.port_path, servos=specs(), retries=0, rx_timeout_ms=150) as ours:
        sim.faults.delay(late, 1)
        assert ours.read(1, ADDR_PRESENT_POSITION, 4) == \
            sim.servo(1).present_position.to_bytes(4, "little", signed=True)
        sim.faults.delay(late, 1)
        ours.write(1, 65, [1])                                    # LED on, status checked
        assert ours.read(1, 65, 1) == b"\x01"


def test_retries_recover_one_bad_reply_and_give_up_on_persistent_ones(sim, bus):
    bus.verify()
    expected = [sim.servo(i).present_position for i in (1, 2, 3)]
    sim.faults.corrupt_crc(times=1)
    before = bus.retries_used
    assert bus.read_positions().tolist() == expected
    assert bus.retries_used == before + 1
    sim.faults.drop(2, times=None)
    with pytest.raises(CommError):
        bus.read_positions()
    assert bus.retries_used == before + 1 + bus.retries


def test_watchdog_arms_in_20ms_units(sim, bus):
    bus.verify()
    bus.configure()
    assert bus.arm_watchdog(45) == 60
    assert bus.watchdog_status() == {1: 3, 2: 3, 3: 3}
    bus.disarm_watchdog()
    assert bus.watchdog_status() == {1: 0, 2: 0, 3: 0}


def test_other_threads_get_busy_while_the_bus_is_claimed(bus):
    errors = []

    def other():
        try:
            bus.read_positions()
        except BusyError as exc:
            errors.append(exc)

    with bus.claim():
        thread = threading.Thread(target=other)
        thread.start()
        thread.join()
        bus.read_positions()                   # the owner itself may re-enter
    assert len(errors) == 1 and errors[0].exit_code == 4
    bus.read_positions()


def test_open_close_leaks_no_fds(sim):
    fds = len(os.listdir("/proc/self/fd"))
    for _ in range(20):
        with ServoBus(sim.port_path, servos=specs()) as b:
            b.read(1, ADDR_GOAL_POSITION, 4)
    assert len(os.listdir("/proc/self/fd")) == fds


# -- scan and the CLI --------------------------------------------------------------------------

def test_scan_lists_id_model_firmware_baud():
    with SimBus((1, 4), model={1: "xm430-w350", 4: "xl430-w250"}, firmware={1: 46, 4: 44},
                timing="fast") as sim:
        by_ping = scan(sim.port_path, ids=[1, 2, 3, 4])
        broadcast = scan(sim.port_path)
        wrong_baud = scan(sim.port_path, [57_600], ids=[1, 4])
    expected = [(1, "xm430-w350", 46, 1_000_000), (4, "xl430-w250", 44, 1_000_000)]
    assert [(s.id, s.model, s.firmware, s.baud) for s in by_ping] == expected
    assert [(s.id, s.model, s.firmware, s.baud) for s in broadcast] == expected
    assert wrong_baud == []


def test_cli_scan_prints_the_servos(capsys):
    with SimBus((2, 3), timing="fast") as sim:
        code = cli.main(["scan", "--port", sim.port_path, "--ids", "1-3", "--json"])
        out = json.loads(capsys.readouterr().out)
        assert code == 0
        assert [s["id"] for s in out["servos"]] == [2, 3]
        assert {s["model"] for s in out["servos"]} == {"xm430-w350"}
        assert cli.main(["scan", "--port", sim.port_path, "--ids", "2"]) == 0
        table = capsys.readouterr().out.splitlines()
        assert table[0].split()[:2] == ["ID", "model"] and table[1].split()[:2] == ["2",
                                                                                  "xm430-w350"]
        assert cli.main(["scan", "--port", sim.port_path, "--ids", "7"]) == 4  # no servo: a fault


def test_cli_scan_errors_are_one_line_with_exit_codes(capsys, tmp_path):
    assert cli.main(["scan"]) == 2
    assert capsys.readouterr().err.startswith("robodcn: scan needs --device")
    assert cli.main(["scan", "--port", str(tmp_path / "none"), "--ids", "1"]) == 4
    assert "cannot open" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main(["scan", "--port", "x", "--ids", "300"])


def test_each_failed_try_is_logged_with_servo_and_instruction(sim, bus, caplog):
    bus.verify()
    caplog.set_level(logging.DEBUG, logger="robodcn.bus")
    sim.faults.corrupt_crc(times=1)
    bus.read(2, ADDR_PRESENT_POSITION, 4)
    tries = [r for r in caplog.records if r.name == "robodcn.bus" and "failed" in r.message]
    assert len(tries) == 1 and tries[0].levelno == logging.DEBUG
    assert "servo 2" in tries[0].message and f"read 4 byte(s) at {ADDR_PRESENT_POSITION}" \
        in tries[0].message and "try 1 of" in tries[0].message
    caplog.clear()
    sim.faults.drop(3, times=None)
    with pytest.raises(CommError):
        bus.write(3, 65, [1])
    tries = [r for r in caplog.records if r.name == "robodcn.bus" and "failed" in r.message]
    assert len(tries) == bus.retries + 1
    assert all("servo 3: write 1 byte(s) at 65" in r.message for r in tries)
    assert tries[-1].levelno == logging.WARNING
    sim.faults.clear()


def test_a_silent_servo_pings_none_after_its_retries(sim, bus):
    before = bus.retries_used
    assert bus.ping(9) is None
    assert bus.retries_used == before + bus.retries


def test_open_again_after_a_lost_device(tmp_path):
    link = str(tmp_path / "ttyDXL")
    with SimBus((1, 2, 3), timing="fast", link=link):
        bus = ServoBus(link, servos=specs(), retries=1, rx_timeout_ms=150).open()
        bus.verify()
    with pytest.raises(CommError) as err:        # the device is gone
        bus.read_positions()
    assert err.value.field == "port" and bus.lost
    with SimBus((1, 2, 3), timing="fast", link=link):
        bus.open()                               # open() on a lost bus reopens it
        assert not bus.lost and len(bus.read_positions()) == 3
        bus.close()


def test_torque_on_some_servos_only_and_unknown_ids_refused(sim3):
    from conftest import ARM3R, open_bus

    from robodcn.errors import InputError

    with open_bus(sim3, ARM3R.servos) as bus:
        bus.torque(True, [2])
        assert bus.torque_enabled() == {1: False, 2: True, 3: False}
        with pytest.raises(InputError) as exc:
            bus.torque(True, [2, 9])          # nothing written: 2 stays as it was
        assert exc.value.field == "ids" and exc.value.value == [9]
        bus.torque(False, [2])
        bus.torque(True)
        assert bus.torque_enabled() == {1: True, 2: True, 3: True}
        assert all(sim3.servo(i).torque_enabled for i in (1, 2, 3))


class _FakePort:
    """A port whose replies arrive late: every failed try leaves a straggler that
    :meth:`flush` clears; a transaction that finds a straggler takes it as its answer."""

    def __init__(self, retries: int) -> None:
        self.retries, self.retries_used, self.lost = retries, 0, False
        self.straggler: str | None = None
        self.flushes = 0

    def flush(self) -> None:
        self.flushes += 1
        self.straggler = None

    def failing(self, what: str):
        def fn() -> str:
            self.straggler = f"late reply to {what}"
            raise CommError("timeout", field="servo[1]")
        return fn

    def answering(self, what: str):
        def fn() -> str:
            return self.straggler if self.straggler is not None else f"reply to {what}"
        return fn


def test_retry_flushes_a_straggler_after_the_last_failed_try_too():
    from robodcn.bus.retry import retry
    port = _FakePort(retries=2)
    with pytest.raises(CommError):
        retry(port, "read", 1, port.failing("read"))
    assert port.retries_used == 2
    assert port.flushes == 3  # after each of the 3 failed tries, the last one too
    # the next transaction gets its own answer, not the failed read's late reply
    assert retry(port, "ping", 1, port.answering("ping")) == "reply to ping"


def test_retry_raises_a_lost_device_at_once():
    from robodcn.bus.retry import retry
    port = _FakePort(retries=3)
    port.lost = True
    with pytest.raises(CommError):
        retry(port, "read", 1, port.failing("read"))
    assert port.retries_used == 0
