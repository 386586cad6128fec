"""robodcn.stream.execute through the real dynamixel-sdk against firmware_sim (timing "fast")."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
import warnings

import numpy as np
import pytest
from conftest import ROOT
from stream_helpers import (
    ARM,
    IDS,
    LONG,
    RATE,
    TRAJ,
    assert_holds,
    execute,
    history,
    inject_at,
    open_bus,
    place,
    present,
    write_count,
)

import robodcn
from firmware_sim.bus import SimBus
from robodcn import cli, servo_units
from robodcn.bus import ADDR_FEEDBACK, ADDR_PRESENT_POSITION, ServoBus, cycle_wire_time
from robodcn.errors import (
    CommError,
    InputError,
)
from robodcn.planner import Trajectory
from robodcn.stream import (
    STOP_REASONS,
    ExecutionOptions,
    RateWarning,
    StopSignal,
    check_rate,
    tracking_error,
)


@pytest.fixture
def sim(sim3):
    return sim3


# -- the happy path ----------------------------------------------------------------------------

@pytest.mark.serial  # its rate is wall-clock (skip_late=False): a loaded parallel pass had 72 Hz
def test_trajectory_executes_end_to_end(sim):
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        before = len(history(sim))
        report = execute(TRAJ, bus, settle=2.0, skip_late=False, tracking_limit=None)
    assert report.stop_reason == "completed" and report.completed, report.message
    assert report.samples_sent == report.samples_total == len(TRAJ.ticks)
    assert report.samples_skipped == 0 and report.hold_goals is None
    # Every goal the simulator accepted during the run is the plan, in order.
    assert np.array_equal(history(sim)[before:], TRAJ.ticks)
    # Feedback: the arm reached the end; tracking stayed within the limit.
    assert report.final_positions == tuple(present(sim))
    assert max(abs(e) for e in report.final_error_ticks) <= 1
    assert np.abs(np.array(present(sim)) - TRAJ.ticks[-1]).max() <= 1
    # One read per cycle: positions, or a health poll in its place (never on the last).
    assert report.health_polls >= 1
    assert report.feedback_reads + report.health_polls == report.samples_sent
    if report.overruns == 0:
        # On time, the simulated servos follow within the last commanded step. (A loaded
        # machine that delays the stream makes the servos lag a burst of late goals.)
        assert max(report.tracking_error_max_rad) < 0.05
    assert all(r <= m + 1e-12 for r, m in zip(report.tracking_error_rms_rad,
                                               report.tracking_error_max_rad, strict=True))
    per_tick = np.array([2 * math.pi / s.ticks_per_turn for s in ARM.servos])
    # The ticks are the radians rounded (a read that lands between two slots compares with
    # the plan interpolated there: a fraction of a tick, which rounds away).
    assert np.array_equal(report.tracking_error_max_ticks,
                          np.round(np.array(report.tracking_error_max_rad) / per_tick))
    assert report.fast_read and report.comm_failures == 0
    # Timing (loose: the suite shares two cores with everything else).
    assert report.achieved_rate_hz == pytest.approx(RATE, rel=0.1)
    assert report.duration_s == pytest.approx(TRAJ.duration, abs=5 / RATE)
    assert report.jitter_p50_s <= report.jitter_p99_s <= report.jitter_max_s
    data = json.loads(json.dumps(report.to_dict()))
    assert data["stop_reason"] == "completed" and data["servo_ids"] == list(IDS)
    # Completed moves keep holding, torque on, watchdog disarmed.
    assert all(sim.servo(i).torque_enabled for i in IDS)
    assert [sim.servo(i).read(98, 1)[1] for i in IDS] == [b"\x00"] * 3


def test_feedback_every_k_samples_and_at_the_end(sim):
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        sim.clear_log()
        report = execute(TRAJ, bus, feedback_every=4, health_interval=10.0, skip_late=False)
    n = len(TRAJ.ticks)
    expected = sum(1 for i in range(n) if i % 4 == 0 or i == n - 1)
    assert report.completed and report.feedback_reads == expected
    def reads_at(address: int) -> int:
        return sum(1 for e in sim.packets("rx", "FAST_SYNC_READ")
                   if int.from_bytes(e.params[:2], "little") == address)
    # The streaming reads are one Fast Sync Read each of the feedback block (positions,
    # velocities, currents, hardware errors); the pre-flight and final reads are positions.
    assert reads_at(ADDR_FEEDBACK) == expected
    assert reads_at(ADDR_PRESENT_POSITION) == 2
    assert len(sim.packets("rx", "SYNC_WRITE")) == n


def test_release_turns_torque_off_at_the_end(sim):
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        report = execute(TRAJ, bus, release=True)
    # Not about skips (a loaded machine may skip a sample: outcome "degraded").
    assert report.stop_reason == "completed" and report.released, report.message
    assert not any(sim.servo(i).torque_enabled for i in IDS)


# -- faults stop the stream and the arm holds --------------------------------------------------

@pytest.mark.parametrize("fault", ["drop", "corrupt_crc"])
def test_comm_faults_stop_with_comm_failure_and_hold(sim, fault):
    with open_bus(sim, retries=2, rx_timeout_ms=30) as bus:
        place(bus, TRAJ.ticks[0])
        arm = getattr(sim.faults, fault)
        report = execute(LONG, bus, max_comm_failures=3,
                         progress=inject_at(1, lambda: arm(IDS[1], times=None)))
        sim.faults.clear()
    assert report.stop_reason == "comm_failure", report.message
    assert report.comm_failures == 3 and report.retries >= 3 * bus.retries
    assert report.samples_sent < report.samples_total
    assert_holds(sim, report)


def test_overload_stops_with_hardware_alert(sim):
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        report = execute(LONG, bus, progress=inject_at(1, lambda: sim.faults.trip(IDS[0])))
    assert report.stop_reason == "hardware_alert", report.message
    assert report.hardware_errors[IDS[0]] == 0x20 and "overload" in report.message
    assert report.samples_sent < report.samples_total
    # The servo's Shutdown already took its torque off; the others hold.
    assert not sim.servo(IDS[0]).torque_enabled
    assert report.hold_goals is not None
    assert [sim.servo(i).goal_position for i in IDS] == list(report.hold_goals)


def test_health_poll_catches_an_alert_in_write_only_streaming(sim):
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        sim.clear_log()
        report = execute(LONG, bus, feedback_every=0, health_interval=0.03,
                         progress=inject_at(1, lambda: sim.faults.trip(IDS[2], 0x20)))
    assert report.stop_reason == "hardware_alert", report.message
    assert report.feedback_reads == 0 and report.health_polls >= 1
    assert report.hardware_errors[IDS[2]] == 0x20
    # Only the pre-flight and the final read asked for Present Position; the hold re-writes
    # the goals the servos hold (Goal Position, 116, read with Profile Velocity from 112:
    # robodcn.bus.reads), so it does not jump back to a lagging present position.
    def reads_of(address):
        return [e for e in sim.packets("rx", "FAST_SYNC_READ")
                if int.from_bytes(e.params[:2], "little") == address]
    assert len(reads_of(132)) == 2               # pre-flight, final
    assert len(reads_of(112)) >= 1               # the hold


def test_host_stall_past_the_watchdog_stops_with_hardware_alert(sim):
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        report = execute(LONG, bus, watchdog_ms=40,
                         progress=inject_at(1, lambda: time.sleep(0.15)))
    assert report.stop_reason == "hardware_alert" and "watchdog" in report.message
    # The hold disarmed the tripped watchdog, which made goals writable again.
    assert [sim.servo(i).read(98, 1)[1] for i in IDS] == [b"\x00"] * 3
    assert_holds(sim, report)


def test_tracking_error_above_the_limit_stops(sim):
    long = LONG
    with open_bus(sim) as bus:
        place(bus, long.ticks[0])
        # The shoulder stops following without any alert: its torque goes off behind our back.
        report = execute(long, bus, tracking_limit=0.05, progress=inject_at(
            1, lambda: sim.servo(IDS[0]).write(64, b"\x00")))
    assert report.stop_reason == "tracking_error", report.message
    assert "'shoulder'" in report.message
    assert report.tracking_error_max_rad[0] > 0.05
    assert report.samples_sent < report.samples_total
    assert report.hold_goals is not None
    assert [sim.servo(i).goal_position for i in IDS] == list(report.hold_goals)


def test_stop_request_stops_within_two_periods(sim):
    stop = StopSignal()
    marks = {}
    slow = robodcn.plan(ARM, [ARM.home, (0.15, 0.25, 1.2)], rate_hz=RATE, duration=2.0)
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        before = len(history(sim))

        def watcher():
            while len(sim.goal_history(IDS[0])) < before + 10:
                time.sleep(0.0005)
            marks["t"] = time.perf_counter()
            stop.request("operator stop")
            marks["count"] = len(sim.goal_history(IDS[0]))

        thread = threading.Thread(target=watcher)
        thread.start()
        report = execute(slow, bus, stop=stop)
        returned = time.perf_counter()
        thread.join()
    assert report.stop_reason == "stopped" and report.message == "operator stop"
    assert 10 <= report.samples_sent < report.samples_total
    assert len(sim.goal_history(IDS[0])) - 1 >= marks["count"]            # minus the hold
    # The loop left (no write after that) within two periods of the request.
    assert report.stop_latency_s is not None and 0 <= report.stop_latency_s < 2 / RATE
    assert returned - marks["t"] < 2 / RATE + 0.5           # + the hold's round trips
    assert_holds(sim, report)


def test_a_threading_event_stops_too(sim):
    event = threading.Event()
    event.set()
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        report = execute(TRAJ, bus, stop=event)
    assert report.stop_reason == "stopped" and report.samples_sent == 0
    assert_holds(sim, report)


# -- resources ---------------------------------------------------------------------------------

def test_no_thread_or_fd_leak_after_100_executions(sim):
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        here = bus.read_positions()
    joints = servo_units.ticks_to_radians(here, ARM.servos)
    short = Trajectory(t=np.arange(3) / 1000.0, poses=np.zeros((3, 3)),
                       joints=np.tile(joints, (3, 1)), ticks=np.tile(here, (3, 1)),
                       joint_names=ARM.joint_names, servo_ids=IDS, rate_hz=1000.0,
                       method="sclerp")
    fds = len(os.listdir("/proc/self/fd"))
    threads = threading.active_count()
    for _ in range(100):
        with open_bus(sim) as bus:
            report = execute(short, bus)
        # Not about skips: at 1 kHz a loaded machine may skip one (outcome "degraded").
        assert report.stop_reason == "completed", report.message
    assert len(os.listdir("/proc/self/fd")) == fds
    assert threading.active_count() == threads


def test_stop_reasons_are_the_documented_ones():
    assert STOP_REASONS == ("completed", "stopped", "comm_failure", "hardware_alert",
                            "tracking_error", "collision")


def test_realtime_priority_is_restored_or_warned(sim):
    policy = os.sched_getscheduler(0)
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            report = execute(TRAJ, bus, realtime=True)
    assert report.stop_reason == "completed", report.message
    # Either the stream ran under SCHED_FIFO or the caller was told why not.
    warned = any(issubclass(w.category, RuntimeWarning) and "SCHED_FIFO" in str(w.message)
                 for w in caught)
    assert report.realtime != warned
    assert os.sched_getscheduler(0) == policy


def test_scan_and_execute_against_python_m_firmware_sim(capsys):
    """The acceptance path: a separate ``python -m firmware_sim`` process on its pty."""
    # About the protocol path (scan, verify, stream, settle), not the physics: the kinematic
    # model, whose servos reach each goal, so the final position is the last goal to a tick.
    # The physics default is exercised by tests/test_compensation.py and test_collision.py.
    proc = subprocess.Popen([sys.executable, "-m", "firmware_sim", "--ids", "1,2,3",
                             "--timing", "fast", "--dynamics", "off"], cwd=ROOT,
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        port = proc.stdout.readline().strip()
        assert cli.main(["scan", "--port", port, "--ids", "1-4", "--json"]) == 0
        found = json.loads(capsys.readouterr().out)["servos"]
        assert [(s["id"], s["model"]) for s in found] == [(i, "xm430-w350") for i in IDS]
        with ServoBus(port, servos=ARM.servos, retries=5) as bus:
            report = execute(TRAJ, bus, approach=True, settle=2.0)
            assert report.stop_reason == "completed", report.message
            assert np.abs(bus.read_positions() - TRAJ.ticks[-1]).max() <= 1
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(10)
        if proc.stdout is not None:
            proc.stdout.close()


# -- issue 9: options, rate warning, lost device, present pose ---------------------------------

def test_execution_options_are_one_validated_object(sim):
    opts = ExecutionOptions(feedback_every=2, tracking_limit=None, settle=1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        opts.settle = 0.0  # type: ignore[misc]
    for bad, field in (({"feedback_every": True}, "feedback_every"),
                       ({"health_interval": 0}, "health_interval"),
                       ({"watchdog_ms": -1}, "watchdog_ms"), ({"release": "yes"}, "release"),
                       ({"progress": 3}, "progress")):
        with pytest.raises(InputError) as err:
            # (data fields on the options, hooks such as progress on its ExecutionHooks)
            ExecutionOptions.build(None, bad)
        assert err.value.field == field
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        with pytest.raises(InputError) as err:
            execute(TRAJ, bus, feedback_evry=2)
        assert err.value.field == "feedback_evry"
        writes = write_count(sim)
        report = execute(TRAJ, bus, opts, skip_late=False)   # keywords over the object
    assert write_count(sim) > writes
    assert report.stop_reason == "completed", report.message
    # feedback_every=2: positions on every other sample (at most) and on the last.
    assert 2 <= report.feedback_reads <= len(TRAJ.ticks) // 2 + 1


def test_wire_time_model_matches_the_notes_table():
    # dynamixel-notes §5: N = 3 / 6 at 1 Mbps, RDT 0 and 500 µs.
    for n, write, sync, fast in ((3, 290, 910, 780), (6, 440, 1540, 1200)):
        assert cycle_wire_time(n, 1_000_000, feedback="none") == pytest.approx(write * 1e-6)
        assert cycle_wire_time(n, 1_000_000, feedback="sync") == pytest.approx(sync * 1e-6)
        assert cycle_wire_time(n, 1_000_000, feedback="fast") == pytest.approx(fast * 1e-6)
    assert cycle_wire_time(3, 1_000_000, feedback="sync", return_delay_us=500) == \
        pytest.approx(2410e-6)
    assert cycle_wire_time(6, 2_000_000, feedback="fast", return_delay_us=500) == \
        pytest.approx(1100e-6)
    with pytest.raises(InputError) as err:
        cycle_wire_time(3, 1_000_000, feedback="bulk")
    assert err.value.field == "feedback"


def test_rate_above_what_the_bus_carries_warns_before_streaming():
    assert check_rate(1000, 3, 1_000_000) is None                 # 780 µs < 1 ms
    warning = check_rate(1000, 6, 1_000_000, fast_read=False)     # 1540 µs > 1 ms
    assert isinstance(warning, RateWarning) and warning.info.max_rate_hz < 1000
    assert check_rate(1000, 6, 1_000_000, fast_read=False, feedback_every=4) is None
    # 57 600 baud: 3 servos with a read-back every sample need 13.5 ms; 100 Hz is too fast.
    with SimBus(IDS, baud=57_600, timing="fast") as slow:
        with ServoBus(slow.port_path, 57_600, servos=ARM.servos, retries=3,
                      rx_timeout_ms=150) as bus:
            place(bus, TRAJ.ticks[0])
            with pytest.warns(RateWarning, match="more than the bus carries"):
                report = execute(TRAJ, bus, tracking_limit=None)
    assert [w["code"] for w in report.warnings] == [RateWarning.code]
    assert report.to_dict()["warnings"][0]["max_rate_hz"] < RATE


def test_progress_and_report_share_the_tracking_error(sim):
    seen = []
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        report = execute(TRAJ, bus, tracking_limit=None, progress=seen.append)
    errors = [p.tracking_error_rad for p in seen if p.tracking_error_rad is not None]
    assert errors and all(len(e) == len(IDS) for e in errors)
    # Every live value is one of the report's samples: never above the report's maximum.
    assert all(e[j] <= report.tracking_error_max_rad[j] + 1e-12
               for e in errors for j in range(len(IDS)))
    present = np.array([5, 20, -7])
    previous, goal = np.array([0, 10, 0]), np.array([10, 15, -5])
    assert tracking_error(present, previous, goal).tolist() == [0, 5, -2]


def test_losing_the_serial_device_mid_move_is_a_fault_with_a_report(tmp_path):
    link = str(tmp_path / "ttyDXL")
    sim = SimBus(IDS, timing="fast", link=link).start()
    try:
        bus = ServoBus(link, servos=ARM.servos, retries=3, rx_timeout_ms=150).open()
        place(bus, TRAJ.ticks[0])
        report = execute(LONG, bus, progress=inject_at(3, sim.close))
    finally:
        sim.close()
    assert report.outcome == "fault" and report.stop_reason == "comm_failure"
    assert "lost" in report.message and not report.completed
    assert 0 < report.samples_sent < report.samples_total
    assert bus.lost
    bus.close()                                   # a lost device does not make close raise
    bus.close()
    # The device comes back (same link): the bus opens again and streams.
    with SimBus(IDS, timing="fast", link=link) as back:
        bus.reopen()
        assert not bus.lost and bus.is_open
        place(bus, TRAJ.ticks[0])
        again = execute(TRAJ, bus, skip_late=False)
        bus.close()
    assert again.outcome == "done", again.message
    assert len(back.goal_history(IDS[0])) >= len(TRAJ.ticks)


def test_reads_on_a_lost_device_are_comm_errors_not_tracebacks(sim):
    bus = open_bus(sim, retries=1, rx_timeout_ms=30)
    bus.verify()
    sim.close()                                   # the pty goes away under the SDK
    for call in (bus.read_positions, bus.torque_enabled, lambda: bus.write_goals(
            TRAJ.ticks[0])):
        with pytest.raises(CommError) as err:
            call()
        assert err.value.field == "port" and bus.lost
    bus.close()


