"""The streaming loop's schedule on virtual time (:class:`robodcn.stream.VirtualClock`):
which sample goes out when, late samples sent or skipped, a stop acted on between two
samples — the logic of :mod:`robodcn.stream.loop`, through the real dynamixel-sdk against
firmware_sim (kinematic), without depending on the host's timing. The clock moves only when
the loop waits, so every sample is exactly on time unless a test makes it late
(``clock.advance``: a stalled host)."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from stream_helpers import ARM, RATE, TRAJ, execute, history, inject_at, open_bus

from robodcn.bus import ServoBus
from robodcn.stream import StopSignal, VirtualClock


@pytest.fixture
def sim(sim3):
    return sim3


def place(bus: ServoBus, ticks) -> None:
    """The simulated (kinematic) arm at ``ticks``: there at once (stream_helpers' ``place``
    waits for an arm that moves)."""
    bus.verify()
    bus.configure()
    bus.write_goals(np.asarray(ticks))
    assert np.abs(bus.read_positions() - ticks).max() <= 1


def test_every_sample_goes_out_at_its_due_time(sim):
    clock = VirtualClock(start=10.0)
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        before = len(history(sim))
        report = execute(TRAJ, bus, clock=clock, watchdog_ms=0)
    assert report.outcome == "done" and report.overruns == 0, report.headline
    assert np.array_equal(history(sim)[before:], TRAJ.ticks)
    # sample i is due at t0 + i/rate, and sent then: no jitter, no lateness, the plan's
    # duration and rate exactly (the last sample's cycle ends on its slot)
    assert report.lateness_max_s == 0.0 and report.jitter_max_s == pytest.approx(0, abs=1e-12)
    assert report.achieved_rate_hz == pytest.approx(RATE, rel=1e-9)
    assert report.duration_s == pytest.approx((len(TRAJ.t) - 1) / RATE, abs=1e-9)


def test_late_samples_are_all_sent_without_skip_late(sim):
    clock = VirtualClock()
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        before = len(history(sim))
        report = execute(TRAJ, bus, skip_late=False, clock=clock, watchdog_ms=0,
                         progress=inject_at(5, lambda: clock.advance(3.5 / RATE)))
    assert report.completed and report.overruns >= 1 and report.samples_skipped == 0
    assert np.array_equal(history(sim)[before:], TRAJ.ticks)
    # 3.5 periods pass after sample 5: samples 6, 7, 8 go out back to back (2.5, 1.5 and
    # 0.5 periods late), sample 9 on time again
    assert report.overruns == 3
    assert report.lateness_max_s == pytest.approx(2.5 / RATE)


def test_overruns_skip_ahead_without_accumulating(sim):
    clock = VirtualClock()
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        before = len(history(sim))
        report = execute(TRAJ, bus, clock=clock, watchdog_ms=0,
                         progress=inject_at(5, lambda: clock.advance(3.5 / RATE)))
    # Skipping samples is not "all samples sent": the outcome and headline say so.
    assert report.stop_reason == "completed" and not report.completed, report.message
    assert report.outcome == "degraded" and report.skipped == report.samples_skipped
    assert report.headline == (f"completed with {report.skipped} of "
                               f"{report.samples_total} samples skipped")
    data = report.to_dict()
    assert data["outcome"] == "degraded" and data["completed"] is False
    assert data["skipped"] == report.skipped and "all samples sent" not in data["message"]
    assert report.overruns >= 1 and report.samples_skipped >= 2
    # 3.5 periods pass after sample 5: the slots of 6 and 7 have passed, 8 goes out half a
    # period late
    assert report.overruns == 1 and report.samples_skipped == 2
    assert report.samples_sent + report.samples_skipped == report.samples_total
    # The schedule did not slip: the run still ends on the planned clock.
    assert report.duration_s == pytest.approx(TRAJ.duration, abs=5 / RATE)
    assert report.duration_s == pytest.approx((len(TRAJ.t) - 1) / RATE, abs=1e-9)
    # What was sent: the plan up to the stall; then, where the skipped samples would make
    # the goal jump beyond a joint's v_max·T, the step guard slews toward the plan at that
    # step (robodcn.stream.step_guard) and rejoins it; it ends on the last sample. Every
    # written goal steps at most v_max·T (+1 tick of rounding) from the one before.
    sent = history(sim)[before:]
    assert np.array_equal(sent[:6], TRAJ.ticks[:6])
    assert np.array_equal(sent[-1], TRAJ.ticks[-1])
    step = np.array([j.max_velocity / RATE * j.servo.ticks_per_turn / (2 * np.pi)
                     for j in ARM.joints])
    assert (np.abs(np.diff(sent, axis=0)) <= step + 1).all()
    # it rejoins the plan: the tail of what was sent is the plan's own tail
    tail = min(10, len(sent) - 8)
    assert np.array_equal(sent[-tail:], TRAJ.ticks[-tail:])


def test_a_stop_while_the_loop_waits_ends_it_before_the_next_sample(sim):
    clock = VirtualClock()
    stop = StopSignal()
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        before = len(history(sim))
        clock.hold(0.0)
        result = {}
        thread = threading.Thread(target=lambda: result.update(
            report=execute(TRAJ, bus, clock=clock, watchdog_ms=0, stop=stop)))
        thread.start()
        try:
            assert clock.wait_parked()
            clock.hold(clock.now() + 9.5 / RATE)     # samples 0 … 9 go out, then it waits
            assert clock.wait_parked()
            stop.request("operator stop")
        finally:
            clock.release()
        thread.join(10)
    report = result["report"]
    assert report.stop_reason == "stopped" and report.message == "operator stop"
    assert report.samples_sent == 10
    # the ten samples, then the hold (the present positions: where the last one put it)
    assert np.array_equal(history(sim)[before:before + 10], TRAJ.ticks[:10])
    assert report.hold_goals == tuple(int(v) for v in TRAJ.ticks[9])
