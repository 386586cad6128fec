"""The fast paths of path_timing against their general (reference) forms, bit for bit."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from robodcn.path_timing import _columns, _gradient, _stageloop, reachability, topp


def _plain(x: float, w: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The specification: x_{i+1} = max(0, min_j(w_ij x_i + z_ij)), a running minimum from
    +inf taking strictly smaller pieces (the cap the last piece, slope 0)."""
    out = [x]
    for ws, zs in zip(w.tolist(), z.tolist(), strict=True):
        m = np.inf
        for wj, zj in zip(ws, zs, strict=True):
            t = x * wj + zj
            if t < m:
                m = t
        x = m if m > 0.0 else 0.0
        out.append(x)
    return np.asarray(out)


_values = st.sampled_from([0.0, -0.0, 1.0, -1.0, 0.5, 3.0, -2.5, 1e-300, 1e300, np.inf,
                           -np.inf, np.nan])


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 4), st.integers(0, 12), st.integers(0, 2 ** 32 - 1),
       st.lists(_values, min_size=0, max_size=6), st.floats(0.0, 10.0))
def test_stage_loop_is_the_plain_loop(m, n, seed, specials, x0):
    """Random pieces with zero-width (0 caps), infeasible (negative) and non-finite entries."""
    rng = np.random.default_rng(seed)
    w = rng.normal(size=(n, m + 1)) * rng.choice([0.0, 1.0, 10.0], size=(n, m + 1))
    z = rng.normal(size=(n, m + 1)) * rng.choice([0.0, 1.0, 1e3], size=(n, m + 1))
    w[:, m] = 0.0  # the cap
    flat = np.concatenate([w[:, :m].ravel(), z.ravel()])
    if flat.size:
        for i, v in enumerate(specials):
            flat[rng.integers(flat.size)] = v if i % 2 else abs(v)
        w[:, :m] = flat[:n * m].reshape(n, m)
        z[:] = flat[n * m:].reshape(n, m + 1)
    want = _plain(x0, w, z)
    got = np.asarray(_stageloop.recurrence(x0, [*w[:, :m].T.tolist(), *z.T.tolist()], m))
    assert got.tobytes() == want.tobytes()
    assert reachability._sequential(x0, w, z).tobytes() == want.tobytes()


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 4), st.integers(0, 150), st.integers(0, 2 ** 32 - 1),
       st.lists(_values, min_size=0, max_size=6), st.sampled_from([0.0, 1.0, 3.0]))
def test_capped_stage_loop_is_the_plain_loop(m, n, seed, specials, x0):
    """capped_recurrence skips the stages where the cap binds: pieces about x + z (z ≥ 0)
    under a wandering cap, so long runs follow the cap and leave it; zero caps, and
    non-finite entries among them."""
    rng = np.random.default_rng(seed)
    w = 1.0 + 0.1 * rng.normal(size=(m, n)) * rng.choice([0.0, 1.0, 20.0], size=(m, n))
    z = np.abs(rng.normal(size=(m, n))) * rng.choice([0.0, 0.1, 1.0, 3.0], size=(m, n))
    cap = np.cumsum(rng.normal(size=n) * 0.3) + 5.0 * rng.random()
    cap[rng.random(n) < 0.05] = 0.0
    flat = np.concatenate([w.ravel(), z.ravel(), cap])
    for v in specials if flat.size else ():
        flat[rng.integers(flat.size)] = v
    w, z, cap = flat[:m * n].reshape(m, n), flat[m * n:2 * m * n].reshape(m, n), flat[2 * m * n:]
    want = _plain(x0, np.concatenate([w, np.zeros((1, n))]).T, np.concatenate([z, cap[None]]).T)
    got = _stageloop.capped_recurrence(x0, np.concatenate([w, z, cap[None]]), m)
    assert np.asarray(got).tobytes() == want.tobytes()


def test_capped_stage_loop_skips_the_capped_stages():
    """On a pass that follows its cap after a few stages, the loop runs those few only."""
    n = 200
    w = np.ones((2, n))
    z = np.full((2, n), 0.5)
    cap = np.full(n, 3.0)  # from 0 by 0.5 a stage: the cap after 6 stages, then held
    ran = []
    loop = _stageloop._loop

    def counting(m, exits):
        inner = loop(m, exits)

        def run(x, columns, out):
            before = len(out)
            try:
                return inner(x, columns, out)
            finally:
                ran.append(len(out) - before)
        return run

    _stageloop._loop = counting
    try:
        got = _stageloop.capped_recurrence(0.0, np.concatenate([w, z, cap[None]]), 2)
    finally:
        _stageloop._loop = loop
    assert got.tolist() == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, *[3.0] * (n - 5)]
    assert sum(ran) == 6


def _path(seed: int, n: int, k: int):
    rng = np.random.default_rng(seed)
    s = np.cumsum(rng.uniform(0.5, 1.5, n))
    s = (s - s[0]) / (s[-1] - s[0])
    c = rng.normal(size=(4, k))
    q = c[0] * s[:, None] + c[1] * np.sin(3 * s[:, None] + c[2]) * 0.5 + c[3] * s[:, None] ** 2
    return q, s, rng.uniform(0.5, 3.0, k), rng.uniform(1.0, 20.0, k)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(3, 150), st.integers(1, 5))
