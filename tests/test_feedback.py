"""Feedback through one packet (issue 11 §2): configure maps Present Position, Velocity,
Current and Hardware Error Status into Indirect Data; one Fast Sync Read returns them."""

from __future__ import annotations

import math

import numpy as np
from conftest import ARM3R

from firmware_sim.bus import SimBus
from robodcn.bus import ADDR_FEEDBACK, FEEDBACK_LENGTH
from robodcn.planner import plan
from robodcn.simulated import simulated_arm
from robodcn.stream import execute


def test_one_fast_sync_read_per_feedback_cycle_carries_all_items():
    traj = plan(ARM3R, [(0.25, 0.10, 0.0), (0.12, 0.24, math.radians(60))], duration="auto")
    with simulated_arm(ARM3R, timing="fast", start_joints=traj.joints[0]) as sa:
        assert sa.bus.feedback_mapped and sa.bus.fast_read
        fb = sa.bus.read_feedback()
        for j, i in enumerate(ARM3R.servo_ids):
            assert fb.positions[j] == sa.sim.servo(i).present_position
        assert (fb.hardware_errors == 0).all()
        sa.sim._log_on = True
        report = execute(traj, sa.bus, health_interval=100.0)
        block = ADDR_FEEDBACK.to_bytes(2, "little") + FEEDBACK_LENGTH.to_bytes(2, "little")
        reads = [e for e in sa.sim.log if e.direction == "rx"
                 and e.instruction == "FAST_SYNC_READ" and e.params[:4] == block]
    assert report.stop_reason == "completed", report.message
    assert report.feedback_reads >= len(traj.t) - 1
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
