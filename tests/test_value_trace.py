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
