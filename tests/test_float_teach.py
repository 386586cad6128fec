"""Float teach (robodcn.workflow.float_teach): the gravity currents, the loop on a fake clock
with a recording bus, and on the wire against firmware_sim's OpenMANIPULATOR-X (physics with
gravity): it stays where it is, a push moves it and it stays there, leaving does not jump."""

from __future__ import annotations

import contextlib
import threading
import time

import numpy as np
import pytest
from conftest import ARM3R, CONFIGS, open_bus

from firmware_sim.bus import SimBus
from robodcn import dynamics, servo_units
from robodcn.config import load_arm
from robodcn.errors import BusyError, CommError, InputError
from robodcn.workflow import float_teach as ft

OMX = load_arm(CONFIGS / "omx.toml")
#: XM430-W350 at 12 V: 4.1 N·m at 2.3 A.
KT = 4.1 / 2.3


class FakeBus:
    """What FloatTeach uses of a ServoBus, recording every call; ``poses`` are the Present
    Positions the arm reports, one per read (the last repeats): a hand moving it."""

    def __init__(self, arm, poses, limit_a=3.2):
        self.ids = arm.servo_ids
        self.servos = arm.servos
        self.poses = [np.asarray(p, dtype=np.int64) for p in poses]
        self.limit_a = limit_a
        self.calls = []
        self.fail_writes = 0
        self.modes = dict.fromkeys(self.ids, 3)
        self.torque = dict.fromkeys(self.ids, False)        # freshly powered

    def read_positions(self):
        pose = self.poses.pop(0) if len(self.poses) > 1 else self.poses[0]
        self.calls.append(("read",))
        return pose.copy()

    def current_limit(self, servo):
        return self.limit_a

    def write_goal_currents(self, amps, ids):
        if self.fail_writes:
            self.fail_writes -= 1
            raise CommError("sync write failed", field="bus", value=-3001)
        self.calls.append(("currents", tuple(ids), tuple(np.asarray(amps).tolist())))

    def set_operating_mode(self, mode, servos, *, goal_current_a=None, torque=None):
        self.calls.append(("mode", mode, tuple(servos), goal_current_a))
        for i in servos:
            self.modes[i] = mode
            if torque is not None:
                self.torque[i] = torque

    def operating_modes(self, servos):
        return {i: self.modes[i] for i in servos}

    def torque_enabled(self):
        return dict(self.torque)

    @contextlib.contextmanager
    def claim(self):
        yield self


class FakeClock:
    def __init__(self):
        self.now = 0.0
        self.sleeps = []

    def __call__(self):
        return self.now

    def sleep(self, seconds):
        self.sleeps.append(seconds)
        self.now += seconds


def ticks_of(arm, q):
    return servo_units.radians_to_ticks(np.asarray(q, dtype=np.float64), arm.servos)


def expected_currents(arm, ticks):
    q = servo_units.ticks_to_radians(ticks, arm.servos)
    chain = ft.arm_chain(arm)
    return dynamics.gravity_torque(chain, q, arm.payload_kg)[1:] / KT


# -- the currents -------------------------------------------------------------------------------

def test_currents_are_the_gravity_torque_over_the_torque_constant():
    assert ft.torque_constant(OMX.joints[1]) == pytest.approx(KT)
    pose = ticks_of(OMX, [0.3, 0.5, -0.4, 0.2])
    bus = FakeBus(OMX, [pose])
    clock = FakeClock()
    with ft.FloatTeach(bus, OMX, clock=clock, sleep=clock.sleep) as fl:
        first = bus.calls[-1]
    assert first[0] == "mode" and first[1] == 0 and first[2] == (12, 13, 14)
    assert first[3] == pytest.approx(expected_currents(OMX, pose).tolist())
    # stretched out horizontally the shoulder holds ≈ 0.84 N·m (omx.md): ≈ 0.47 A
    up = np.arctan2(0.128, 0.024)                 # the first link's elevation at zero
    level = ticks_of(OMX, [0.0, up, -up, 0.0])
    amps = fl.currents(servo_units.ticks_to_radians(level, OMX.servos))
    assert abs(amps[0]) == pytest.approx(0.84 / KT, rel=0.05)
    assert bus.calls[-1] == ("mode", 3, (12, 13, 14), None)     # left: position mode


