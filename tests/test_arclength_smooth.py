"""Smooth's few-query Hermite path (basis rows in one array) against the plain Hermite
formula, bit for bit; the planner's pieces keep one interpolant per (s, q)."""

from __future__ import annotations

import numpy as np
import pytest
from planner_helpers import ARM3R, WAYPOINTS_3R

from robodcn.contract.request import PlanRequest
from robodcn.path_timing.arclength import Smooth, arc_length, uneven
from robodcn.planner.arc import by_arc_length
from robodcn.planner.optimal import OptimalTiming
from robodcn.planner.pieces import build_pieces


@pytest.mark.parametrize("width", [None, 1, 3])
@pytest.mark.parametrize("monotone", [False, True])
def test_hermite_rows_are_the_plain_formula_bit_for_bit(width: int | None,
                                                        monotone: bool) -> None:
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(2, 150))
        x = np.unique(np.concatenate([[0.0, 1.0], rng.random(n)]))
        if monotone:
            if width is not None:
                continue
            y = np.cumsum(rng.random(x.shape[0]))
        else:
            shape = (x.shape[0],) if width is None else (x.shape[0], width)
            y = rng.normal(size=shape)
        smooth = Smooth(x, y, monotone=monotone)
        xq = rng.random(int(rng.integers(1, 2 * x.shape[0] - 1))) * 1.2 - 0.1
        clipped = np.clip(xq, x[0], x[-1])
        i = np.clip(np.searchsorted(x, clipped, side="right") - 1, 0, x.shape[0] - 2)
        h = np.diff(x)[i]
        t = (clipped - x[i]) / h
        np.testing.assert_array_equal(smooth._hermite(i, t, h), smooth._hermite_any(i, t, h))


def test_arc_length_is_the_graph_length() -> None:
    """σ as its docstring's formula (numpy.linalg.norm of the steps), in [0, 1]."""
    rng = np.random.default_rng(2)
    u = np.sort(np.concatenate([[0.0, 1.0], rng.random(40)]))
    q = np.cumsum(rng.normal(size=(u.shape[0], 3)), axis=0)
    step = np.linalg.norm(np.diff(q, axis=0), axis=1)
    step = np.hypot(step, step.sum() * np.diff(u) / (u[-1] - u[0]))
    want = np.concatenate([[0.0], np.cumsum(step)]) / step.sum()
    want[-1] = 1.0
    np.testing.assert_array_equal(arc_length(q, u), want)
    steps = np.diff(want)
    assert uneven(want) == steps.max() * steps.shape[0]


def test_a_piece_keeps_its_interpolant_until_its_samples_change() -> None:
    req = PlanRequest(arm=ARM3R, waypoints=WAYPOINTS_3R[:2], rate_hz=100)
    pieces, _ = build_pieces(req)
    assert pieces is not None
    piece = by_arc_length(req, pieces)[0]
    first = piece.interpolant()
    assert piece.interpolant() is first
    np.testing.assert_array_equal(first(piece.s), piece.q)
    piece.q = piece.q + 1.0
    assert piece.interpolant() is not first
    np.testing.assert_array_equal(piece.interpolant()(piece.s), piece.q)


def test_sampling_twice_gives_the_same_plan() -> None:
    """A law sampled again (a retry's round) reads the kept interpolant: the same samples."""
    req = PlanRequest(arm=ARM3R, waypoints=WAYPOINTS_3R, rate_hz=100)
    pieces, _ = build_pieces(req)
    law = OptimalTiming(req, pieces)
    a, b = law.sample(), law.sample()
    np.testing.assert_array_equal(a.joints, b.joints)
    np.testing.assert_array_equal(a.poses, b.poses)
    np.testing.assert_array_equal(a.segment_of, b.segment_of)
    assert a.marks == b.marks


@pytest.mark.parametrize("seed", range(6))
def test_counted_interval_index_is_searchsorted(seed: int) -> None:
    """_right_index counts the data points below many sorted queries (with repeats, data
    points among them and the ends); unsorted and NaN queries take numpy's search; the
    same integers either way."""
    from robodcn.path_timing import arclength

    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(0.0, 1.0, 40))
    x[0], x[-1] = 0.0, 1.0
    xq = np.sort(np.concatenate([rng.uniform(0.0, 1.0, 600), x[::3], [0.0, 1.0, 1.0]]))
    assert xq.shape[0] > arclength.MERGE_SHARE * x.shape[0]
    for queries in (xq, xq[::-1].copy(), np.where(np.arange(xq.shape[0]) == 7, np.nan, xq)):
        got = arclength._right_index(x, queries)
        assert np.array_equal(got, np.searchsorted(x, queries, side="right"))
