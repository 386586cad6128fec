"""robodcn.path_timing: time-optimal (TOPP-RA) and jerk-limited timing of a joint path."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import CubicSpline

from bench.bench_path_timing import cases, ours, toppra_duration
from robodcn.errors import InputError
from robodcn.path_timing import max_start_speed, time_optimal

RATE = 1000.0
# finite differences at the stream rate: a sampled law is checked within these shares
V_TOL, A_TOL, J_TOL = 1e-3, 2e-2, 5e-2


@pytest.fixture(scope="module")
def paths():
    return cases()


def fd(q: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint velocity, acceleration, jerk by finite differences of stream samples."""
    return (np.diff(q, axis=0) * rate, np.diff(q, 2, axis=0) * rate ** 2,
            np.diff(q, 3, axis=0) * rate ** 3)


def stream_joints(case, law) -> np.ndarray:
    """q(s(t)) at the stream rate: a cubic spline through the samples of each piece."""
    m = law.sample(RATE)
    cuts = [0, *(int(np.argmin(np.abs(case.s - x))) for x in case.stops), case.s.shape[0] - 1]
    q = np.empty((m.s.shape[0], case.q.shape[1]))
    for lo, hi in itertools.pairwise(cuts):
        inside = (m.s >= case.s[lo]) & (m.s <= case.s[hi])
        q[inside] = CubicSpline(case.s[lo:hi + 1], case.q[lo:hi + 1])(m.s[inside])
    return q


def test_at_least_20_varied_paths(paths):
    names = [c.name for c in paths]
    assert len(paths) >= 20
    for word in ("arm2r", "arm3r", "sclerp", "kenlerp", "seplerp", "dlb", "stops", "blend"):
        assert any(word in n for n in names), word


def test_jerk_free_duration_within_2_percent_of_toppra(paths):
    for case in paths:
        ratio = ours(case).duration / toppra_duration(case)
        assert ratio <= 1.02, (case.name, ratio)


def test_jerk_free_law_within_limits_at_stream_rate(paths):
    for case in paths:
        # the full sample grid: a coarser one steps over a blend's curvature corners
        law = ours(case, max_stages=case.s.shape[0])
        v, a, _ = case.limits
        vel, acc, _ = fd(stream_joints(case, law), RATE)
        assert (np.abs(vel) <= v * (1 + V_TOL) + 1e-9).all(), case.name
        # FD acceleration spans two samples across a step of s̈: compare with the limit
        assert (np.abs(acc) <= a * (1 + A_TOL) + 1e-9).all(), case.name


def _within_every_limit(cases_) -> None:
    for case in cases_:
        law = ours(case, jerk=True, rate_hz=RATE)
        v, a, j = case.limits
        vel, acc, jrk = fd(stream_joints(case, law), RATE)
        assert (np.abs(vel) <= v * (1 + V_TOL)).all(), case.name
        assert (np.abs(acc) <= a * (1 + A_TOL)).all(), case.name
        assert (np.abs(jrk) <= j * (1 + J_TOL)).all(), (case.name, (np.abs(jrk) / j).max())
        assert law.duration >= ours(case).duration


def test_jerk_limited_law_within_every_limit(paths):
    # blends included: their curvature corners (the blended geometry is C¹ only) are crossed
    # slowly enough that the step of joint acceleration stays within the jerk limit
    _within_every_limit(paths)


def test_blend_never_slower_than_stopping_at_every_via(paths):
    by_path: dict[str, dict[str, float]] = {}
    for case in paths:
        if len(case.waypoints) > 2:
            kind = "blend" if case.blend else "stops"
            by_path.setdefault(case.name.rsplit(" ", 1)[0], {})[kind] = ours(case).duration
    assert by_path
    for name, d in by_path.items():
        assert d["blend"] <= d["stops"], name