def test_a_reversed_servo_gets_the_opposite_current():
    from dataclasses import replace
    flipped = replace(OMX, joints=tuple(
        replace(j, servo=replace(j.servo, direction=-1)) if j.name == "elbow" else j
        for j in OMX.joints))
    q = [0.0, 0.4, 0.3, 0.1]
    a = ft.FloatTeach(FakeBus(OMX, [ticks_of(OMX, q)]), OMX).currents(np.array(q))
    b = ft.FloatTeach(FakeBus(flipped, [ticks_of(flipped, q)]), flipped).currents(np.array(q))
    assert b == pytest.approx([a[0], -a[1], a[2]])


def test_currents_above_the_limit_are_clipped_and_reported():
    bus = FakeBus(OMX, [ticks_of(OMX, [0.0, 1.2, 0.0, 0.0])], limit_a=0.1)
    clock = FakeClock()
    with ft.FloatTeach(bus, OMX, clock=clock, sleep=clock.sleep) as fl:
        report = fl.run(duration_s=0.05)
    assert max(abs(a) for a in report.last.currents_a) == pytest.approx(0.1)
    assert "shoulder" in report.clipped


def test_a_planar_arm_without_gravity_floats_with_zero_current():
    bus = FakeBus(ARM3R, [np.array([2048, 2100, 1900])])
    with ft.FloatTeach(bus, ARM3R) as fl:
        assert fl.joint_names == ARM3R.joint_names
        assert fl.step().currents_a == (0.0, 0.0, 0.0)


# -- the loop -----------------------------------------------------------------------------------

def test_the_loop_refreshes_at_its_rate_and_follows_the_hand():
    start = ticks_of(OMX, [0.0, 0.2, 0.1, 0.0])
    poses = [start + np.array([0, 5 * k, -3 * k, 0]) for k in range(30)]
    bus = FakeBus(OMX, poses)
    clock = FakeClock()
    with ft.FloatTeach(bus, OMX, rate_hz=100, clock=clock, sleep=clock.sleep) as fl:
        report = fl.run(duration_s=0.2)
    writes = [c for c in bus.calls if c[0] == "currents"]
    assert report.cycles == len(writes) == 20
    assert clock.sleeps == pytest.approx([0.01] * 20)
    assert report.rate_hz == pytest.approx(100, rel=0.06) and report.late_cycles == 0
    for k, call in enumerate(writes):              # each write holds the pose just read
        assert call[1] == (12, 13, 14)
        assert call[2] == pytest.approx(expected_currents(OMX, poses[k + 1]).tolist())
    assert report.last.ticks == tuple(poses[20].tolist())


def test_stop_from_the_sample_callback_or_another_thread():
    bus = FakeBus(OMX, [ticks_of(OMX, [0.0, 0.2, 0.1, 0.0])])
    clock = FakeClock()
    with ft.FloatTeach(bus, OMX, clock=clock, sleep=clock.sleep) as fl:
        seen = []

        def on_sample(sample):
            seen.append(sample)
            if len(seen) == 5:
                fl.stop()

        assert fl.run(on_sample=on_sample).cycles == 5
    with ft.FloatTeach(FakeBus(OMX, [ticks_of(OMX, [0.0] * 4)]), OMX, rate_hz=200) as fl:
        threading.Timer(0.1, fl.stop).start()
        t0 = time.monotonic()
        report = fl.run()
        assert 0.08 < time.monotonic() - t0 < 2.0 and report.cycles >= 10


def test_slow_cycles_are_counted_late_without_catching_up():
    bus = FakeBus(OMX, [ticks_of(OMX, [0.0, 0.2, 0.1, 0.0])])
    clock = FakeClock()
    slow = {"n": 0}

    def on_sample(sample):
        slow["n"] += 1
        if slow["n"] == 3:
            clock.now += 0.05                     # one cycle takes 50 ms

    with ft.FloatTeach(bus, OMX, clock=clock, sleep=clock.sleep) as fl:
        report = fl.run(duration_s=0.2, on_sample=on_sample)
    assert report.late_cycles == 1 and report.worst_period_s == pytest.approx(0.05)
    assert all(s > 0 for s in clock.sleeps)


def test_an_error_in_the_loop_still_restores_position_mode():
    bus = FakeBus(OMX, [ticks_of(OMX, [0.0, 0.2, 0.1, 0.0])])
    bus.fail_writes = 1
    clock = FakeClock()
    with pytest.raises(CommError):
        with ft.FloatTeach(bus, OMX, clock=clock, sleep=clock.sleep) as fl:
            fl.run(duration_s=1.0)
    assert bus.calls[-1] == ("mode", 3, (12, 13, 14), None)
    with pytest.raises(InputError):
        fl.step()                                  # not active any more


