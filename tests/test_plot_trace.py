"""The advice plot's thinned trace (issue 36; fuzzyfeed.report.plot_trace): the same trace however
the rows are split, every arc-length bucket's first, last, least and greatest values kept, every xy
cell's last short segment kept (checked against a brute-force pass at the final sizes), a small
program kept whole, and windows of a few dozen lines on library programs give the whole read's
plot data."""

from __future__ import annotations

import os
import warnings

import numpy as np
import pytest

from fuzzyfeed.report.plot_trace import _SERIES, FuzzyTrace


def _columns(n: int, cuts: int, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    cut = np.sort(rng.integers(1, cuts + 1, n))
    step = rng.uniform(0.01, 0.3, n)
    s = np.zeros(n)
    xy = np.zeros((n, 2))
    for c in np.unique(cut):
        at = np.flatnonzero(cut == c)
        s[at] = np.concatenate([[0.0], np.cumsum(step[at][1:])])
        ang = np.cumsum(rng.normal(0, 0.3, at.size))
        xy[at] = rng.uniform(0, 5, 2) + np.cumsum(np.stack([np.cos(ang), np.sin(ang)], 1) * step[at, None], 0)
    cols = {"cut": cut, "s_mm": s, "x_mm": xy[:, 0], "y_mm": xy[:, 1],
            "programmed_feed_mm_min": rng.choice([800.0, 1200.0], n)}
    for k in _SERIES:
        cols[k] = np.round(rng.uniform(0, 100, n), 1)     # ties on purpose
    return cols


def _split(cols: dict, bounds) -> list[dict]:
    edges = [0, *bounds, len(cols["cut"])]
    return [{k: v[a:b] for k, v in cols.items()} for a, b in zip(edges[:-1], edges[1:])]


def _trace(parts, **kw) -> FuzzyTrace:
    t = FuzzyTrace(**kw)
    for p in parts:
        t.add(p)
    return t


def _same(a, b) -> None:
    da, db = a.data(), b.data()
    assert np.array_equal(da.s, db.s) and np.array_equal(da.segments, db.segments)
    assert np.array_equal(da.mid, db.mid) and da.value_range == db.value_range and da.cuts == db.cuts
    for k in _SERIES:
        assert np.array_equal(da.lines[k], db.lines[k])


def test_the_trace_does_not_depend_on_the_split_and_keeps_every_bucket_and_cell(monkeypatch):
    import fuzzyfeed.report.plot_trace as plot_trace

    cols = _columns(6000, 5, 1)
    kw = {"max_buckets": 64, "max_segments": 400}
    whole = _trace([cols], **kw)
    rng = np.random.default_rng(2)
    for pending in (1, 300, 10 ** 9):       # thinned after every piece, every few, only at the end
        monkeypatch.setattr(plot_trace, "PENDING_ROWS", pending)
        bounds = np.sort(rng.choice(np.arange(1, 6000), 12, replace=False))
        _same(whole, _trace(_split(cols, bounds), **kw))
    # brute force at the final sizes: the arc length end to end, every bucket's extremes
    d = whole.data()
    offset, s = 0.0, np.empty(6000)
    for c in np.unique(cols["cut"]):
        at = np.flatnonzero(cols["cut"] == c)
        s[at] = offset + cols["s_mm"][at]
        offset += cols["s_mm"][at][-1]
    bucket = np.floor(s / whole.width).astype(np.int64)
    kept = np.floor(d.s / whole.width).astype(np.int64)
    assert np.unique(bucket).size <= 64 and np.unique(bucket).size > 16 and d.s.size < 6000
    for b in np.unique(bucket):
        here, mine = bucket == b, kept == b
        assert s[here][0] == d.s[mine][0] and s[here][-1] == d.s[mine][-1]
        for k in _SERIES:
            assert cols[k][here].min() == d.lines[k][mine].min() and cols[k][here].max() == d.lines[k][mine].max()
    # every cell's last short segment (by a dict, in order), and every longer one
    xy = np.stack([cols["x_mm"], cols["y_mm"]], 1)
    last, longer = {}, []
    for i in range(1, 6000):
        if cols["cut"][i] != cols["cut"][i - 1]:
            continue
        a, b = xy[i - 1], xy[i]
        if np.linalg.norm(b - a) <= whole.cell:
            last[tuple(np.floor(0.5 * (a + b) / whole.cell).astype(int))] = i
        else:
            longer.append(i)
    want = sorted([*last.values(), *longer])
    assert len(want) == d.mid.size <= 400 and len(want) < 5990
    raw = whole._seg                  # the kept segments as they are on the path
    assert np.array_equal(raw["b"], xy[want]) and np.array_equal(raw["a"], xy[np.array(want) - 1])
    # drawn about their middles, along themselves, at least sqrt(2) cells long: no gap between cells
    length = np.linalg.norm(raw["b"] - raw["a"], axis=1)
    drawn = np.linalg.norm(d.segments[:, 1] - d.segments[:, 0], axis=1)
    assert np.allclose(d.segments.mean(axis=1), 0.5 * (raw["a"] + raw["b"]), rtol=0, atol=1e-12)
    assert np.allclose(drawn, np.maximum(length, 2 ** 0.5 * whole.cell), rtol=1e-12, atol=1e-12)
    feed = cols["feed_pct"] / 100.0 * cols["programmed_feed_mm_min"] / 60.0 * 60.0
    assert np.allclose(d.mid, 0.5 * (feed[np.array(want) - 1] + feed[want]), rtol=0, atol=0)


def test_a_small_program_keeps_every_sample_and_segment():
    cols = _columns(3000, 3, 4)
    d = _trace(_split(cols, [700, 1900])).data()
    assert d.s.size == 3000 and d.mid.size == 3000 - 3 and d.cuts == 3
    for k in _SERIES:
        assert np.array_equal(d.lines[k], cols[k])


def test_windows_on_library_programs_give_the_whole_reads_plot_data(monkeypatch):
    """Windows of 40 lines (the pieces' rows from the windows) against the whole read's pieces."""
    import fuzzyfeed.program.windows as windows
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.program.stream import stream_program_advice
    from fuzzyfeed.program.window_advice import advise_in_windows
    from test_program_windows import _programs

    monkeypatch.setattr(windows, "MAX_GROWTH", 1 << 20)
    table = load_rule_table(None)
    done = 0
    for path in _programs(20_000):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                program = read_program(path)
                if program.n_cuts == 0:
                    continue
                win = FuzzyTrace(max_buckets=256, max_segments=2000)
                advise_in_windows(path, table, step_mm=0.25, cap_mm_min=None, feed_step_mm_min=10.0,
                                  sink=win.add, window_lines=40)
            except Exception:
                continue                 # the windows fall back (or the read refuses it): not this test's
            whole = FuzzyTrace(max_buckets=256, max_segments=2000)
            for piece in stream_program_advice(program, table, step_mm=0.25, feed_step_mm_min=10.0):
                whole.add(piece.columns)
        _same(whole, win)
        done += 1
        if done >= 4:
            break
    assert done >= 4