def test_column_constraints_are_the_general_ones(seed, n, k):
    q, s, v, a = _path(seed, n, k)
    dq, ddq = topp.path_derivatives(q, s, [], 2)
    delta = s[1:] - s[:-1]
    got = _columns.constraints(delta, dq, ddq, v, a)
    dq2, ddq2, v2, a2 = topp.interpolated(s, dq, ddq, v, a)
    p_lo, p_hi, r, x_cap = reachability.stage_constraints(dq2, ddq2, v2, a2)
    if got is None:  # a still joint: the general path only
        assert not (np.abs(dq2) > reachability._FLAT).all() or not np.isfinite(r).all()
        return
    half, r_c, cap_c = got
    assert half.T.tobytes() == p_hi.tobytes()
    assert (-half).T.tobytes() == p_lo.tobytes()
    assert np.ascontiguousarray(r_c.T).tobytes() == r.tobytes()
    assert cap_c.tobytes() == x_cap.tobytes()
    n_stages = delta.shape[0]
    pieces = _columns.pieces(delta, half, r_c, cap_c)
    w, z = reachability.backward_pieces(delta[:, None], p_lo[:n_stages], r[:n_stages])
    assert np.ascontiguousarray(pieces.w.T).tobytes() == w.tobytes()
    assert np.ascontiguousarray(pieces.z.T).tobytes() == z.tobytes()


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(3, 150), st.integers(1, 5),
       st.sampled_from([0.0, 0.3, 5.0]), st.booleans())
def test_solve_fast_path_is_the_general_path(seed, n, k, sd_start, stop):
    """topp.solve's column path against the general constraints and the stage loops of
    controllable / greedy_forward (infeasible starts raise alike)."""
    q, s, v, a = _path(seed, n, k)
    dq, ddq = topp.path_derivatives(q, s, [], 2)
    cap = np.full(n, np.inf)
    if stop:
        cap[n // 2] = 0.0  # a zero-width set
    try:
        x, u = topp.solve(s, dq, ddq, v, a, cap, sd_start ** 2, 0.0)
    except topp.InputError as exc:
        fast_error = exc.value
    else:
        fast_error = None
    dq2, ddq2, v2, a2 = topp.interpolated(s, dq, ddq, v, a)
    p_lo, p_hi, r, x_cap = reachability.stage_constraints(dq2, ddq2, v2, a2)
    x_cap = np.minimum(x_cap, cap)
    delta = np.diff(s)
    x_max = reachability.controllable(delta, p_lo, r, x_cap, 0.0)
    if sd_start ** 2 > x_max[0] * (1 + 1e-9) + 1e-15:
        assert fast_error == sd_start
        return
    assert fast_error is None
    x_ref, u_ref = reachability.greedy_forward(delta, p_hi, r, x_max, min(sd_start ** 2,
                                                                          x_max[0]))
    assert x.tobytes() == x_ref.tobytes() and u.tobytes() == u_ref.tobytes()
    # the vectorised scans (large grids) agree to rounding
    np.testing.assert_allclose(reachability.controllable_scan(delta, p_lo, r, x_cap, 0.0),
                               x_max, rtol=1e-11, atol=1e-13)
    x_scan, _ = reachability.greedy_scan(delta, p_hi, r, x_max, min(sd_start ** 2, x_max[0]))
    np.testing.assert_allclose(x_scan, x_ref, rtol=1e-11, atol=1e-13)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(2, 60), st.integers(1, 4))
def test_derivatives_one_piece_is_the_piecewise_form(seed, n, k):
    q, s, _, _ = _path(seed, n, k)
    fast = topp.derivatives(q, s, [], 3, repeated=False)
    general = topp.derivatives(q, s, [0, n - 1], 3, repeated=True)  # the per-piece loop
    for f, g in zip(fast, general, strict=True):
        assert f.tobytes() == g.tobytes()


def test_kept_gradients_are_fresh_copies_of_the_same_bits():
    """_gradient.repeated keeps the gradients of its first ask (handing out copies: a
    caller writing into them changes nothing kept), hands them over at the second ask of
    the same bytes, then computes again; other bytes are other entries (-0.0 is not 0.0)."""
    q, s, _, _ = _path(7, 40, 3)
    q[0, 0] = 0.0
    want = topp.derivatives(q, s, [0, q.shape[0] - 1], 3, repeated=True)
    _gradient._kept.clear()
    first = _gradient.repeated(s, q, 3)
    for got in first:
        got[:] = np.nan  # must not reach the kept entry
    assert len(_gradient._kept) == 1
    again = _gradient.repeated(s, q, 2)
    assert not _gradient._kept  # handed over
    for f, g in zip(again, want[:2], strict=True):
        assert f.tobytes() == g.tobytes()
    third = _gradient.repeated(s, q, 3)
    for f, g in zip(third, want, strict=True):
        assert f.tobytes() == g.tobytes()
    flipped = q.copy()
    flipped[0, 0] = -0.0
    want = topp.derivatives(flipped, s, [0, q.shape[0] - 1], 2, repeated=True)
    for f, g in zip(_gradient.repeated(s, flipped, 2), want, strict=True):
        assert f.tobytes() == g.tobytes()
    for count in range(_gradient.KEEP + 2):  # more paths than kept: the oldest go
        _gradient.repeated(s, q + count, 1)
    assert len(_gradient._kept) <= _gradient.KEEP


def test_break_index_is_the_clipped_search():
    """PathTiming._at0's one search over the inner breaks is clip(searchsorted − 1, 0, N − 1)
    for times before, at, between and after the breaks (repeated breaks, NaN too)."""
    from robodcn.path_timing.law import PathTiming

    rng = np.random.default_rng(3)
    for n in (1, 2, 7, 40):
        tb = np.concatenate([[0.0], np.cumsum(rng.choice([0.0, 0.1, 0.5], n))])
        law = PathTiming(tb, np.linspace(0.0, 1.0, n + 1), np.ones(n + 1), np.zeros(n))
        t = np.concatenate([tb, rng.uniform(-1.0, tb[-1] + 1.0, 50), [np.nan, -0.0]])
        want = np.clip(np.searchsorted(tb, t, side="right") - 1, 0, n - 1)
        assert np.array_equal(law._at0(t)[0], want)
