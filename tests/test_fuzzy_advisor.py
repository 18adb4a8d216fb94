"""Features, average filter and the advisor on the shipped shapes (seed 002)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.signal import find_peaks

from fuzzyfeed.errors import InputError, MachineLimitsError
from fuzzyfeed.fuzzy.advisor import advise, advise_details, average_filter
from fuzzyfeed.fuzzy.engine import compile_table
from fuzzyfeed.fuzzy.features import features, forward_window_max, normalise
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.io.shapes import load_shape, sample_shape
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.geometry.sampling import PathSamples, sample_uniform_u

from conftest import circle_nurbs

floats = st.floats(0, 50, allow_nan=False, allow_infinity=False)


@pytest.fixture(scope="module")
def paper():
    return load_rule_table()


@pytest.fixture(scope="module")
def shipped(paper):
    out = {}
    for name in ("infinity", "trident", "butterfly"):
        samples = sample_shape(load_shape(name), 2000)
        out[name] = (advise_details(samples, paper, 100.0),
                     advise_details(samples, replace(paper, window_points=1), 100.0))
    return out


# ---------------------------------------------------------------------------------------------
# features and filter against naive loops

@settings(max_examples=200, deadline=None)
@given(arrays(float, st.integers(1, 80), elements=floats), st.integers(1, 100))
def test_forward_window_max_equals_a_naive_loop(values, ws):
    want = np.array([values[i:i + ws].max() for i in range(values.size)])
    np.testing.assert_array_equal(forward_window_max(values, ws), want)


@settings(max_examples=200, deadline=None)
@given(arrays(float, st.integers(1, 80), elements=floats), st.integers(0, 15).map(lambda h: 2 * h + 1))
def test_average_filter_equals_a_naive_loop(values, m):
    n = values.size
    want = []
    for i in range(n):
        h = min(m // 2, i, n - 1 - i)
        want.append(values[i - h:i + h + 1].mean())
    np.testing.assert_allclose(average_filter(values, m), want, rtol=1e-12, atol=1e-12)


def test_average_filter_keeps_ends_and_constants():
    v = np.array([5.0, 1.0, 9.0, 3.0, 7.0])
    out = average_filter(v, 3)
    assert out[0] == 5.0 and out[-1] == 7.0 and out[1] == pytest.approx(5.0)
    np.testing.assert_allclose(average_filter(np.full(50, 42.0), 21), 42.0)
    np.testing.assert_array_equal(average_filter(v, 1), v)
    with pytest.raises(InputError, match="filter_points = 0"):
        average_filter(v, 0)


def test_normalisation_clip_and_constant():
    np.testing.assert_array_equal(normalise(np.full(10, 0.3), 3.0), np.zeros(10))
    np.testing.assert_allclose(normalise(np.array([0.0, 1.0, 5.0, 40.0]), 3.0), [0, 1 / 3, 1, 1])
    f = features(np.array([0.0, 0.0, 10.0, 0.0, 0.0]), window_points=2, clip_1_mm=3.0)
    np.testing.assert_array_equal(f.window_max_1_mm, [0, 10, 10, 0, 0])
    np.testing.assert_array_equal(f.curvature_variation, [0, 1, 1, 0, 0])


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_nan_or_infinite_curvature_is_an_error(bad, paper):
    k = np.array([0.1, 0.2, bad, 0.1])
    with pytest.raises(InputError, match=r"curvature\[2\] = (nan|inf); curvature must be finite"):
        features(k)
    n = k.size
    xyz = np.zeros((n, 3))
    xyz[:, 0] = np.arange(n)
    samples = PathSamples(u=np.linspace(0, 1, n), xyz=xyz, s=np.arange(n, dtype=float),
                          tangent=np.tile([1.0, 0, 0], (n, 1)), curvature=k, d1=xyz, d2=xyz)
    with pytest.raises(InputError, match=r"curvature\[2\]"):
        advise(samples, paper)


# ---------------------------------------------------------------------------------------------
# the advisor

def test_straight_line_gets_the_top_feed(paper):
    line = sample_uniform_u(Nurbs(1, [0, 0, 1, 1], [[0, 0], [100, 30]]), 500)
    advice = advise_details(line, paper, 100.0)
    top = compile_table(paper).feed_pct([0.0], [0.0])[0]     # TF alone: its centroid, 95 %
    assert top == pytest.approx(95.0)
    np.testing.assert_allclose(advice.feed_pct, top, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(advice.features.curvature_variation, 0.0)
    # nothing on any shipped shape is faster than the straight line
    for name in ("infinity", "wm", "butterfly"):
        assert advise(sample_shape(load_shape(name), 500), paper).feed_pct.max() <= top + 1e-9


def test_circle_has_constant_feed(paper):
    circle = sample_uniform_u(circle_nurbs(10.0), 400)
    advice = advise_details(circle, paper, 100.0)
    np.testing.assert_allclose(advice.features.curvature_variation, 0.0, atol=0)
    np.testing.assert_allclose(advice.feed_pct, advice.feed_pct[0], rtol=0, atol=1e-9)


def test_profile_units_and_method(shipped):
    advice = shipped["infinity"][0]
    p = advice.profile
    assert p.method == "fuzzy" and p.max_feed_mm_s == 100.0
    np.testing.assert_allclose(p.feed_mm_min, advice.feed_pct / 100 * 6000.0, rtol=1e-15)
    np.testing.assert_allclose(p.feed_pct, advice.feed_pct, rtol=1e-14)


def test_inputs_beyond_the_universe_clip(paper, shipped):
    advice = shipped["butterfly"][0]
    k = advice.features.curvature_1_mm
    assert k.max() > 30 * paper.curvature.universe[1]       # far above κ_top = 1 /mm
    e = compile_table(paper)
    np.testing.assert_array_equal(e.feed_pct(k, advice.features.curvature_variation),
                                  e.feed_pct(np.minimum(k, 1.0), advice.features.curvature_variation))


def test_feed_never_below_the_floor_never_zero_or_nan(paper):
    high_floor = replace(paper, feed_floor_pct=30.0)
    for name in ("infinity", "trident", "butterfly", "wm", "trident2"):
        samples = sample_shape(load_shape(name), 2000)
        for table in (paper, high_floor):
            advice = advise_details(samples, table, 50.0)
            assert np.isfinite(advice.feed_pct).all()
            assert advice.feed_pct.min() >= table.feed_floor_pct
            assert advice.profile.feed_mm_s.min() > 0
    # the floor binds: the butterfly's controller goes below 30 %
    b = advise_details(sample_shape(load_shape("butterfly"), 2000), high_floor)
    assert b.controller_pct.min() < 30 and b.feed_pct.min() == 30.0


@pytest.mark.parametrize("bad", [0.0, -5.0, np.nan, np.inf])
def test_bad_max_feed(paper, bad):
    samples = sample_shape(load_shape("infinity"), 100)
    with pytest.raises(MachineLimitsError, match="the maximum feed must be finite and > 0"):
        advise(samples, paper, bad)


def _region_starts(kappa: np.ndarray, thr: float) -> np.ndarray:
    above = kappa >= thr
    return np.flatnonzero(above[1:] & ~above[:-1]) + 1


@pytest.mark.parametrize("name", ["infinity", "trident", "butterfly"])
def test_feed_drops_before_each_high_curvature_region(shipped, paper, name):
    advice, no_lookahead = shipped[name]
    k = advice.features.curvature_1_mm
    f, f1 = advice.feed_pct, no_lookahead.feed_pct
    ws = paper.window_points
    thr = 0.5 * k.max()
    starts = [i for i in _region_starts(k, thr) if i >= 2 * ws and (k[i - 2 * ws:i] < thr).all()]
    assert len(starts) >= 2
    earlier = []
    for i0 in starts:
        # well before the region the feed is high; half a window before entry it has come down
        assert f[i0 - 2 * ws:i0 - ws].max() > f[i0 - ws // 2] + 5.0, (name, i0)
        assert f[i0] < f[i0 - 2 * ws:i0 - ws].max() - 5.0, (name, i0)
        # and it is the look-ahead window Dκ that brings it down early: never later than without
        # it, and clearly earlier somewhere (where κ is still low half a window before entry)
        assert f[i0 - ws // 2] <= f1[i0 - ws // 2] + 0.01, (name, i0)
        earlier.append(f1[i0 - ws // 2] - f[i0 - ws // 2])
    assert max(earlier) > 1.0, (name, earlier)


def _extrema(x: np.ndarray, prominence: float = 1.0) -> np.ndarray:
    return np.sort(np.concatenate([find_peaks(x, prominence=prominence)[0],
                                   find_peaks(-x, prominence=prominence)[0]]))


@pytest.mark.parametrize("name", ["infinity", "trident", "butterfly"])
def test_average_filter_removes_the_oscillation(shipped, paper, name):
    advice = shipped[name][0]
    raw = advice.controller_pct
    smooth = advice.feed_pct
    # point-to-point jumps (the "oscillation") shrink at least tenfold
    assert np.abs(np.diff(smooth, 2)).max() * 10 <= np.abs(np.diff(raw, 2)).max()
    # no more ups and downs than before, and no reversal of 5 % or more within half a filter
    # window (the raw controller output of the butterfly has dozens)
    half = paper.filter_points // 2
    ext_raw, ext = _extrema(raw, 5.0), _extrema(smooth, 5.0)
    assert ext.size <= ext_raw.size
    assert (np.diff(ext) < half).sum() == 0
    if name == "butterfly":
        assert (np.diff(ext_raw) < half).sum() >= 10
        assert _extrema(smooth, 1.0).size < 0.7 * _extrema(raw, 1.0).size


def _samples_with_curvature(k: np.ndarray) -> PathSamples:
    n = k.size
    xyz = np.zeros((n, 3))
    xyz[:, 0] = np.arange(n, dtype=float)
    return PathSamples(u=np.linspace(0, 1, n), xyz=xyz, s=np.arange(n, dtype=float),
                       tangent=np.tile([1.0, 0, 0], (n, 1)), curvature=k, d1=xyz, d2=xyz)


@settings(max_examples=150, deadline=None)
@given(arrays(float, st.integers(2, 300), elements=st.floats(0, 1e4, allow_nan=False)),
       st.floats(0.1, 1e4), st.integers(1, 60), st.integers(0, 20).map(lambda h: 2 * h + 1),
       st.floats(0.1, 100))
def test_feed_always_within_floor_and_max(paper, k, max_feed, ws, m, floor):
    table = replace(paper, window_points=ws, filter_points=m, feed_floor_pct=floor)
    advice = advise_details(_samples_with_curvature(k), table, max_feed)
    pct = advice.feed_pct
    assert np.isfinite(pct).all() and (pct >= floor).all() and (pct <= 100).all()
    assert (advice.profile.feed_mm_s > 0).all() and (advice.profile.feed_mm_s <= max_feed * (1 + 1e-12)).all()
    assert ((advice.features.curvature_variation >= 0) & (advice.features.curvature_variation <= 1)).all()


def _l_path(step_first_leg: float) -> np.ndarray:
    """An L of two 40 mm legs with one true corner, the first leg cut into ``step`` mm and the
    second leg a quarter arc of R 5 flattened finely (as a DXF chain of a LINE and an ARC is)."""
    first = np.column_stack([np.arange(0.0, 40.0, step_first_leg), np.zeros(int(round(40 / step_first_leg)))])
    theta = np.linspace(0.0, np.pi / 2, 800)
    arc = np.column_stack([40.0 + 5.0 * np.sin(theta), 5.0 - 5.0 * np.cos(theta)])
    return np.vstack([first, arc])


def test_point_sequence_windows_are_lengths_not_point_counts(paper):
    from fuzzyfeed.geometry.sampling import POINT_STEP_MM, samples_from_points

    coarse = advise_details(samples_from_points(_l_path(1.0)), paper, 100.0)
    fine = advise_details(samples_from_points(_l_path(0.1)), paper, 100.0)
    # the windows became lengths (WS and M points at the step whole programs are sampled at)
    assert coarse.table.window_mm == pytest.approx((paper.window_points - 1) * POINT_STEP_MM)
    assert coarse.table.filter_mm == pytest.approx((paper.filter_points - 1) * POINT_STEP_MM)
    for adv in (coarse, fine):
        s, pct = adv.profile.samples.s, adv.feed_pct
        # the first 10 mm of the leg (30 mm before the corner) run at the straight-line feed;
        # counted in points, 30 points of 1 mm (and a filter of 21) slow the whole leg down
        straight = s < 10.0
        assert np.ptp(pct[straight]) < 1e-9 and pct[straight][0] > 90.0
        assert pct[np.argmin(np.abs(s - 40.0))] < 20.0
    # the same path at another spacing gets the same advice where both have points
    at = np.flatnonzero(coarse.profile.samples.s < 39.5)
    np.testing.assert_allclose(np.interp(coarse.profile.samples.s[at], fine.profile.samples.s, fine.feed_pct),
                               coarse.feed_pct[at], atol=6.0)


def test_point_sequence_keeps_lengths_the_table_gives(paper):
    from fuzzyfeed.geometry.sampling import samples_from_points

    table = replace(paper, window_mm=2.0, filter_mm=1.0)
    adv = advise_details(samples_from_points(_l_path(1.0)), table, 100.0)
    assert (adv.table.window_mm, adv.table.filter_mm) == (2.0, 1.0)
    # a NURBS keeps seed 002's point counts
    nurbs = advise_details(sample_uniform_u(circle_nurbs(10.0), 2000), paper, 100.0)
    assert nurbs.table.window_mm is None and nurbs.table.filter_mm is None
