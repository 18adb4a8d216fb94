"""The polyline curvature of a point sequence given in chunks (fuzzyfeed.geometry.polyline_stream,
issue 36): three passes over the chunks, memory bounded by a window of vertices, and the result of
polyline_curvature over the whole sequence bit for bit — on the window tests' cases, on open paths
with tiny moves, and on random polylines (hypothesis); both sides of the whole fallback."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from test_polyline import wavy_spiral
from test_polyline_window import CASES
from fuzzyfeed.errors import InputError
from fuzzyfeed.geometry import polyline as pl
from fuzzyfeed.geometry import polyline_runs as runs
from fuzzyfeed.geometry import polyline_stream as ps

pytest.importorskip("numba")


def _chunked(pts: np.ndarray, sizes):
    """chunks() over ``pts`` in pieces of the cycled ``sizes``, and how often it was called."""
    calls = []

    def chunks():
        calls.append(1)
        i, k = 0, 0
        while i < len(pts):
            yield pts[i:i + sizes[k % len(sizes)]]
            i += sizes[k % len(sizes)]
            k += 1
    return chunks, calls


def _streamed(pts, sizes=(333,), window=97, **kw):
    chunks, calls = _chunked(pts, sizes)
    fit = ps.fit_chunks(chunks, window=window, **kw)
    parts = list(fit.pieces())
    out = tuple(np.concatenate([p[i] for p in parts]) for i in range(3))
    return fit, out, len(calls)


def _equal(fit, out, whole) -> bool:
    return (np.array_equal(out[0], whole.curvature) and np.array_equal(out[1], whole.tangent)
            and np.array_equal(out[2], whole.corner) and fit.tolerance_mm == whole.tolerance_mm
            and fit.quantum_mm == whole.quantum_mm and fit.path_tolerance_mm == whole.path_tolerance_mm)


def _open_with_tiny_moves():
    rng = np.random.default_rng(3)
    pts = wavy_spiral(60_000)[0][2000:6000]
    rep = np.repeat(pts, rng.integers(1, 4, len(pts)), axis=0)
    jog = rng.random(len(rep)) < 0.05
    rep[jog] += 0.0001                     # a 0.1 µm jog: merged into its cluster
    return rep


STREAM_CASES = dict(CASES, **{"open, tiny moves and duplicates": _open_with_tiny_moves(),
                              "inch-rounded 3-D walk": np.round(np.cumsum(np.random.default_rng(5).normal(
                                  0, 0.004, (3000, 3)), axis=0) / 25.4, 4) * 25.4})


@pytest.fixture(autouse=True)
def _compiled(monkeypatch):
    monkeypatch.setattr(runs, "COMPILED_MIN_VERTICES", 0)     # the windowed search is the compiled one


@pytest.mark.parametrize("name", list(STREAM_CASES))
def test_streamed_fit_equals_the_whole_fit_bit_for_bit(name):
    pts = STREAM_CASES[name]
    whole = pl.polyline_curvature(pts, window=10**9)
    for window, sizes in ((20, (7,)), (97, (50, 1, 333)), (1000, (4096,))):
        fit, out, calls = _streamed(pts, sizes, window)
        assert _equal(fit, out, whole), (name, window, sizes)
        assert fit.n == len(pts) and calls == 3         # scan, vertices, fit (or the whole read)


def test_which_paths_are_streamed_and_which_fitted_whole():
    bounded = {name: _streamed(pts, window=97)[0].bounded for name, pts in STREAM_CASES.items()}
    assert bounded["wavy spiral (smooth arc chains)"] and bounded["3-D raster"]
    assert bounded["open, tiny moves and duplicates"] and bounded["inch-rounded 3-D walk"]
    assert not bounded["closed circle"] and not bounded["closed wavy"]      # the seam
    assert not bounded["full precision"]                                    # no rounding to see through
    fit = _streamed(STREAM_CASES["3-D raster"], window=10_000)[0]
    assert not fit.bounded and fit.m <= 10_000                              # one window: whole


def test_the_window_sees_one_run_beyond_its_own_on_each_side(monkeypatch):
    """The check can fail: without the runs beyond those touching a window, the smooth chains'
    interpolation (and the meets at the window's edges) give other κ on the wavy spiral."""
    pts = STREAM_CASES["wavy spiral (smooth arc chains)"]
    whole = pl.polyline_curvature(pts, window=10**9)
    monkeypatch.setattr(ps, "NEAR_RUNS", 0)
    fit, out, _ = _streamed(pts, (333,), 97)
    assert fit.bounded and not _equal(fit, out, whole)


def test_memory_is_bounded_by_the_window():
    """The buffer of vertices never holds much more than a window and the longest run (the
    3-D raster's rows are 1000 vertices long)."""
    pts = STREAM_CASES["wavy spiral (smooth arc chains)"]
    chunks, _ = _chunked(pts, (50,))
    fit = ps.fit_chunks(chunks, window=200)
    held = []
    real = ps._StreamChords.release

    def spy(self, a):
        real(self, a)
        held.append(len(self._v))
    ps._StreamChords.release = spy
    try:
        list(fit.pieces())
    finally:
        ps._StreamChords.release = real
    assert held and max(held) < 1000 < len(pts)


def test_bad_points_are_refused_as_the_whole_fit_refuses_them():
    pts = np.round(np.random.default_rng(0).uniform(0, 10, (500, 2)), 3)
    pts[321, 1] = np.nan
    with pytest.raises(InputError, match=r"points\[321\] = \[.*nan\]; coordinates must be finite"):
        ps.fit_chunks(_chunked(pts, (100,))[0])
    with pytest.raises(InputError, match="points: shape"):
        ps.fit_chunks(_chunked(pts[:1], (100,))[0])
    with pytest.raises(InputError, match="path_tolerance_mm"):
        ps.fit_chunks(_chunked(pts[:10], (100,))[0], path_tolerance_mm=-1.0)


@st.composite
def polylines(draw):
    """Open polylines of lines, arcs and tiny moves, rounded in mm or inch (sometimes not at all)."""
    rng = np.random.default_rng(draw(st.integers(0, 2**31 - 1)))
    parts, p, heading = [np.zeros((1, 3))], np.zeros(3), 0.0
    for _ in range(draw(st.integers(3, 25))):
        kind = rng.integers(0, 3)
        if kind == 0:                      # a line of equal moves
            k = int(rng.integers(2, 60))
            step = rng.uniform(0.02, 1.0)
            heading += rng.uniform(-2.5, 2.5)
            d = np.array([np.cos(heading), np.sin(heading), rng.uniform(-0.2, 0.2)]) * step
            pts = p + d * np.arange(1, k + 1)[:, None]
        elif kind == 1:                    # an arc as chords
            r = rng.uniform(0.5, 40.0)
            sweep = rng.uniform(0.2, 4.0) * rng.choice([-1, 1])
            k = int(rng.integers(5, 120))
            t = heading + np.sign(sweep) * np.pi / 2
            c = p[:2] - r * np.array([np.cos(t), np.sin(t)])
            a = t + np.pi + sweep * np.arange(1, k + 1) / k
            pts = np.column_stack([c[0] + r * np.cos(a + np.pi), c[1] + r * np.sin(a + np.pi),
                                   np.full(k, p[2])])
            heading += sweep
        else:                              # tiny moves and jogs
            k = int(rng.integers(1, 8))
            pts = p + rng.normal(0, 0.0004, (k, 3))
        parts.append(pts)
        p = pts[-1]
    pts = np.concatenate(parts)
    unit = draw(st.sampled_from(["mm3", "mm4", "inch", "float"]))
    if unit == "mm3":
        pts = np.round(pts, 3)
    elif unit == "mm4":
        pts = np.round(pts, 4)
    elif unit == "inch":
        pts = np.round(pts / 25.4, 4) * 25.4
    if draw(st.booleans()):
        pts = pts[:, :2].copy()
    return pts


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(pts=polylines(), window=st.integers(8, 120), sizes=st.lists(st.integers(1, 200), min_size=1, max_size=4))
def test_streamed_fit_of_random_polylines_is_the_whole_fit(pts, window, sizes):
    runs.COMPILED_MIN_VERTICES = 0
    try:
        whole = pl.polyline_curvature(pts, window=10**9)
    except InputError:
        with pytest.raises(InputError):
            _streamed(pts, sizes, window)
        return
    fit, out, _ = _streamed(pts, sizes, window)
    assert _equal(fit, out, whole)


def _cluster_loop(pts, merge_mm):
    """The tiny moves' clusters as the per-point loop makes them (the reference)."""
    ids = np.zeros(len(pts), dtype=int)
    current, first = 0, pts[0]
    for i in range(1, len(pts)):
        if np.linalg.norm(pts[i] - first) >= merge_mm:
            current += 1
            first = pts[i]
        ids[i] = current
    return ids


def test_clusters_skip_the_loop_only_where_it_starts_a_cluster():
    """cluster_ids (whole, and in chunks from a carried state) gives the per-point loop's ids on
    paths whose steps sit on, just under and just over the merge distance."""
    from fuzzyfeed.geometry.polyline_chords import cluster_ids

    rng = np.random.default_rng(0)
    merge = 0.001
    for trial in range(200):
        n = int(rng.integers(2, 300))
        u = rng.normal(size=(n, 3))
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        mag = rng.choice([0.0, 0.0004, merge, merge * (1 - 1e-12), merge * (1 + 1e-12), 0.0015, 0.05], size=n)
        pts = np.cumsum(u * mag[:, None], axis=0)
        want = _cluster_loop(pts, merge)
        assert np.array_equal(cluster_ids(pts, merge)[0], want), trial
        parts, cur, first, i = [], 0, None, 0
        while i < n:
            k = int(rng.integers(1, 40))
            ids, cur, first = cluster_ids(pts[i:i + k], merge, cur, first)
            parts.append(ids)
            i += k
        assert np.array_equal(np.concatenate(parts), want), trial