def test_stops_are_at_rest(paths):
    case = next(c for c in paths if c.stops)
    for jerk in (False, True):
        law = ours(case, jerk=jerk)
        m = law.at(np.linspace(0, law.duration, 200_001))
        for stop in case.stops:
            i = int(np.argmin(np.abs(m.s - stop)))
            assert m.sd[i] < 1e-2 * m.sd.max(), (jerk, stop, m.sd[i])


def test_stretch_is_uniform_and_refuses_shorter(paths):
    case = paths[0]
    law = ours(case, jerk=True)
    longer = law.stretch(2.0 * law.duration)
    assert longer.duration == pytest.approx(2.0 * law.duration)
    a = law.at(np.array([0.3 * law.duration]))
    b = longer.at(np.array([0.6 * law.duration]))
    assert b.s[0] == pytest.approx(a.s[0])
    assert b.sd[0] == pytest.approx(a.sd[0] / 2) and b.sdd[0] == pytest.approx(a.sdd[0] / 4)
    with pytest.raises(InputError) as err:
        law.stretch(0.9 * law.duration)
    assert err.value.field == "duration" and "shorter than the time-optimal" in str(err.value)


def test_scale_slows_by_its_inverse(paths):
    case = paths[0]
    full, half = ours(case), ours(case, scale=0.5)
    assert half.duration == pytest.approx(2.0 * full.duration, rel=1e-6)


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"scale": 0.0}, "scale"), ({"scale": 1.5}, "scale"), ({"sd_start": -1.0}, "sd_start"),
    ({"v_max": [1.0]}, "v_max"), ({"a_max": [1.0, -1.0]}, "a_max"),
    ({"stops": [1.0]}, "stops"), ({"sd_start": 1e6}, "sd_start"),
])
def test_bad_input_names_the_argument(kwargs, field):
    s = np.linspace(0, 1, 101)
    q = np.stack([s, s ** 2], axis=1)
    args = {"v_max": [1.0, 1.0], "a_max": [2.0, 2.0], **kwargs}
    with pytest.raises(InputError) as err:
        time_optimal(q, s, args.pop("v_max"), args.pop("a_max"), **args)
    assert err.value.field == field


def test_max_start_speed_is_the_controllable_limit(paths):
    case = paths[0]
    v, a, _ = case.limits
    top = max_start_speed(case.q, case.s, v, a)
    assert top > 0
    assert ours(case, sd_start=0.999 * top).sample(RATE).sd[0] == pytest.approx(0.999 * top)
    with pytest.raises(InputError) as err:
        ours(case, sd_start=1.01 * top)
    assert err.value.field == "sd_start"


def test_bad_grid_is_refused():
    with pytest.raises(InputError) as err:
        time_optimal(np.zeros((3, 2)), np.array([0.0, 0.5, 0.5]), [1, 1], [1, 1])
    assert err.value.field == "s"


# -- properties on random smooth paths ---------------------------------------------------------

def _path(coef: list[float], s: np.ndarray) -> np.ndarray:
    """q_j(s) = c1 s + c2 sin(c3 s + j): smooth, with exact values at any s."""
    c1, c2, c3 = coef
    return np.stack([c1 * s + c2 * np.sin(c3 * s + j) + j * 0.3 * s for j in range(2)], axis=1)


@settings(max_examples=25, deadline=None)
@given(coef=st.tuples(st.floats(0.3, 2.0), st.floats(-0.5, 0.5), st.floats(0.5, 4.0)),
       v=st.floats(0.5, 3.0), a=st.floats(2.0, 20.0), jerk=st.booleans(),
       start_share=st.floats(0.0, 0.6), with_stop=st.booleans())
