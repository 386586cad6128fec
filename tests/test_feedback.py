"""Feedback through one packet (issue 11 §2): configure maps Present Position, Velocity,
Current and Hardware Error Status into Indirect Data; one Fast Sync Read returns them."""

from __future__ import annotations

import math

import numpy as np
from conftest import ARM3R, lockstep_arm

from firmware_sim.bus import SimBus
from robodcn.bus import ADDR_FEEDBACK, FEEDBACK_LENGTH
from robodcn.planner import plan
from robodcn.stream import execute


def test_one_fast_sync_read_per_feedback_cycle_carries_all_items():
    traj = plan(ARM3R, [(0.25, 0.10, 0.0), (0.12, 0.24, math.radians(60))], duration="auto")
    # virtual time (conftest.lockstep_arm): a starved in-process simulator answers late,
    # not wrongly; the invariant below also holds for a real-time run with skipped samples
    with lockstep_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as (sa, clock):
        assert sa.bus.feedback_mapped and sa.bus.fast_read
        fb = sa.bus.read_feedback()
        for j, i in enumerate(ARM3R.servo_ids):
            assert fb.positions[j] == sa.sim.servo(i).present_position
        assert (fb.hardware_errors == 0).all()
        sa.sim.keep_log()
        report = execute(traj, sa.bus, health_interval=100.0, clock=clock)
        block = ADDR_FEEDBACK.to_bytes(2, "little") + FEEDBACK_LENGTH.to_bytes(2, "little")
        reads = [e for e in sa.sim.log if e.direction == "rx"
                 and e.instruction == "FAST_SYNC_READ" and e.params[:4] == block]
    assert report.stop_reason == "completed", report.message
    # One read per cycle that ran: every sample sent (feedback_every 1, no health cycle in
    # 100 s) is followed by its read; a sample skipped late is neither written nor read, and
    # a read that failed after the bus's retries is a comm failure (as a failed write is).
    failed_reads = report.comm_failures - (report.skipped - report.skipped_late)
    assert report.health_polls == 0
    assert report.feedback_reads == report.samples_sent - failed_reads, report.message
    assert report.samples_sent + report.skipped == len(traj.t)
    assert len(reads) >= report.feedback_reads
    # Velocities and currents came from the same reads: the shoulder moved and drew current.
    assert report.velocity_peak_rad_s is not None and report.velocity_peak_rad_s[0] > 0.5
    assert report.current_peak_a is not None and report.current_peak_a[0] > 0.05
    assert report.current_limit_a == tuple(1193 * 2.69e-3 for _ in ARM3R.servo_ids)


def test_plain_sync_read_fallback_decodes_the_same_block():
    with SimBus((1, 2, 3), timing="fast", firmware=44, dynamics=True,
                positions={1: 1000, 2: 2000, 3: 3000}) as sim:
        from conftest import open_bus
        with open_bus(sim, ARM3R.servos) as bus:
            bus.verify()
            assert bus.fast_read is False
            bus.configure()
            fb = bus.read_feedback()
            assert fb.positions.tolist() == [1000, 2000, 3000]
            assert np.allclose(fb.velocities, 0.0, atol=0.05)
            raw = bus.sync_read(ADDR_FEEDBACK, FEEDBACK_LENGTH)
            assert len(raw) == 3 and all(len(b) == FEEDBACK_LENGTH for b in raw)


def test_wire_model_counts_the_feedback_block():
    from robodcn.bus import cycle_wire_time
    from robodcn.bus.wire import read_bytes, write_bytes
    from robodcn.stream import check_rate

    n = 3
    # Fast Sync Read reply: header 8 + per servo ERR, ID, L data, CRC 2 (L + 4).
    assert read_bytes(n, "fast", FEEDBACK_LENGTH) == 14 + n + 8 + (FEEDBACK_LENGTH + 4) * n
    assert read_bytes(n, "sync", FEEDBACK_LENGTH) == 14 + n + (11 + FEEDBACK_LENGTH) * n
    assert read_bytes(n, "fast") == read_bytes(n, "fast", 4) == 14 + n + 8 + 8 * n
    at_2m = cycle_wire_time(n, 2_000_000, feedback="fast", item_bytes=FEEDBACK_LENGTH)
    assert at_2m == 10 * (write_bytes(n) + read_bytes(n, "fast", FEEDBACK_LENGTH)) / 2e6
    assert at_2m < 1e-3                     # 1 kHz fits at 2 Mbps
    assert check_rate(1000, n, 2_000_000, item_bytes=FEEDBACK_LENGTH) is None
    # At 1 Mbps the block needs ~1 ms: a 1.1 kHz stream is more than the wire carries.
    assert check_rate(1100, n, 1_000_000, item_bytes=FEEDBACK_LENGTH) is not None


