"""The exact Mamdani engine against two independent references.

1. A brute-force exact centroid written here in plain numpy: every candidate breakpoint of the
   aggregated set (all term vertices, every edge at every clip level, every pair of edges crossing)
   plus a dense grid, and 2-point Gauss-Legendre on each piece (exact for the linear pieces, and it
   never evaluates a piece at its ends, so vertical edges need no care). Tolerance 1e-9 %-feed.
2. scikit-fuzzy's ControlSystemSimulation with a 1001-point output universe: within its own
   discretisation error, 2e-3 %-feed.

Both on the paper's table and on random valid tables (random universes, term counts, triangles and
trapezoids, overlapping or gappy output terms, random grids).
"""

from __future__ import annotations

import csv
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.errors import InputError
from fuzzyfeed.fuzzy import engine as engine_mod
from fuzzyfeed.fuzzy.engine import compile_table
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.fuzzy.rules import RuleTable, Term, Variable
from fuzzyfeed.fuzzy.skfuzzy_ref import skfuzzy_feed_pct

GOLDEN = Path(__file__).parent / "golden" / "fuzzy_paper_surface.csv"
N_RANDOM_TABLES = 24


# ---------------------------------------------------------------------------------------------
# independent reference

def _mu(points, x):
    """Membership of one term (3 or 4 breakpoints) at array x, written from the definition."""
    p = list(points)
    a, b, c, d = (p[0], p[1], p[1], p[2]) if len(p) == 3 else p
    x = np.asarray(x, dtype=float)
    out = np.zeros_like(x)
    if b > a:
        m = (x > a) & (x < b)
        out[m] = (x[m] - a) / (b - a)
    out[(x >= b) & (x <= c)] = 1.0
    if d > c:
        m = (x > c) & (x < d)
        out[m] = (d - x[m]) / (d - c)
    return out


def _edges(points):
    """The sloped edges of a term as (x0, y0, x1, y1)."""
    p = list(points)
    a, b, c, d = (p[0], p[1], p[1], p[2]) if len(p) == 3 else p
    out = []
    if b > a:
        out.append((a, 0.0, b, 1.0))
    if d > c:
        out.append((c, 1.0, d, 0.0))
    return out


def brute_force_centroid(table: RuleTable, kappa: float, dk: float, dense: int = 400) -> float:
    k = float(np.clip(kappa, *table.curvature.universe))
    d = float(np.clip(dk, *table.curvature_variation.universe))
    mk = {t.label: float(_mu(t.points, np.array([k]))[0]) for t in table.curvature.terms}
    md = {t.label: float(_mu(t.points, np.array([d]))[0]) for t in table.curvature_variation.terms}
    level = {t.label: 0.0 for t in table.feed.terms}
    for lk, ld, lf in table.rules:
        level[lf] = max(level[lf], min(mk[lk], md[ld]))
    terms = [(t.points, level[t.label]) for t in table.feed.terms if level[t.label] > 0]
    if not terms:
        return table.feed_floor_pct
    lo, hi = table.feed.universe
    cand = [lo, hi, *np.linspace(lo, hi, dense)]
    edges = [e for pts, _ in terms for e in _edges(pts)]
    levels = [h for _, h in terms]
    for pts, _ in terms:
        cand += list(pts)
    for x0, y0, x1, y1 in edges:
        for h in levels:
            if min(y0, y1) < h < max(y0, y1):
                cand.append(x0 + (h - y0) * (x1 - x0) / (y1 - y0))
    for i, (a0, b0, a1, b1) in enumerate(edges):
        sa = (b1 - b0) / (a1 - a0)
        for c0, d0, c1, d1 in edges[i + 1:]:
            sc = (d1 - d0) / (c1 - c0)
            if sa == sc:
                continue
            x = (d0 - b0 + sa * a0 - sc * c0) / (sa - sc)
            if max(a0, c0) < x < min(a1, c1):
                cand.append(x)
    xs = np.unique(np.clip(cand, lo, hi))
    x0, x1 = xs[:-1], xs[1:]
    half, mid = 0.5 * (x1 - x0), 0.5 * (x0 + x1)
    g = half / np.sqrt(3.0)
    area = moment = 0.0
    for node in (mid - g, mid + g):
        agg = np.zeros_like(node)
        for pts, h in terms:
            agg = np.maximum(agg, np.minimum(_mu(pts, node), h))
        area += float(np.sum(half * agg))
        moment += float(np.sum(half * agg * node))
    return moment / area


# ---------------------------------------------------------------------------------------------
# random valid tables

