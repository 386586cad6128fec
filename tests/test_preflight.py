"""Before the first write (robodcn.stream.preflight) and moving from the present pose
(robodcn.present): refusals, the approach, the present ticks a caller has just read;
through the real dynamixel-sdk against firmware_sim (timing "fast")."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ARM2R
from stream_helpers import (
    ARM,
    IDS,
    RATE,
    TRAJ,
    execute,
    history,
    open_bus,
    place,
    write_count,
)

import robodcn
from firmware_sim.bus import SimBus
from robodcn import servo_units
from robodcn.bus import ADDR_PRESENT_POSITION
from robodcn.errors import (
    HardwareAlertError,
    InputError,
    ServoMismatchError,
    StartMismatchError,
    TickLimitError,
)
from robodcn.present import approach_of, plan_from_present, present_joints


@pytest.fixture
def sim(sim3):
    return sim3


# -- refusals before any write -----------------------------------------------------------------

def test_missing_servo_is_refused_before_any_write():
    with SimBus(IDS[:2], timing="fast") as sim, open_bus(sim, retries=0) as bus:
        with pytest.raises(ServoMismatchError, match=rf"\[{IDS[2]}\]"):
            execute(TRAJ, bus)
        assert write_count(sim) == 0


def test_wrong_model_is_refused_before_any_write():
    models = {i: "xm430-w350" for i in IDS} | {IDS[1]: "xl430-w250"}
    with SimBus(IDS, model=models, timing="fast") as sim, open_bus(sim) as bus:
        with pytest.raises(ServoMismatchError, match="xl430-w250") as err:
            execute(TRAJ, bus)
        assert err.value.value["wrong_model"] == [IDS[1]]
        assert write_count(sim) == 0


def test_out_of_limit_tick_is_refused_before_any_write(sim):
    # The servos' own Position Limits are tighter than the plan (the servo would refuse).
    low = int(TRAJ.ticks[:, 1].min()) + 5
    for i in IDS:
        sim.servo(i).write(52, low.to_bytes(4, "little"))
    with open_bus(sim) as bus:
        with pytest.raises(TickLimitError, match=f"servo {IDS[1]}") as err:
            execute(TRAJ, bus)
    assert TRAJ.ticks[err.value.sample, 1] < low
    assert write_count(sim) == 0


def test_arm_far_from_start_is_refused_before_any_write(sim):
    with open_bus(sim) as bus:
        with pytest.raises(StartMismatchError, match="approach=True"):
            execute(TRAJ, bus)
    assert write_count(sim) == 0


def test_hardware_error_before_start_is_refused(sim):
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        sim.faults.trip(IDS[2], 0x04)
        writes = write_count(sim)
        with pytest.raises(HardwareAlertError, match="overheating"):
            execute(TRAJ, bus)
    assert write_count(sim) == writes


def test_approach_segment_starts_from_the_present_positions(sim):
    with open_bus(sim) as bus:
        bus.verify()
        start = bus.read_positions()
        report = execute(TRAJ, bus, approach=True, settle=2.0, skip_late=False,
                         tracking_limit=None)
    assert report.completed and report.approach is not None, report.message
    # The inserted approach is reported with its samples and duration.
    approach = report.approach
    assert approach.samples == report.samples_total - len(TRAJ.ticks)  # path starts at n
    assert approach.duration_s == pytest.approx(approach.samples / RATE)
    assert report.to_dict()["approach"] == {"samples": approach.samples,
                                            "duration_s": approach.duration_s}
    goals = history(sim)
    assert report.samples_sent > len(TRAJ.ticks)
    streamed = goals[-report.samples_sent:]
    # The approach leaves from where the arm was (within half a tick of the planner's
    # joint-space start) and ends on the original plan.
    assert np.abs(streamed[0] - start).max() <= 1
    assert np.array_equal(streamed[-len(TRAJ.ticks):], TRAJ.ticks)


def test_trajectory_for_other_servos_is_refused(sim):
    with open_bus(sim, servos=ARM.servos[:2]) as bus:
        with pytest.raises(ServoMismatchError, match="same order"):
            execute(TRAJ, bus)


@pytest.mark.parametrize("kwargs, field", [
    ({"feedback_every": -1}, "feedback_every"), ({"max_comm_failures": 0}, "max_comm_failures"),
    ({"tracking_limit": 0.0}, "tracking_limit"), ({"start_tolerance": math.nan},
                                                   "start_tolerance"),
    ({"stop": object()}, "stop"), ({"settle": -1.0}, "settle"),
])
def test_bad_arguments_name_the_field(sim, kwargs, field):
    with open_bus(sim) as bus:
        with pytest.raises(InputError) as err:
            execute(TRAJ, bus, **kwargs)
    assert err.value.field == field
    assert write_count(sim) == 0


# -- moving from the present pose -------------------------------------------------------------

def test_present_joints_and_plan_from_present(sim):
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        q = present_joints(ARM, bus, verify=True)
        np.testing.assert_allclose(q, servo_units.ticks_to_radians(TRAJ.ticks[0], ARM.servos))
        end = (0.22, 0.18, 0.6)
        # A waypoint list starting at None starts at the present pose: no approach.
        here = plan_from_present(ARM, bus, [None, end], rate_hz=RATE)
        assert approach_of(here) is None
        np.testing.assert_allclose(here.joints[0], q, atol=1e-9)
        # A request from elsewhere gets an approach from the present joints.
        other = robodcn.plan(ARM, [(0.15, 0.25, 1.2), end], rate_hz=RATE)
        moved = plan_from_present(ARM, bus, other.request)
        approach = approach_of(moved)
        assert approach is not None and approach.samples >= 2
        np.testing.assert_allclose(moved.joints[0], q)
        # whatever law times it (the default optimal profile was not found by inferring a
        # quintic): the samples the planner recorded, ending where the path begins
        for profile in ("optimal", "quintic", "trapezoid"):
            req = robodcn.plan(ARM, [(0.15, 0.25, 1.2), end], rate_hz=RATE,
                               profile=profile).request
            timed = plan_from_present(ARM, bus, req)
            found = approach_of(timed)
            assert found is not None and found.samples == timed.approach_samples > 0, profile
            assert found.duration_s == pytest.approx(found.samples / RATE)
            start = robodcn.plan(ARM, [(0.15, 0.25, 1.2), end], rate_hz=RATE,
                                 profile=profile).joints[0]
            np.testing.assert_allclose(timed.joints[found.samples], start, atol=1e-9)
        with pytest.raises(ServoMismatchError):
            present_joints(ARM2R, bus)


def test_present_ticks_the_caller_read_are_not_read_again(sim):
    """A caller that has just read Present Position (and planned from it) passes it: the
    streamer does not read it again, and its start checks work from those ticks."""
    with open_bus(sim) as bus:
        place(bus, TRAJ.ticks[0])
        here = bus.read_positions()

        def position_reads() -> int:
            return sum(1 for e in sim.packets("rx", "FAST_SYNC_READ")
                       if int.from_bytes(e.params[:2], "little") == ADDR_PRESENT_POSITION)

        sim.clear_log()
        report = execute(TRAJ, bus, present_ticks=here, skip_late=False)
        assert report.stop_reason == "completed", report.message
        assert position_reads() == 1                      # the final read only
        # the refusals judge the ticks given: far from the start says the arm is not there
        far = here + np.array([400, 0, 0])
        writes = write_count(sim)
        with pytest.raises(StartMismatchError) as err:
            execute(TRAJ, bus, present_ticks=far)
        assert f"present tick {int(far[0])}" in err.value.message
        assert write_count(sim) == writes
        # with approach=True the approach leaves from them
        moved = execute(TRAJ, bus, present_ticks=far, approach=True, skip_late=False,
                        tracking_limit=None)
        assert moved.approach is not None and moved.approach.samples > 0
        assert np.abs(history(sim)[-moved.samples_sent] - far).max() <= 1
        for bad in ([1, 2], [1.5, 2, 3], "123", [True, 2, 3]):
            with pytest.raises(InputError) as err:
                execute(TRAJ, bus, present_ticks=bad)
            assert err.value.field == "present_ticks"