def test_a_float_the_servos_do_not_take_is_refused_and_the_arm_held():
    """A servo that does not read back current control with torque on: CommError naming
    it, never "it stays where you leave it"; the joints are put back in position mode with
    torque on (the last switch)."""
    bus = FakeBus(OMX, [ticks_of(OMX, [0.0, 0.2, 0.1, 0.0])])
    real = bus.set_operating_mode

    def stubborn(mode, servos, **kw):           # the elbow ignores the torque-on
        real(mode, servos, **kw)
        bus.torque[13] = mode != 0 and bus.torque[13]

    bus.set_operating_mode = stubborn
    with pytest.raises(CommError) as err:
        with ft.FloatTeach(bus, OMX):
            pass
    assert err.value.field == "joints" and err.value.value == ["elbow"]
    assert bus.calls[-1][:3] == ("mode", 3, (12, 13, 14))
    assert bus.modes == {11: 3, 12: 3, 13: 3, 14: 3}


@pytest.mark.parametrize("kwargs, field", [
    ({"rate_hz": 20}, "rate_hz"), ({"rate_hz": float("nan")}, "rate_hz"),
    ({"joints": ["knee"]}, "joints"), ({"joints": []}, "joints"),
    ({"payload_kg": -1}, "payload_kg"),
])
def test_bad_options_name_the_field(kwargs, field):
    bus = FakeBus(OMX, [ticks_of(OMX, [0.0] * 4)])
    with pytest.raises(InputError) as err:
        ft.FloatTeach(bus, OMX, **kwargs)
    assert err.value.field == field and bus.calls == []


def test_an_arm_with_gravity_but_no_masses_is_refused_before_any_write():
    from dataclasses import replace
    bare = replace(OMX, mass_properties=replace(OMX.mass_properties, link_masses=None))
    bus = FakeBus(bare, [ticks_of(bare, [0.0] * 4)])
    with pytest.raises(InputError) as err:
        ft.FloatTeach(bus, bare)
    assert err.value.field == "dynamics.link_masses" and bus.calls == []


# -- on the wire --------------------------------------------------------------------------------

START = {12: 2048 + 300, 13: 2048 - 200, 14: 2048 + 100}


@pytest.fixture
def omx_bus():
    with SimBus(arm=CONFIGS / "omx.toml", dynamics=True, timing="fast",
                positions=START) as sim:
        with open_bus(sim, OMX.servos) as bus:
            bus.verify()
            bus.configure()
            yield sim, bus
        assert not sim.errors, sim.errors


def test_on_the_wire_the_arm_floats_moves_by_hand_and_stays(omx_bus):
    sim, bus = omx_bus
    time.sleep(0.4)                                      # the position-mode sag settles
    fl = ft.FloatTeach(bus, OMX)
    with fl:
        entry = fl.latest.ticks                          # the pose the float began at
        assert bus.operating_modes() == {11: 3, 12: 0, 13: 0, 14: 0}
        runner = threading.Thread(target=fl.run)
        runner.start()
        try:
            time.sleep(0.6)
            held = fl.latest.ticks
            assert np.abs(np.subtract(held, entry)).max() <= 3     # it stays there
            with pytest.raises(BusyError):               # the loop holds the bus
                bus.read_positions()
            sim.servo(12).push(-0.3)                     # a hand lifts the shoulder
            time.sleep(0.3)
            sim.servo(12).push(0.0)                      # and lets go
            time.sleep(0.6)
            left = fl.latest.ticks
            time.sleep(0.4)
            still = fl.latest.ticks
        finally:
            fl.stop()
            runner.join()
    assert left[1] < entry[1] - 50                       # it moved ...
    assert abs(still[1] - left[1]) <= 3                  # ... and stays where it was left
    report = fl.report()
    assert report.rate_hz >= ft.MIN_RATE_HZ and not report.clipped
    after = bus.read_positions()
    assert bus.operating_modes() == {11: 3, 12: 3, 13: 3, 14: 3}
    assert [sim.servo(i).goal_position for i in (12, 13, 14)] == pytest.approx(
        list(still[1:]), abs=3)                          # goal = present: no jump
    assert np.abs(after - np.array(still)).max() <= 3


def test_on_the_wire_zero_current_lets_the_arm_fall(omx_bus):
    """The comparison: current control without the gravity currents drops the arm."""
    _, bus = omx_bus
    bus.set_operating_mode(0, [12, 13, 14], goal_current_a=0.0)
    time.sleep(0.5)
    fallen = bus.read_positions()
    bus.set_operating_mode(3, [12, 13, 14])
    assert fallen[1] > START[12] + 100                   # the shoulder fell forward