def _input_variable(rng, name, lo, hi, n, trapezoids=True):
    peaks = np.sort(rng.uniform(lo, hi, n - 2)) if n > 2 else np.array([])
    peaks = np.concatenate([[lo], peaks, [hi]])
    peaks = np.maximum.accumulate(peaks + np.arange(n) * 1e-3 * (hi - lo))
    peaks = np.minimum(peaks, hi)
    span = hi - lo
    terms = []
    for i in range(n):
        left = lo if i == 0 else max(lo, peaks[i - 1] - rng.uniform(0, 0.1) * span)
        right = hi if i == n - 1 else min(hi, peaks[i + 1] + rng.uniform(0, 0.1) * span)
        top = float(peaks[i])
        if i == 0:
            pts = [lo, lo, max(right, lo + 0.02 * span)]
        elif i == n - 1:
            pts = [min(left, hi - 0.02 * span), hi, hi]
        elif trapezoids and rng.random() < 0.3:
            w = rng.uniform(0, 0.5) * (right - top)
            pts = [left, top, top + w, right]
        else:
            pts = [left, top, right]
        if pts[0] == pts[1] and i != 0:
            pts[0] = max(lo, pts[1] - 0.01 * span)
        terms.append(Term(f"{name[0].upper()}{i}", tuple(float(x) for x in pts)))
    return Variable(name, (float(lo), float(hi)), tuple(terms))


def _output_variable(rng, n, vertical_edges=False, gentle=False):
    """Random output terms; ``gentle``: every sloped edge at least 1/5 of a term's width and terms
    at least 15 % wide (what a 1001-point grid resolves to 2e-3 %), else anything down to
    vertical edges."""
    terms = []
    for i in range(n):
        width = rng.uniform(15, 45) if gentle else rng.uniform(2, 45)
        a = rng.uniform(0, 100 - width)
        d = a + width
        margin = 0.2 * width if gentle else 0.0
        if rng.random() < 0.35:
            b, c = np.sort(rng.uniform(a + margin, d - margin, 2))
            pts = [a, b, c, d]
        else:
            pts = [a, rng.uniform(a + max(margin, 0.01 * width), d - max(margin, 0.01 * width)), d]
        if vertical_edges and rng.random() < 0.3:
            pts[1] = pts[0]                     # an interior vertical edge (shoulder)
        pts = [float(round(x, 1)) if gentle else float(x) for x in pts]
        pts = sorted(pts)
        terms.append(Term(f"F{i}", tuple(pts)))
    if rng.random() < 0.5:                      # a shoulder at one end of the universe
        terms[0] = Term("F0", (0.0, 0.0, float(round(rng.uniform(15, 30), 1))))
    return Variable("feed", (0.0, 100.0), tuple(terms))


def random_table(seed: int, vertical_edges: bool = False, gentle: bool = False) -> RuleTable:
    rng = np.random.default_rng(seed)
    k_top = float(rng.uniform(0.3, 3.0))
    k = _input_variable(rng, "curvature", 0.0, k_top, int(rng.integers(2, 8)))
    d = _input_variable(rng, "curvature_variation", 0.0, 1.0, int(rng.integers(2, 7)))
    f = _output_variable(rng, int(rng.integers(3, 10)), vertical_edges, gentle)
    grid = tuple(tuple(str(rng.choice(f.labels)) for _ in d.terms) for _ in k.terms)
    return RuleTable(name=f"random{seed}", curvature=k, curvature_variation=d, feed=f, grid=grid,
                     feed_floor_pct=float(rng.uniform(1, 10)))


def _random_inputs(table: RuleTable, rng, n: int):
    k_hi = table.curvature.universe[1]
    kappa = rng.uniform(-0.1 * k_hi, 1.2 * k_hi, n)
    dk = rng.uniform(-0.1, 1.1, n)
    # also exact breakpoints, where edges start and memberships are 0 or 1
    kb = np.array([p for t in table.curvature.terms for p in t.points])
    db = np.array([p for t in table.curvature_variation.terms for p in t.points])
    kappa[: kb.size] = kb[: n]
    dk[: min(db.size, n)] = db[: n]
    return kappa, dk


@pytest.fixture(scope="module")
def paper():
    return load_rule_table()


# ---------------------------------------------------------------------------------------------
# exactness

def test_paper_table_equals_brute_force(paper):
    rng = np.random.default_rng(1)
    kappa, dk = _random_inputs(paper, rng, 300)
    got = compile_table(paper).feed_pct(kappa, dk)
    want = np.array([brute_force_centroid(paper, k, d) for k, d in zip(kappa, dk)])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(N_RANDOM_TABLES))
