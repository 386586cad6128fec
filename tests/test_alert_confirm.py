"""A hardware alert ends a move only when a second read confirms it (issue 26 §6).

One move of 742 under load ended ``fault`` with the same alert value (13) on all four servos
at once. 13 is the Bus Watchdog register of a 250 ms watchdog (20 ms units): a late reply to
a Bus Watchdog poll — a Fast Sync Read of one byte from every servo — was taken for the
answer of the next Hardware Error Status poll, one byte from every servo too (status
packets carry no sequence number; a straggler of the same size passes every check), and the
confirming read took another. firmware_sim's ``stale`` fault sends exactly that straggler
before a read's own reply; the real dynamixel-sdk reads it over the pty.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading

import pytest
from conftest import ROOT
from stream_helpers import IDS, LONG, execute, inject_at, open_bus, place

from firmware_sim.protocol import Instruction
from robodcn.bus import ADDR_GOAL_POSITION, ADDR_HARDWARE_ERROR, ADDR_PRESENT_POSITION
from robodcn.bus.control_table import ADDR_BUS_WATCHDOG

#: The example of the issue: a 250 ms Bus Watchdog reads 13 (20 ms units).
WATCHDOG_MS = 250


@pytest.fixture
def sim(sim3):
    return sim3


@pytest.mark.parametrize("times", [1, 2, 3])
def test_a_stale_watchdog_reply_is_not_taken_for_a_hardware_alert(sim, times):
    """The Bus Watchdog poll's reply arrives again before the next Hardware Error Status
    reads' (``times`` of them: the poll, the confirming read, a retry): the move completes,
    no alert."""
    with open_bus(sim) as bus:
        place(bus, LONG.ticks[0])
        # armed now: it fires once a Bus Watchdog poll has been answered (the stream's
        # health polls take turns: Hardware Error Status, then the watchdog, …)
        fault = sim.faults.stale(ADDR_BUS_WATCHDOG, address=ADDR_HARDWARE_ERROR, times=times,
                                 instructions={Instruction.FAST_SYNC_READ,
                                               Instruction.SYNC_READ})
        report = execute(LONG, bus, watchdog_ms=WATCHDOG_MS)
    assert fault.fired == times, "the straggler was not sent as often as asked"
    stale = [e for e in sim.packets("tx") if e.note.startswith("stale")]
    assert len(stale) == times and stale[0].raw.count(bytes([13])) >= len(IDS)
    assert report.stop_reason == "completed", report.message
    assert not any(report.hardware_errors.values()), report.hardware_errors


def test_a_persistent_alert_ends_the_move(sim):
    """A servo that reports an overload on every read: the move ends hardware_alert, naming
    it, after the confirming read."""
    with open_bus(sim) as bus:
        place(bus, LONG.ticks[0])
        report = execute(LONG, bus, watchdog_ms=WATCHDOG_MS,
                         progress=inject_at(20, lambda: sim.faults.trip(IDS[1])))
    assert report.stop_reason == "hardware_alert", report.message
    assert report.hardware_errors[IDS[1]] == 0x20 and "overload" in report.message
    assert report.samples_sent < report.samples_total


def test_move_on_a_firmware_sim_that_sends_stale_watchdog_replies(tmp_path) -> None:
    """``python -m firmware_sim --stale bus:of=98,read=70,n=3`` (the command line's form of
    the fault) and ``robodcn move --device`` on it, as a user runs them: the move completes
    (exit 0, or 5 when a loaded machine skipped samples), no hardware alert."""
    proc = subprocess.Popen([sys.executable, "-m", "firmware_sim", "--ids", "1,2,3", "--arm",
                             str(ROOT / "configs" / "arm3r.toml"), "--timing", "fast",
                             "--log", str(tmp_path / "wire.log"), "--stale",
                             "bus:of=98,read=70,n=3"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=ROOT)
    try:
        device = proc.stdout.readline().strip()  # type: ignore[union-attr]
        assert device.startswith("/dev/"), proc.stderr.read()  # type: ignore[union-attr]
        out = subprocess.run([sys.executable, "-m", "robodcn", "move", "--arm",
                              str(ROOT / "configs" / "arm3r.toml"), "--device", device,
                              "--to", "0.12,0.24,60", "--json"], capture_output=True,
                             text=True, timeout=60, cwd=ROOT)
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=10)
    assert out.returncode in (0, 5), out.stderr
    stale = [line for line in (tmp_path / "wire.log").read_text().splitlines()
             if "stale" in line]
    assert len(stale) == 3, "the straggler was not sent as often as asked"
    report = json.loads(out.stdout)
    assert report["stop_reason"] == "completed", report["message"]
    assert not any(report["hardware_errors"].values()), report["hardware_errors"]


def test_a_stale_position_reply_is_not_taken_for_the_goals_a_stop_holds(sim):
    """A stop holds the goals the servos hold, read back (stream.finish). The Present
    Position read at the start of the move (4 bytes from every servo) answered again in
    place of that read — the same size as Goal Position's — would be the hold: the arm sent
    back to where it started. The goals are read in a form no other read shares; the hold
    is the goal the servos were heading for, and the read-back confirms it."""
    with open_bus(sim) as bus:
        place(bus, LONG.ticks[0])
        start = [sim.servo(i).present_position for i in IDS]
        stop = threading.Event()

        def stop_now():
            sim.faults.stale(ADDR_PRESENT_POSITION, address=ADDR_GOAL_POSITION, times=2,
                             instructions={Instruction.FAST_SYNC_READ, Instruction.SYNC_READ})
            stop.set()

        report = execute(LONG, bus, stop=stop, progress=inject_at(15, stop_now))
    assert report.stop_reason == "stopped" and report.outcome == "stopped", report.message
    assert report.hold_failed is None, report.hold_failed
    assert list(report.hold_goals) == [sim.servo(i).goal_position for i in IDS]
    # where the move was, not where it started
    assert max(abs(h - s) for h, s in zip(report.hold_goals, start, strict=True)) > 50, (
        report.hold_goals, start)
    stale = [e for e in sim.packets("tx") if e.note.startswith("stale")]
    assert len(stale) == 2, "the straggler was not sent as often as asked"