def test_properties(coef, v, a, jerk, start_share, with_stop):
    s = np.linspace(0.0, 1.0, 801)
    q = _path(list(coef), s)
    vmax, amax, jmax = np.full(2, v), np.full(2, a), np.full(2, 10.0 * a)
    stops = [0.5] if with_stop else []
    free = time_optimal(q, s, vmax, amax, stops=stops)
    # a moving start at a share of the fastest speed the path allows at s = 0
    # (with a jerk limit the braking ramps need room: a smaller share of it)
    sd0 = start_share * (0.3 if jerk else 1.0) * max_start_speed(q, s, vmax, amax, stops=stops)
    law = time_optimal(q, s, vmax, amax, jmax if jerk else None, sd_start=sd0, stops=stops,
                       rate_hz=RATE)
    m = law.sample(RATE)
    assert m.sd[0] == pytest.approx(sd0, abs=1e-9)
    assert m.s[0] == pytest.approx(0.0, abs=1e-12)
    assert m.s[-1] == pytest.approx(1.0, abs=1e-9) and abs(m.sd[-1]) < 1e-9
    assert (np.diff(m.s) >= -1e-12).all()
    vel, acc, jrk = fd(_path(list(coef), m.s), RATE)
    assert (np.abs(vel) <= v * (1 + V_TOL) + 1e-9).all()
    # FD over a coarse-grid law (801 samples, ≤ 1000 stages): 5 % (see the report)
    assert (np.abs(acc) <= a * 1.05 + 2 * v * a / RATE).all(), (np.abs(acc) / a).max()
    if jerk:
        assert (np.abs(jrk) <= 10.0 * a * (1 + J_TOL)).all(), (np.abs(jrk) / (10 * a)).max()
    if sd0 == 0.0:
        assert law.duration >= free.duration * (1 - 1e-9)


def test_per_sample_limits_bound_each_stage():
    """(n, k) limits: the same as (k,) when every row is equal; lowered over the first half,
    the law's joint velocity there stays within the lower limit and the rest is faster."""
    s = np.linspace(0, 1, 201)
    q = _path([1.0, 0.3, 2.0], s)
    v, a = np.array([1.0, 1.2]), np.array([4.0, 5.0])
    whole = time_optimal(q, s, v, a)
    same = time_optimal(q, s, np.tile(v, (201, 1)), np.tile(a, (201, 1)))
    assert same.duration == pytest.approx(whole.duration, rel=1e-12)
    v_s, a_s = np.tile(v, (201, 1)), np.tile(a, (201, 1))
    v_s[:101] *= 0.5
    a_s[:101] *= 0.25
    law = time_optimal(q, s, v_s, a_s)
    assert law.duration > whole.duration
    m = law.sample(RATE)
    dq = np.gradient(q, s, axis=0)
    qd = np.abs(np.interp(m.s, s, dq[:, 0]) * m.sd), np.abs(np.interp(m.s, s, dq[:, 1]) * m.sd)
    first = m.s < s[100]
    assert (qd[0][first] <= 0.5 * v[0] * (1 + 1e-3)).all()
    assert (qd[1][first] <= 0.5 * v[1] * (1 + 1e-3)).all()
    assert max(qd[0][~first].max() / v[0], qd[1][~first].max() / v[1]) > 0.5
    with pytest.raises(InputError) as err:
        time_optimal(q, s, v_s, a, j_max=[10.0, 10.0])
    assert err.value.field == "v_max"


@pytest.mark.parametrize("jerk", [None, 200.0], ids=["jerk-free", "jerk-limited"])
def test_sd_cap_bounds_the_law_and_only_slows_it(jerk):
    """``sd_cap`` (a speed scale's k × the plan's own ṡ): the law stays under it wherever it
    is, is no shorter than without it, and a cap above the free law changes nothing."""
    t = np.linspace(0.0, 1.0, 400)
    q = np.stack([np.cos(2 * t), np.sin(2 * t), 0.5 * t], axis=1)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    v, a = np.full(3, 3.0), np.full(3, 20.0)
    j = None if jerk is None else np.full(3, jerk)
    free = time_optimal(q, s, v, a, j, rate_hz=RATE)
    cap = np.full(len(s), 0.6)
    capped = time_optimal(q, s, v, a, j, rate_hz=RATE, sd_cap=cap)
    m = capped.sample(RATE)
    assert m.sd.max() <= 0.6 * 1.01
    assert capped.duration >= free.duration
    loose = time_optimal(q, s, v, a, j, rate_hz=RATE, sd_cap=np.full(len(s), 1e3))
    assert loose.duration == pytest.approx(free.duration, rel=1e-9)
    with pytest.raises(InputError) as info:
        time_optimal(q, s, v, a, j, sd_cap=np.full(3, 1.0))
    assert info.value.field == "sd_cap"


