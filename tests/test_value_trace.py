"""The value plot's feed trace made block by block and thinned (fuzzyfeed.report.value_trace, issue 36):
the same step plot of F, and every replaced point within the stated share of the extent of the
segment drawn in its place."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from fuzzyfeed.machine.planner import Motion
from fuzzyfeed.program.run import Chain
from fuzzyfeed.report import value_trace as V


def _path(rng, n_chains=3, n=1500):
    chains = []
    for c in range(n_chains):
        t = np.linspace(0, 1, n + 1)
        if c == 0:      # a raster line: straight in x, y, z varying
            pts = np.column_stack([100 * t, np.full_like(t, 3.0), np.sin(40 * t)])
        elif c == 1:    # a circle: nothing to merge within the share
            pts = np.column_stack([20 * np.cos(6 * t), 20 * np.sin(6 * t), np.zeros_like(t)])
        else:           # a walk
            pts = np.cumsum(rng.normal(0, 0.1, (n + 1, 3)), axis=0)
        feed = np.repeat(rng.choice([10.0, 20.0, 30.0], n // 50 + 1), 50)[:n]
        measured = rng.random(n) > 0.05
        motion = Motion(pts, feed, np.zeros(n, bool), np.full(n + 1, np.nan))
        chains.append(Chain(motion, np.arange(n), measured))
    return SimpleNamespace(chains=chains)


def _value_at(s0, s1, f, x):
    i = np.searchsorted(s0, x, side="right") - 1
    inside = (i >= 0) & (x < s1[np.maximum(i, 0)])
    return np.where(inside, f[np.maximum(i, 0)], np.nan)


def test_blocks_give_the_whole_arc_lengths_and_feeds():
    path = _path(np.random.default_rng(1))
    s0, s1, f, a, b, _ = V._along(path)
    blocks = list(V._along(path, 777))
    for k, whole in enumerate((s0, s1, f, a, b)):
        np.testing.assert_allclose(np.concatenate([blk[k] for blk in blocks]), whole, rtol=0, atol=1e-9)


def test_thinned_steps_draw_the_same_feed():
    path = _path(np.random.default_rng(2))
    s0, s1, f, _, _, _ = V._along(path)
    t0, t1, tf = V._thin_steps(s0, s1, f)
    assert tf.size < f.size / 10
    x = 0.5 * (s0 + s1)
    np.testing.assert_array_equal(_value_at(t0, t1, tf, x), _value_at(s0, s1, f, x))


def test_thinned_segments_stay_within_the_share_and_keep_the_fractions():
    rng = np.random.default_rng(4)
    path = _path(rng)
    _, _, f, a, b, _ = V._along(path)
    frac = np.round(f / 30.0, 2)
    eps = 0.01
    ta, tb, tfrac = V._thin_segments(a, b, frac, eps)
    assert tfrac.size < 0.7 * frac.size    # the raster line merges; the circle and the walk do not
    # every original point lies within eps (x, y) of a thinned segment of its own fraction
    for pts in (a, b):
        best = np.full(len(pts), np.inf)
        for k in range(0, len(ta), 256):
            p, q, fr = ta[k:k + 256, :2], tb[k:k + 256, :2], tfrac[k:k + 256]
            d = q - p
            dd = np.maximum((d * d).sum(1), 1e-300)
            t = np.clip(((pts[:, None, :2] - p[None]) * d[None]).sum(2) / dd[None], 0, 1)
            dist = np.linalg.norm(pts[:, None, :2] - (p[None] + t[..., None] * d[None]), axis=2)
            dist = np.where(fr[None, :] == frac[:, None], dist, np.inf)
            best = np.minimum(best, dist.min(1))
        assert best.max() <= eps * (1 + 1e-9)
    # a share of 0 merges only exactly collinear runs; the circle keeps every segment
    _, _, f1 = V._thin_segments(a, b, frac, 0.0)
    assert f1.size < frac.size


def test_a_run_bending_more_than_the_share_is_kept_whole():
    t = np.linspace(0, np.pi / 2, 101)
    pts = np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)]) * 10
    a, b = pts[:-1], pts[1:]
    ta, tb, tf = V._thin_segments(a, b, np.ones(100), 0.01)
    np.testing.assert_array_equal(ta, a)
    np.testing.assert_array_equal(tb, b)


def test_column_extremes_keep_each_columns_first_last_lowest_and_highest_in_order():
    """M4 against a column-by-column count: every pixel column keeps its first and last vertex and
    its lowest and highest y, at most four vertices, in the polyline's order."""
    rng = np.random.default_rng(5)
    x = np.sort(rng.uniform(0, 50, 4000))
    y = rng.normal(0, 1, x.size).cumsum()
    x0, per = -1.0, 3.7
    xs, ys = V.column_extremes(x, y, x0, per, column0=0.4)
    kept = np.searchsorted(x, xs)                  # x is distinct: the vertex each kept one is
    assert np.array_equal(x[kept], xs) and np.array_equal(y[kept], ys)
    assert np.all(np.diff(kept) > 0)               # in order, none twice
    col = np.floor(0.4 + (x - x0) * per).astype(int)
    for c in np.unique(col):
        here = np.flatnonzero(col == c)
        mine = kept[col[kept] == c]
        assert 1 <= mine.size <= 4
        assert here[0] in mine and here[-1] in mine
        assert ys[col[kept] == c].min() == y[here].min() and ys[col[kept] == c].max() == y[here].max()