def test_random_tables_equal_brute_force(seed):
    table = random_table(seed, vertical_edges=seed % 3 == 0)
    rng = np.random.default_rng(100 + seed)
    kappa, dk = _random_inputs(table, rng, 120)
    got = compile_table(table).feed_pct(kappa, dk)
    want = np.array([brute_force_centroid(table, k, d) for k, d in zip(kappa, dk)])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


def test_paper_table_matches_skfuzzy(paper):
    rng = np.random.default_rng(2)
    kappa, dk = _random_inputs(paper, rng, 400)
    got = compile_table(paper).feed_pct(kappa, dk)
    ref = skfuzzy_feed_pct(paper, kappa, dk, output_points=1001)
    assert np.max(np.abs(got - ref)) <= 2e-3


def test_skfuzzy_per_point_loop_equals_its_array_input(paper):
    rng = np.random.default_rng(3)
    kappa, dk = _random_inputs(paper, rng, 25)
    loop = skfuzzy_feed_pct(paper, kappa, dk, array=False)
    array = skfuzzy_feed_pct(paper, kappa, dk, array=True)
    np.testing.assert_allclose(loop, array, rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", range(N_RANDOM_TABLES))
def test_random_tables_match_skfuzzy(seed):
    table = random_table(seed, gentle=True)
    rng = np.random.default_rng(200 + seed)
    kappa, dk = _random_inputs(table, rng, 60)
    got = compile_table(table).feed_pct(kappa, dk)
    ref = skfuzzy_feed_pct(table, kappa, dk, output_points=1001)
    assert np.max(np.abs(got - ref)) <= 2e-3


def test_random_tables_are_really_random():
    tables = [random_table(s) for s in range(N_RANDOM_TABLES)]
    assert len({(len(t.curvature.terms), len(t.curvature_variation.terms), len(t.feed.terms))
                for t in tables}) >= 10
    assert any(len(term.points) == 4 for t in tables for term in t.feed.terms)


# ---------------------------------------------------------------------------------------------
# analytic cases and behaviour

def test_single_full_rule_gives_that_terms_centroid(paper):
    e = compile_table(paper)
    # κ = 0, Dκ = 0: only R1 (ZO, ZO -> TF) fires, fully: centroid of the triangle [85, 100, 100]
    assert e.feed_pct([0.0], [0.0])[0] == pytest.approx(95.0, abs=1e-12)
    # κ at S's peak, Dκ at M's peak: only (S, M) -> HF [40, 55, 70]
    assert e.feed_pct([0.05], [0.5])[0] == pytest.approx(55.0, abs=1e-12)
    # κ = VB plateau, any Dκ peak: VLF [0, 10, 25] -> (0 + 10 + 25) / 3
    assert e.feed_pct([0.7], [0.75])[0] == pytest.approx(35.0 / 3.0, abs=1e-12)


def test_two_equal_clipped_symmetric_terms():
    """Two rules fire at 0.5 with mirror-image outputs: the centroid is the mirror axis."""
    var = lambda name, labels, pts: Variable(name, (0.0, 1.0), tuple(Term(l, p) for l, p in zip(labels, pts)))  # noqa: E731
    k = var("curvature", ["A", "B"], [(0.0, 0.0, 1.0), (0.0, 1.0, 1.0)])
    d = var("curvature_variation", ["Z"], [(0.0, 0.0, 1.0, 1.0)])
    f = Variable("feed", (0.0, 100.0), (Term("LO", (10.0, 20.0, 40.0)), Term("HI", (60.0, 80.0, 90.0))))
    t = RuleTable("sym", k, d, f, grid=(("LO",), ("HI",)))
    assert compile_table(t).feed_pct([0.5], [0.3])[0] == pytest.approx(50.0, abs=1e-12)


def test_inputs_beyond_the_universe_clip(paper):
    e = compile_table(paper)
    np.testing.assert_array_equal(e.feed_pct([43.0, 1.0, -0.5], [2.0, 1.0, -3.0]),
                                  e.feed_pct([1.0, 1.0, 0.0], [1.0, 1.0, 0.0]))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_inputs_are_errors(paper, bad):
    e = compile_table(paper)
    with pytest.raises(InputError, match=r"curvature\[1\] = (nan|inf|-inf); controller inputs must be finite"):
        e.feed_pct([0.1, bad], [0.2, 0.3])
    with pytest.raises(InputError, match=r"curvature_variation\[0\] = "):
        e.feed_pct([0.1], [bad])
    with pytest.raises(InputError, match=r"curvature\[0\]"):
        e.firing_strengths([bad], [0.2])


def test_mismatched_lengths(paper):
    with pytest.raises(InputError, match="one pair per point"):
        compile_table(paper).feed_pct([0.1, 0.2], [0.3])


def test_no_rule_fires_gives_the_floor(paper):
    e = compile_table(paper)
    empty = np.array([], dtype=np.int64)
    silent = replace(e, rule_k=empty, rule_d=empty, rule_o=empty, grid_o=np.full_like(e.grid_o, -1))
    np.testing.assert_array_equal(silent.feed_pct([0.1, 0.5], [0.2, 0.9]), [paper.feed_floor_pct] * 2)


def test_firing_strengths(paper):
    e = compile_table(paper)
    rng = np.random.default_rng(4)
    kappa, dk = rng.uniform(0, 1, 50), rng.uniform(0, 1, 50)
    w = e.firing_strengths(kappa, dk)
    assert w.shape == (50, 30)
    assert len(e.rule_names) == 30 and e.rule_names[0] == "k=ZO & Dk=ZO -> TF"
    assert e.rule_names[20] == "k=B & Dk=ZO -> MF"
    # min of the two memberships, computed independently
    for n, (lk, ld, _) in enumerate(paper.rules):
        mk = _mu(paper.curvature.term(lk).points, kappa)
        md = _mu(paper.curvature_variation.term(ld).points, dk)
        np.testing.assert_allclose(w[:, n], np.minimum(mk, md), atol=1e-15)
    # every point fires at least one rule (inputs covered, grid full)
    assert (w.max(axis=1) > 0).all()
    # only R1 at the origin
    w0 = e.firing_strengths([0.0], [0.0])[0]
    assert w0[0] == 1.0 and w0[1:].sum() == 0.0
    h = e.clip_levels(kappa, dk)
    assert h.shape == (50, 8)


def test_chunking_does_not_change_results(paper, monkeypatch):
    rng = np.random.default_rng(5)
    kappa, dk = rng.uniform(0, 1, 1000), rng.uniform(0, 1, 1000)
    whole = compile_table(paper).feed_pct(kappa, dk)
    monkeypatch.setattr(engine_mod, "CHUNK_POINTS", 97)
    np.testing.assert_array_equal(compile_table(paper).feed_pct(kappa, dk), whole)


def test_output_stays_inside_the_output_universe():
    for seed in range(10):
        t = random_table(seed)
        rng = np.random.default_rng(seed)
        out = compile_table(t).feed_pct(rng.uniform(-1, 4, 2000), rng.uniform(-1, 2, 2000))
        assert np.isfinite(out).all() and (out >= 0).all() and (out <= 100).all()


# ---------------------------------------------------------------------------------------------
# golden file of the shipped table

GOLDEN_KAPPA = [0.0, 0.01, 0.02, 0.035, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3, 0.5, 0.75, 1.0]
GOLDEN_DK = [0.0, 0.1, 0.25, 0.4, 0.5, 0.6, 0.75, 0.9, 1.0]


def test_golden_paper_surface(paper):
    """tests/golden/fuzzy_paper_surface.csv: the shipped table on a 13 x 9 grid (regenerate with
    FUZZYFEED_REGEN_GOLDEN=1 after a deliberate change to rules/paper.toml)."""
    kk, dd = np.meshgrid(GOLDEN_KAPPA, GOLDEN_DK, indexing="ij")
    got = compile_table(paper).feed_pct(kk.ravel(), dd.ravel())
    want_bf = np.array([brute_force_centroid(paper, k, d) for k, d in zip(kk.ravel(), dd.ravel())])
    np.testing.assert_allclose(got, want_bf, atol=1e-9, rtol=0)
    if os.environ.get("FUZZYFEED_REGEN_GOLDEN"):
        GOLDEN.parent.mkdir(exist_ok=True)
        with open(GOLDEN, "w", newline="") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(["curvature_1_mm", "curvature_variation", "feed_pct"])
            w.writerows(zip(kk.ravel().tolist(), dd.ravel().tolist(), got.tolist()))
    with open(GOLDEN, newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["curvature_1_mm", "curvature_variation", "feed_pct"]
    data = np.array(rows[1:], dtype=float)
    np.testing.assert_array_equal(data[:, 0], kk.ravel())
    np.testing.assert_array_equal(data[:, 1], dd.ravel())
    np.testing.assert_allclose(got, data[:, 2], atol=1e-9, rtol=0)