def test_path_derivatives_of_a_dwell_warn_nothing_and_share_the_sample():
    """Issue 17 §7: divide-by-zero warnings from path_derivatives (a held sample repeats its
    s). A repeated (s, q) is one sample; under numpy's 'raise' no FloatingPointError."""
    from robodcn.path_timing import path_derivatives

    s = np.linspace(0.0, 1.0, 21)
    q = np.column_stack([np.sin(s), s ** 2])
    held = np.insert(np.arange(21), [0, 7, 7, 21], [0, 7, 7, 20])
    with np.errstate(all="raise"):
        plain = path_derivatives(q, s, [10], 2)
        dwell = path_derivatives(q[held], s[held], [int(np.argmax(held == 10))], 2)
    for d_plain, d_dwell in zip(plain, dwell, strict=True):
        assert np.isfinite(d_dwell).all()
        np.testing.assert_allclose(d_dwell, d_plain[held], atol=1e-12)
    with pytest.raises(InputError) as err:
        path_derivatives(q[::-1], s[::-1], [], 1)
    assert err.value.field == "s"
    jump = q[held].copy()
    jump[8] += 0.1  # a second, different sample at the held s
    with pytest.raises(InputError) as err:
        path_derivatives(jump, s[held], [], 1)
    assert err.value.field == "s"
    # a path that does not move: zero derivatives
    with np.errstate(all="raise"):
        still = path_derivatives(np.zeros((3, 2)), np.zeros(3), [], 2)
    assert all((d == 0).all() for d in still)


def test_brake_without_velocity_is_no_brake():
    """Issue 17 §7: a replace during a braking pause or stop divided by T₀ = 0 (ZeroDivision):
    the state at the end of a brake has q̇ = 0 and q̈ ≠ 0."""
    from robodcn.path_timing import JointLimits
    from robodcn.path_timing.moving_start import JointState, brake_line, join

    lim = JointLimits(np.full(3, 2.0), np.full(3, 10.0))
    state = JointState(np.array([0.1, -0.4, 0.3]), np.zeros(3), np.array([-9.0, 4.0, 1.0]))
    with np.errstate(all="raise"):
        brake = brake_line(state, lim, 100.0)
    assert brake.law.duration == 0.0
    np.testing.assert_array_equal(brake.q_stop, state.q)
    m = brake.law.sample(100.0)
    assert np.isfinite(m.s).all() and (m.sd == 0).all()
    # and a braking state with velocity still brakes over |q̇|/2a at the limits
    moving = JointState(state.q, np.array([1.0, 0.0, 0.0]), state.qdd)
    assert brake_line(moving, lim, 100.0).law.duration == pytest.approx(0.1, rel=2e-2)
    # joining a path from the still-braking state plans from where it is
    s = np.linspace(0.0, 1.0, 50)
    q = state.q + np.outer(s, [0.5, 0.2, -0.1])
    with np.errstate(divide="raise", invalid="raise"):
        seg = join(state, q, s, lim, 100.0)
    assert seg.law is not None and np.isfinite(seg.law.duration)


def _plain_min_affine(x0, slope, offset):
    """The recurrence x_{i+1} = max(0, min_j(slope_ij x_i + offset_ij)) stage by stage."""
    out = [x0]
    for w, z in zip(slope, offset, strict=True):
        out.append(max(0.0, min(wj * out[-1] + zj for wj, zj in zip(w, z, strict=True))))
    return np.asarray(out)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("rounds", [0, 1, 8])
