"""The G1-run fit window after window (fuzzyfeed.geometry.polyline, issue 36): a point sequence longer
than the window is fitted in pieces — the run search stopped before any trial reaching a window's
last vertex and resumed with the last run carried, the per-vertex pass with the arc length carried —
and gives the whole sequence's κ, corners and tangents bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from test_polyline import rounded_circle, wavy_spiral
from fuzzyfeed.geometry import polyline as pl
from fuzzyfeed.geometry import polyline_runs as runs

pytest.importorskip("numba")


def _cases():
    rng = np.random.default_rng(7)
    sq = np.array([[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]], dtype=float)
    t = np.linspace(0, 6 * np.pi, 6000)
    raster = np.column_stack([np.repeat(np.arange(6) * 0.5, 1000), np.tile(np.linspace(0, 50, 1000), 6),
                              0.3 * np.sin(t)])
    circle = rounded_circle(20.0, 0.001)
    return {
        "closed circle": rounded_circle(200.0, 1e-4, decimals=4),
        "open arc": rounded_circle(30.0, 0.001, sweep=1.5 * np.pi),
        "squares": np.round(np.concatenate([sq * (1 + k * 0.01) for k in range(300)]), 3),
        "random polygon": np.round(rng.uniform(-50, 50, (3000, 2)), 3),
        "3-D walk": np.round(np.cumsum(rng.normal(0, 0.05, (3000, 3)), axis=0), 4),
        "wavy spiral (smooth arc chains)": wavy_spiral(100_000)[0][5000:15000],
        "closed wavy": np.vstack([wavy_spiral(8000)[0], wavy_spiral(8000)[0][:1]]),
        "3-D raster": np.round(raster, 3),
        "duplicates (clusters)": np.repeat(circle, rng.integers(1, 3, len(circle)), axis=0),
        "full precision": np.column_stack([np.cos(t[:2000]), np.sin(t[:2000])]) * 17.0,
    }


CASES = _cases()


def _same(a: pl.PolylineCurvature, b: pl.PolylineCurvature) -> bool:
    return (np.array_equal(a.curvature, b.curvature) and np.array_equal(a.corner, b.corner)
            and np.array_equal(a.tangent, b.tangent) and a.tolerance_mm == b.tolerance_mm)


@pytest.mark.parametrize("name", list(CASES))
def test_windowed_fit_equals_the_whole_fit_bit_for_bit(name, monkeypatch):
    monkeypatch.setattr(runs, "COMPILED_MIN_VERTICES", 0)     # the windowed search is the compiled one
    pts = CASES[name]
    whole = pl.polyline_curvature(pts, window=10**9)
    for window in (20, 97, 1000):
        assert _same(pl.polyline_curvature(pts, window=window), whole), (name, window)


def test_windowed_search_without_the_stop_before_the_window_end_differs(monkeypatch):
    """The check can fail: a search allowed trials up to the window's last vertex (the run cut
    there, the gallop's trials clamped to it) finds other runs on the wavy spiral."""
    monkeypatch.setattr(runs, "COMPILED_MIN_VERTICES", 0)
    pts = CASES["wavy spiral (smooth arc chains)"]
    whole = pl.polyline_curvature(pts, window=10**9)
    kernel = runs.run_search_kernel()

    def no_stop(pts_, turn, maybe, tol, path_tol, ij, kind, fit, i0, count0, limit, stop):
        return kernel(pts_, turn, maybe, tol, path_tol, ij, kind, fit, i0, count0, len(pts_), stop)

    monkeypatch.setattr(runs, "run_search_kernel", lambda: no_stop)
    assert not _same(pl.polyline_curvature(pts, window=97), whole)


def test_rounding_quantum_in_chunks_is_the_whole_one(monkeypatch):
    rng = np.random.default_rng(1)
    for decimals in (2, 3, 4):
        pts = np.round(rng.uniform(-100, 100, (5000, 3)), decimals)
        pts[::17] += 1e-7          # under 10 % off the grid
        whole = pl.rounding_quantum(pts)
        monkeypatch.setattr(pl, "WINDOW_VERTICES", 64)
        assert pl.rounding_quantum(pts) == whole == pytest.approx(10.0 ** -decimals)
        monkeypatch.setattr(pl, "WINDOW_VERTICES", 1 << 16)
    assert pl.rounding_quantum(rng.uniform(-1, 1, (300, 2))) is None