def _many_cut_trace(cuts: int, steps: int = 400):
    """A feed trace as a raster of ``cuts`` cuts gives: each a plunge at 300 mm/min, then ``steps``
    advised F steps between 600 and 2000 along 40 mm of the cut."""
    rng = np.random.default_rng(cuts)
    s0, f, wf, ws0 = [], [], [], []
    for c in range(cuts):
        base = 50.0 * c
        edges = base + np.concatenate([[0.0, 2.0], 2.0 + np.sort(rng.uniform(0, 40, steps - 1)), [42.0]])
        s0.append(edges[:-1])
        f.append(np.concatenate([[300.0], rng.uniform(600, 2000, steps)]))
        ws0.append([base, base + 2.0])
        wf.append([300.0, 2000.0])
    s0, f = np.concatenate(s0), np.concatenate(f)
    s1 = np.append(s0[1:], s0[-1] + 1.0)
    ws0, wf = np.concatenate(ws0), np.concatenate(wf)
    ws1 = np.append(ws0[1:], ws0[-1] + 40.0)
    pts = np.column_stack([s0 % 100, (s0 // 100) * 0.1, np.zeros_like(s0)])
    segs = np.stack([pts, pts + [0.1, 0.0, 0.0]], axis=1)
    return V.FeedTrace(s_mm={"as written": (ws0, ws1), "advised": (s0, s1)},
                       feed_mm_min={"as written": wf, "advised": f}, segments=segs,
                       advised_fraction=np.clip(f / 2000.0, 0, 1), over_s_mm=np.zeros(0),
                       over_xyz=np.zeros((0, 3)))


def test_the_value_plots_f_steps_are_drawn_with_as_many_vertices_for_40_cuts_as_for_10(monkeypatch):
    """Agg holds a cell for every pixel each edge of a path crosses before it fills it: the F steps
    of every cut drawn whole cost memory in proportion to the cuts (issue 36: the many-cut
    raster's --report grew ~40 B a line). The largest path the plot hands Agg is bounded by the
    figure's pixel columns (at most four vertices each), 10 cuts or 40, while the trace grows 4 x."""
    import io

    from matplotlib.backends.backend_agg import RendererAgg

    from fuzzyfeed.report import value_files

    drawn = []
    real = RendererAgg.draw_path

    def spy(self, gc, path, transform, rgbFace=None):
        drawn.append(len(path.vertices))
        return real(self, gc, path, transform, rgbFace)
    monkeypatch.setattr(RendererAgg, "draw_path", spy)
    largest = {}
    for cuts in (10, 40):
        tr = _many_cut_trace(cuts)
        drawn.clear()
        buf = io.BytesIO()
        value_files.plot_value(SimpleNamespace(trace=tr, tol_um=50.0, name="r"), buf)
        assert buf.getvalue().startswith(b"\x89PNG")
        largest[cuts] = max(drawn)
        assert 2 * tr.feed_mm_min["advised"].size > largest[cuts]       # the steps were cut down
    width_px = 13 * value_files.INLINE_DPI          # the figure's: the axes' columns are fewer
    assert max(largest.values()) <= 4 * width_px, largest
    assert largest[40] < 1.5 * largest[10], largest    # drawn whole: 4 x (the trace's steps)