def test_min_affine_scan_matches_the_stage_loop(seed, rounds, monkeypatch):
    """The policy-iteration scan (path_timing._scan) against the plain loop: random stages
    with a cap piece (slope 0), pieces that never bind (inf), and the floor at 0; with 0 or
    1 rounds the fallback finishes from wherever the scan got to."""
    from robodcn.path_timing import _scan

    monkeypatch.setattr(_scan, "ROUNDS", rounds)
    rng = np.random.default_rng(seed)
    n, m = 300, 4
    slope = rng.uniform(0.9, 1.05, (n, m))
    offset = rng.uniform(-0.05, 0.2, (n, m))
    offset[rng.random((n, m)) < 0.1] = np.inf
    cap = rng.uniform(0.5, 3.0, n)
    cap[rng.random(n) < 0.02] = 0.0  # stops
    slope = np.hstack([slope, np.zeros((n, 1))])
    offset = np.hstack([offset, cap[:, None]])
    want = _plain_min_affine(0.0, slope, offset)
    calls = []

    def sequential(x, first):
        calls.append(first)
        return _plain_min_affine(x, slope[first:], offset[first:])

    got = _scan.min_affine(0.0, slope, offset, sequential)
    np.testing.assert_allclose(got, want, rtol=1e-11, atol=1e-13)
    assert (rounds == 0) == (calls == [0])