def test_near_limits_names_joint_quantity_and_where():
    from robodcn.stream.report import near_limits

    values = np.array([[0.1, 0.5], [0.95, 0.6], [0.5, 0.91]])
    out = near_limits(("a", "b"), np.array([0, 5, 9]), np.array([0.0, 0.05, 0.09]),
                      {"current": (values, np.array([1.0, 1.0]))})
    assert [(o["joint"], o["sample"], o["time_s"]) for o in out] == [("a", 5, 0.05),
                                                                     ("b", 9, 0.09)]
    assert out[0]["peak"] == 0.95 and out[1]["limit"] == 1.0
    assert near_limits(("a", "b"), np.array([0]), np.array([0.0]),
                       {"current": (values[:1], np.array([1.0, 1.0]))}) == ()


def test_the_reports_near_limit_marks_agree_with_its_peaks():
    traj = plan(ARM3R, [(0.25, 0.10, 0.0), (0.12, 0.24, math.radians(60))], duration="auto")
    with lockstep_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as (sa, clock):
        # Every mark must agree with the peaks the report states (none is invented or lost).
        report = execute(traj, sa.bus, clock=clock, compensation=False,
                         tracking_limit=math.radians(30), collision=False)
    assert report.stop_reason == "completed", report.message
    marks = report.to_dict()["near_limits"]
    for mark in marks:
        assert mark["peak"] >= mark["value"] >= 0.9 * mark["limit"]
        assert 0 <= mark["sample"] < len(traj.t) and mark["time_s"] == traj.t[mark["sample"]]
    for j, name in enumerate(report.joint_names):
        near_tracking = report.tracking_error_max_rad[j] >= 0.9 * math.radians(30)
        assert near_tracking == any(m["joint"] == name and m["quantity"] == "tracking_error"
                                    for m in marks)
        near_threshold = report.current_peak_a[j] >= 0.9 * report.collision_threshold_a[j]
        assert near_threshold == any(m["joint"] == name and m["quantity"] ==
                                     "collision_current" for m in marks)


def test_decode_feedback_signed_items_and_units():
    from robodcn.bus.feedback import (
        VELOCITY_UNIT_RAD_S,
        current_units,
        decode_feedback,
        indirect_map,
    )

    def block(pos: int, vel: int, cur: int, err: int) -> bytes:
        return (pos.to_bytes(4, "little", signed=True) + vel.to_bytes(4, "little", signed=True)
                + cur.to_bytes(2, "little", signed=True) + bytes([err]))

    fb = decode_feedback([block(-70000, -12, -300, 0), block(4095, 7, 1000, 0x20)],
                         current_units(["xm430-w350", "xl430-w250"]))
    assert fb.positions.tolist() == [-70000, 4095]
    assert np.allclose(fb.velocities, [-12 * VELOCITY_UNIT_RAD_S, 7 * VELOCITY_UNIT_RAD_S])
    assert np.allclose(fb.currents, [-300 * 2.69e-3, 1000 * 1.4e-3])   # XL: 0.1 % of 1.4 A
    assert fb.hardware_errors.tolist() == [0, 0x20]
    # The map names each feedback byte's source address, little-endian, 2 bytes an entry.
    addresses = [int.from_bytes(bytes(indirect_map()[i:i + 2]), "little")
                 for i in range(0, 2 * FEEDBACK_LENGTH, 2)]
    assert addresses == [132, 133, 134, 135, 128, 129, 130, 131, 126, 127, 70]
