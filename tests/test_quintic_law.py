"""robodcn.path_timing.quintic_law: the uniform quintic law, the jerk pass's rest-to-rest
fallback when the filtered optimum is slower (a tight jerk limit)."""

from __future__ import annotations

import numpy as np
import pytest
from test_path_timing import J_TOL, RATE, V_TOL, fd, stream_joints

from bench.bench_path_timing import cases, ours
from robodcn.errors import InputError
from robodcn.path_timing.quintic_law import QuinticTiming


@pytest.fixture(scope="module")
def paths():
    return cases()


def test_the_law_is_the_minimum_jerk_polynomial_and_its_derivatives():
    law = QuinticTiming(0.2, 1.2, 2.0)
    t = np.linspace(-0.5, 2.5, 30001)
    m = law.at(t)
    tau = np.clip(t / 2.0, 0.0, 1.0)
    assert np.allclose(m.s, 0.2 + 10 * tau ** 3 - 15 * tau ** 4 + 6 * tau ** 5, atol=1e-15)
    h = t[1] - t[0]
    # each derivative is the finite difference of the one before (central, away from 0 and T
    # where s⃛ steps)
    inner = (np.abs(t) > 2 * h) & (np.abs(t - 2.0) > 2 * h)
    for lo, hi in ((m.s, m.sd), (m.sd, m.sdd), (m.sdd, m.sddd)):
        central = np.gradient(lo, h)
        assert np.allclose(central[inner], hi[inner], atol=2e-6 * np.abs(hi).max())
    # at rest before, at the ends and after; the peaks of the minimum-jerk law
    assert m.s[0] == 0.2 and m.s[-1] == 1.2 and m.sd[0] == m.sd[-1] == 0.0
    assert m.sddd[t < 0].max() == 0.0 and m.sddd[t >= 2.0].max() == 0.0
    assert m.sd.max() == pytest.approx(15 / 8 / 2.0, rel=1e-6)
    assert law.at(np.array([0.0])).sddd[0] == pytest.approx(60 / 8.0)
    assert np.array_equal(law.positions(t), m.s)


def test_stretch_and_compress_change_only_the_duration():
    law = QuinticTiming(0.0, 1.0, 1.5)
    slow = law.stretch(3.0)
    assert slow.duration == 3.0
    assert np.allclose(slow.at(np.array([1.5])).s, law.at(np.array([0.75])).s)
    assert law.compressed(0.5).duration == 0.75
    with pytest.raises(InputError) as info:
        law.stretch(1.0)
    assert info.value.field == "duration"
    samples = law.sample(100.0)
    assert samples.t[-1] >= law.duration and samples.s[-1] == 1.0


def test_under_a_tight_jerk_limit_every_piece_keeps_every_limit_and_beats_its_box_filter(paths):
    """The jerk limit of a quintic over the whole path (its peak jerk): the box filter's
    window overhead loses to the uniform law there, so pieces take it; the samples keep every
    limit, also where a piece ends at a stop (the path's corner: the check reads the
    piece's own q′ there, not the next one's)."""
    taken = 0
    for case in paths:
        v, a, _ = case.limits
        tight = 0.5 * a / np.sqrt(a.max() / a)  # rad/s³: a jerk of the order a·2/s
        law = ours(case, jerk=tight, rate_hz=RATE)
        pieces = getattr(law, "pieces", [law])
        taken += sum(isinstance(p, QuinticTiming) for p in pieces)
        vel, acc, jrk = fd(stream_joints(case, law), RATE)
        assert (np.abs(vel) <= v * (1 + V_TOL)).all(), case.name
        assert (np.abs(acc) <= a * (1 + 2e-2)).all(), case.name
        assert (np.abs(jrk) <= tight * (1 + J_TOL)).all(), (case.name,
                                                           (np.abs(jrk) / tight).max())
    assert taken > 0, "no piece took the quintic: the test would show nothing"