def test_reachability_passes_match_their_stage_loops():
    """controllable and greedy_forward's scans against the plain stage loop on a real
    TOPP-RA problem (3 joints, interpolated rows)."""
    from robodcn.path_timing import reachability, topp

    s = np.linspace(0.0, 1.0, 500)
    q = np.stack([np.sin(3 * s), s ** 2 - s, np.cos(2 * s) * 0.5], axis=1)
    dq, ddq = topp.path_derivatives(q, s, [], 2)
    dq2, ddq2, v, a = topp.interpolated(s, dq, ddq, np.full(3, 2.0), np.full(3, 5.0))
    p_lo, p_hi, r, cap = reachability.stage_constraints(dq2, ddq2, v, a)
    delta = np.diff(s)
    n = delta.shape[0]
    x_max = reachability.controllable_scan(delta, p_lo, r, cap, 0.0)
    slope = 1.0 + 2.0 * delta[:, None] * r[:n]
    good = (slope > 0) & np.isfinite(p_lo[:n])
    w = np.where(good, 1.0 / np.where(good, slope, 1.0), 0.0)
    z = np.where(good, -2.0 * delta[:, None] * np.where(good, p_lo[:n], 0.0) * w, np.inf)
    plain = reachability._sequential(min(0.0, cap[n]), np.hstack([w, np.zeros((n, 1))])[::-1],
                                     np.hstack([z, cap[:n, None]])[::-1])[::-1]
    np.testing.assert_allclose(x_max, plain, rtol=1e-11, atol=1e-13)
    x, u = reachability.greedy_scan(delta, p_hi, r, x_max, 0.0)
    fw = np.hstack([1.0 + 2.0 * delta[:, None] * r[:n], np.zeros((n, 1))])
    fz = np.hstack([2.0 * delta[:, None] * p_hi[:n], x_max[1:, None]])
    np.testing.assert_allclose(x, reachability._sequential(0.0, fw, fz), rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(x[1:], x[:-1] + 2.0 * delta * u, rtol=1e-12, atol=1e-14)
    assert x.max() > 0.1  # the law moves


@pytest.mark.parametrize("n", [2, 3, 5, 400])
@pytest.mark.parametrize("uniform", [True, False])
def test_shared_gradient_is_numpys_bit_for_bit(n, uniform):
    """path_derivatives' gradient (coefficients once per grid) against numpy.gradient."""
    from robodcn.path_timing._gradient import Gradient

    rng = np.random.default_rng(n)
    x = np.linspace(0.0, 1.0, n) if uniform else np.sort(rng.random(n))
    for f in (rng.random((n, 4)), rng.random(n)):
        np.testing.assert_array_equal(Gradient(x)(f),
                                      np.gradient(f, x, axis=0, edge_order=2 if n > 2 else 1))


@pytest.mark.parametrize("ndim", [1, 2])
def test_smooth_power_basis_matches_the_hermite_basis(ndim):
    """Smooth evaluates many queries from per-interval power-basis coefficients (Horner)
    and few by the Hermite basis: the same quintic (to rounding), exact on a quadratic."""
    from robodcn.path_timing.arclength import Smooth

    rng = np.random.default_rng(3)
    x = np.sort(np.concatenate([[0.0, 1.0], rng.random(60)]))
    y = 2.0 * x * x - x + 0.5 if ndim == 1 else np.stack([np.sin(3 * x), x ** 2], axis=1)
    smooth = Smooth(x, y)
    xq = np.linspace(0.0, 1.0, 1001)
    many = smooth(xq)                                          # > 2 queries per interval
    few = np.concatenate([smooth(xq[k:k + 10]) for k in range(0, 1001, 10)])  # Hermite
    np.testing.assert_allclose(many, few, rtol=0, atol=1e-13)
    if ndim == 1:
        np.testing.assert_allclose(many, 2.0 * xq * xq - xq + 0.5, rtol=0, atol=1e-12)


def _straight_then_arc(s: np.ndarray, radius: float = 0.3) -> np.ndarray:
    """A joint path with a curvature corner at s = 0.5: straight, then an arc (C¹ there)."""
    a = np.where(s < 0.5, 0.0, (s - 0.5) / radius)
    x = np.where(s < 0.5, s, 0.5 + radius * np.sin(a))
    y = np.where(s < 0.5, 0.0, radius * (1.0 - np.cos(a)))
    return np.stack([x, y], axis=1)


def test_a_corner_is_a_spike_of_the_change_of_q2_not_its_level():
    from robodcn.path_timing.jerk import corner_jumps
    from robodcn.path_timing.topp import derivatives

    s = np.linspace(0.0, 1.0, 400)
    smooth = np.stack([s ** 3, np.sin(3 * s)], axis=1)  # q''' ≠ 0 everywhere, no corner
    assert corner_jumps(derivatives(smooth, s, [], 2, repeated=False)[1]).max() == 0.0
    s = np.linspace(0.0, 1.2, 401)
    jumps = corner_jumps(derivatives(_straight_then_arc(s), s, [], 2, repeated=False)[1])
    marked = np.flatnonzero(jumps.max(axis=1) > 0)
    assert marked.size and (np.abs(s[marked] - 0.5) <= 4 * (s[1] - s[0])).all()


@pytest.mark.parametrize("n", [201, 801])
def test_a_curvature_corner_is_crossed_within_every_limit(n):
    """The step of joint acceleration at a C¹ corner is crossed slowly enough (the jerk
    pass's corner cap, ``smooth=False``), on a coarse grid as on a fine one; the coarse one
    took 3.5× as long before only spikes counted as corners."""
    s = np.linspace(0.0, 1.2, n)
    v, a, j = np.array([1.0, 1.0]), np.array([5.0, 5.0]), np.array([100.0, 100.0])
    law = time_optimal(_straight_then_arc(s), s, v, a, j, rate_hz=RATE)
    vel, acc, jrk = fd(_straight_then_arc(law.sample(RATE).s), RATE)
    assert (np.abs(vel) <= v * (1 + V_TOL)).all()
    assert (np.abs(acc) <= a * (1 + A_TOL)).all()
    assert (np.abs(jrk) <= j * (1 + J_TOL)).all(), (np.abs(jrk) / j).max()
    fine = time_optimal(_straight_then_arc(np.linspace(0.0, 1.2, 1601)),
                        np.linspace(0.0, 1.2, 1601), v, a, j, rate_hz=RATE)
    assert law.duration <= 1.15 * fine.duration, (law.duration, fine.duration)
