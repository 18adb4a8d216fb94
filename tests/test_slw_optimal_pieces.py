"""The whole-path LP in bounded pieces (fuzzyfeed.slw.optimal_pieces) against the LP over the
whole grid (slw/optimal.py), every limit recomputed on the joined grid from the curve's own
derivatives (tests/test_slw_optimal.py: check_profile), and the ticks' limits recomputed from the
positions."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.geometry.polyline_fit import fit_polyline
from fuzzyfeed.io.shapes import load_shape
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.slw import optimal_pieces
from fuzzyfeed.slw.feed_cap import FeedCap
from fuzzyfeed.slw.optimal import grid_problem, profile_time, solve_grid
from fuzzyfeed.slw.optimal_pieces import repair, solve_pieces, stopping_distance
from test_slw_optimal import SLOW_Y, _assert_within_limits, _lp_ticks, check_profile


@pytest.mark.parametrize("name, limits, share", [("trident2", SLOW_Y, 5), ("butterfly", MachineLimits(), 3)])
def test_pieces_match_the_whole_lp(name, limits, share):
    """Several pieces (1/share of the grid kept each: 750 nodes on trident2, 2861 on butterfly)
    against one LP over the whole grid, both with the whole grid's LP count (4 LPs a piece on
    butterfly): the time within 0.5 % and every limit kept on the joined grid. (Butterfly in
    pieces of 1716 nodes is 1.15 % slower: 4 LPs do not converge in one of its pieces.)"""
    curve = load_shape(name).curve
    grid = grid_problem(curve, limits)
    s = grid[0]
    log: list = []
    x, a = solve_pieces(*grid, limits, piece_nodes=max(s.size // share, 50), log=log)
    assert len(log) >= 3 and all(lps > 0 for *_, lps in log)   # several pieces, none kept to a rest
    check_profile(curve, limits, s, x, a)
    x_w, _ = solve_grid(*grid, limits, max_iter=optimal_pieces.iterations(s.size))
    t_p, t_w = profile_time(s, x, limits.jerk_mm_s3), profile_time(s, x_w, limits.jerk_mm_s3)
    assert t_p == pytest.approx(t_w, rel=5e-3)


def _random_polyline(seed: int, n: int) -> Nurbs:
    """A CAM-like chain: n segments of 0.2-8 mm turning by up to ±100°, some runs straight."""
    rng = np.random.default_rng(seed)
    step = rng.uniform(0.2, 8.0, n)
    turn = np.where(rng.random(n) < 0.3, 0.0, rng.uniform(-1.75, 1.75, n))
    heading = np.cumsum(turn)
    pts = np.concatenate([[[0.0, 0.0]], np.cumsum(np.stack([step * np.cos(heading), step * np.sin(heading)], 1), 0)])
    knots = np.concatenate([[0.0], np.linspace(0.0, 1.0, n + 1), [1.0]])
    return Nurbs(1, knots, pts)


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 10_000), st.sampled_from([MachineLimits(), SLOW_Y]))
def test_pieced_ticks_never_exceed_a_machine_limit(seed, limits):
    """No machine limit is ever exceeded: a long random polyline (blended as schedule() follows it)
    in many small pieces, through the ticks, the tick check and the span repairs: every tick within
    every limit, or no schedule at all."""
    from fuzzyfeed.errors import InputError

    curve = fit_polyline(_random_polyline(seed, 60), None).curve
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(optimal_pieces, "PIECE_NODES", 300)
        log: list = []
        grid = grid_problem(curve, limits)
        solve_pieces(*grid, limits, log=log)
        assert len(log) >= 3
        try:
            t, s, u, xyz, j = _lp_ticks(curve, limits)
        except InputError:
            return
    _assert_within_limits(curve, limits, t, s, u, xyz, j)


def test_repair_solves_only_the_span_around_the_lowered_cap():
    """A feed cap lowered over 1 mm in the middle: the profile changes only within a stopping
    distance or so of it (bit for bit the same elsewhere), and keeps the lowered limit and every other."""
    curve, limits = load_shape("infinity").curve, MachineLimits()
    grid = grid_problem(curve, limits)
    s = grid[0]
    x, a = solve_pieces(*grid, limits)
    mid = 0.5 * s[-1]
    level = 0.5 * float(np.sqrt(x[np.searchsorted(s, mid)]))
    cap = FeedCap(np.array([0.0, mid - 0.5, mid - 0.5, mid + 0.5, mid + 0.5, s[-1]]),
                  np.array([1e3, 1e3, level, level, 1e3, 1e3]), s[-1])
    new_grid, x2, a2 = repair(grid, x, a, cap, limits)
    far = np.abs(s - mid) > 0.5 + 1.01 * stopping_distance(limits)
    assert far.any() and np.array_equal(x2[far], x[far]) and np.array_equal(a2[far], a[far])
    near = np.abs(s - mid) < 0.5
    assert np.sqrt(x2[near]).max() <= level * (1 + 1e-6)
    check_profile(curve, limits, s, x2, a2)
    assert (x2 <= new_grid[1] * (1 + 1e-6) + 1e-9).all()


def test_a_path_over_the_work_budget_is_refused_and_the_window_kept(monkeypatch):
    from fuzzyfeed.slw import schedule

    curve = load_shape("trident2").curve
    grid = grid_problem(curve, SLOW_Y)
    monkeypatch.setattr(optimal_pieces, "PATH_WORK_BUDGET", 3 * grid[0].size // 2)
    with pytest.raises(RuntimeError, match="budget"):
        solve_pieces(*grid, SLOW_Y, piece_nodes=grid[0].size // 4)
    monkeypatch.setattr(optimal_pieces, "PIECE_NODES", grid[0].size // 4)
    best = schedule(curve, SLOW_Y, planner="optimal", transition="seven-phase")
    assert best.n_blocks > 0   # the window's (the LP's has no blocks)


def test_a_path_the_budget_refuses_on_its_length_is_refused_before_its_grid(monkeypatch):
    """A 30 m path: its uniform nodes alone are over the work budget, so pieced_profile refuses it
    without building the grid (a spy on grid_problem) — and the grid, built here, is refused by
    solve_pieces too (the early refusal never refuses what the full count would take)."""
    curve = Nurbs(1, np.array([0.0, 0.0, 0.5, 1.0, 1.0]), np.array([[0.0, 0.0], [15_000.0, 0.0], [15_000.0, 15_000.0]]))
    limits = MachineLimits()
    built = []
    real = optimal_pieces.grid_problem
    monkeypatch.setattr(optimal_pieces, "grid_problem", lambda *a, **k: built.append(1) or real(*a, **k))
    with pytest.raises(RuntimeError, match="budget"):
        optimal_pieces.pieced_profile(curve, limits)
    assert not built
    grid = real(curve, limits)
    assert grid[0].size >= optimal_pieces.least_nodes(float(curve.length)) // 2
    with pytest.raises(RuntimeError, match="budget"):
        solve_pieces(*grid, limits)


def test_a_path_under_the_early_count_still_gets_its_grid(monkeypatch):
    """Half the budget's length: the early count lets it through to the grid (whatever the full
    count then says)."""
    curve = Nurbs(1, np.array([0.0, 0.0, 1.0, 1.0]), np.array([[0.0, 0.0], [2_000.0, 0.0]]))
    built = []
    real = optimal_pieces.grid_problem

    def spy(*a, **k):
        built.append(1)
        raise RuntimeError("stop here")
    monkeypatch.setattr(optimal_pieces, "grid_problem", spy)
    with pytest.raises(RuntimeError, match="stop here"):
        optimal_pieces.pieced_profile(curve, MachineLimits())
    assert built and real is not spy
