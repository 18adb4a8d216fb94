"""A jerk-limited time-optimal feed over the whole path: sequential linear programming on x = v².

On the bound's arc-length grid (:func:`fuzzyfeed.slw.bound._grid_raw`, refined where the
acceleration-limited passes change √x fast: :func:`grid_problem`) the variables are x_i = v_i² and
the tangential acceleration a_i at the nodes, a(s) linear and x(s) quadratic between them (x' = 2a):

* x_{k+1} − x_k = h_k·(a_k + a_{k+1})  (the interpolant, exactly; from/to rest the constant-jerk
  start x_1 = 1.5·h·a_1, x ≤ (4.5·J·h²)^{2/3});
* 0 ≤ x_i ≤ m_v²·x_lim,i (command, axial velocity, chord error, centripetal curve; corners' caps;
  the fastest start under the jerk alone from the nearest stop);
* |a_i·T_ij + x_i·κN_ij| ≤ m_A·A_j on every axis j (the bound's axial acceleration);
* √x_i·|a_{k+1} − a_k|/h_k ≤ m_J·J at both nodes i of interval k (the tangential jerk j = √x·da/ds:
  phase_ticks realises |j| ≤ √(max x)·|Δa|/h on the interval);
* x = a = 0 at both ends and at every full stop; |a| ≤ CORNER_ACC·min A at a true corner (the corner
  rule leaves 10 % of A_j: preprocess.corners).

The jerk rows are not convex (1/√x is convex, on the wrong side). The convex-concave procedure
replaces 1/√x_i by its tangent at the last iterate (below it for every x), so every LP's solution
keeps the jerk and the last iterate is feasible for the next LP; the objective, the time
T = Σ h̄/√x, is linearised at the last iterate (maximise Σ w_i·x_i, w_i = h̄_i/x̂_i^{3/2}) and the
step taken only as far as it shortens T (the segment between two points of one LP's polytope stays
in it), so T falls monotonically. The first tangents are at the acceleration-limited passes under
the same margins. Stops when T moves less than T_RTOL. The margins leave the servo ticks
(slw/phase_ticks.py) room.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.machine.limits import MachineLimits

#: Grid refinement: √x of the passes changes by at most this ratio across an interval, at most
#: REFINE_LEVELS halvings, never below twice phase_ticks' merge distance (:func:`_min_step`).
REFINE_RATIO = 1.2
REFINE_LEVELS = 10
#: Margins of the plan: feed (on v), axial acceleration, jerk (phase_ticks realises the grid's a and j
#: within them: measured ≤ 0.9959 of A, 0.9950 of J on the shapes and random curves at 0.995).
FEED_MARGIN = 0.996
ACC_MARGIN = 0.995
JERK_MARGIN = 0.995
#: |a| at a true corner's node, as a share of the smallest axis acceleration.
CORNER_ACC = 0.05
#: The jerk rows' tangent point: the last iterate, at least this share of x_lim.
TANGENT_FLOOR = 0.01
#: Each LP's step taken only as far as it shortens the time (golden-section search).
LINE_SEARCH = True
#: HiGHS options of every LP.
HIGHS_OPTIONS = {"presolve": "off"}
#: Stop when the time changes by less than this (relative), or after MAX_ITER LPs.
T_RTOL = 1e-4
MAX_ITER = 30
#: Budgets: a grid of more nodes is refused (RuntimeError: the caller falls back), and at most
#: WORK_BUDGET / nodes LPs are solved (at least MIN_ITER; the best iterate so far is kept). A count,
#: not a clock: the same path and limits give the same schedule on a busy machine and an idle one.
MAX_NODES = 20_000
WORK_BUDGET = 40_000
MIN_ITER = 3
#: x below this share of F² counts as rest in the weights (their 1/x^{3/2} is clipped there).
WEIGHT_FLOOR = 1e-6


def profile_time(s: np.ndarray, x: np.ndarray, jerk_mm_s3: float | None = None) -> float:
    """T = Σ 2h_k/(√x_k + √x_{k+1}) (x linear in s per interval); an interval from or to rest
    (one end 0) is the constant-jerk start s = J_r·t³/6, 3h/√x of its moving end (the law
    phase_ticks realises there). An interval with both ends at rest (a stop's neighbour within
    rounding) counts as a rest-to-rest move under the jerk alone, 2·(3h/J)^{1/3}, or inf without
    ``jerk_mm_s3``."""
    v = np.sqrt(np.maximum(np.asarray(x, dtype=float), 0.0))
    h = np.diff(np.asarray(s, dtype=float))
    m = v[:-1] + v[1:]
    one = (v[:-1] == 0.0) ^ (v[1:] == 0.0)
    rest = np.inf if jerk_mm_s3 is None else 2.0 * np.cbrt(3.0 * h / jerk_mm_s3)
    with np.errstate(divide="ignore", invalid="ignore"):
        dt = np.where(h > 0, np.where(m > 0, np.where(one, 3.0 * h / m, 2.0 * h / m), rest), 0.0)
    return float(dt.sum())


def _rows(s, tangent, kn, stops, x_hat, a_hat, c_floor, jerk: float, acc: np.ndarray, x_top: np.ndarray,
          held=None):
    """The LP's rows (variables [x_0 … x_n, a_0 … a_n]) as a CSC matrix with their bounds:

    * x_{k+1} − x_k − h_k·(a_k + a_{k+1}) = 0 (the interpolant); on an interval from rest
      x_{k+1} = 1.5·h_k·a_{k+1}, to rest x_k = −1.5·h_k·a_k (the constant-jerk start/stop, x ∝ s^{4/3},
      whose jerk the bound of :func:`rest_step_limit` on x keeps, so no jerk row there);
    * the jerk √x·|da/ds| ≤ m_J·J on every moving interval at its largest x: x is quadratic there
      (x'' = 2Δa/h) and humps between the nodes where a changes sign; it is at most its chord plus
      |x''|·h²/8, so at most x_i + |Δa|·h/4 for one of its nodes i. Per node and sign:
      ±Δa·(√c/(1.5·m_J·J·h) + h/(12c)) + x_i/(3c) ≤ 1, 1/√x replaced by its tangent at c,
      (1.5 − 0.5·x/c)/√c, which is below it for every x (1/√x is convex): every solution keeps the
      jerk. c is the last iterate's x_i + |Δa|·h/4 (``x_hat``, ``a_hat``; at least ``c_floor``),
      where the tangent is exact: the last iterate keeps the rows. (With the nodes' x alone the
      ticks broke J by 4 % on HelixEnter.gcode#1: a from +146 to −143 mm/s² over 0.25 mm at 8.3 mm/s;
      rows at the middle too, with |Δa|·h/16, would be tighter at 1.5 × the jerk rows);
    * |a_i·T_ij + x_i·κN_ij|/(m_A·A_j) ≤ 1 on every axis at the moving nodes (ranged rows, ``acc``
      the m_A·A_j), but not at ``held`` nodes (a piece's ends held at a state that keeps them);
    * x at the middle of each interval between moving nodes, (x_k + x_{k+1})/2 + h_k·(a_k − a_{k+1})/4,
      at most max(x_top_k, x_top_{k+1}): the quadratic between two nodes at the limit would otherwise hump
      over it (at 8.3 mm/s the jerk rows let a swing ±150 mm/s² between nodes: ticks 1.2 % over F).
    """
    from scipy.sparse import coo_matrix

    n1 = s.size
    h = np.diff(s)
    k = np.arange(n1 - 1)
    one = np.ones(n1 - 1)
    start, stop = stops[:-1] & ~stops[1:], ~stops[:-1] & stops[1:]
    h_a = np.where(start, 0.0, np.where(stop, 1.5 * h, h))
    h_b = np.where(stop, 0.0, np.where(start, 1.5 * h, h))
    r = [np.repeat(k, 4)]
    cc = [np.stack([k + 1, k, n1 + k, n1 + k + 1], axis=1).ravel()]
    v = [np.stack([one, -one, -h_a, -h_b], axis=1).ravel()]
    lo, hi = [np.zeros(n1 - 1)], [np.zeros(n1 - 1)]
    row = n1 - 1
    kk = k[(~(stops[:-1] | stops[1:]))]
    hk = h[kk]
    swing = np.abs(a_hat[kk + 1] - a_hat[kk]) * hk / 4.0
    floor = np.maximum(c_floor[kk], c_floor[kk + 1])
    for node in (kk, kk + 1):
        c = np.maximum(x_hat[node] + swing, floor)
        slope = np.sqrt(c) / (1.5 * JERK_MARGIN * jerk * hk) + hk / (12.0 * c)
        for sign in (1.0, -1.0):
            rr = row + np.arange(kk.size)
            r += [rr, rr, rr]
            cc += [n1 + kk + 1, n1 + kk, node]
            v += [sign * slope, -sign * slope, 1.0 / (3.0 * c)]
            lo.append(np.full(kk.size, -np.inf))
            hi.append(np.ones(kk.size))
            row += kk.size
    moving = ~(stops[:-1] | stops[1:])
    m = k[moving]
    rr = row + np.arange(m.size)
    r += [rr, rr, rr, rr]
    cc += [m, m + 1, n1 + m, n1 + m + 1]
    v += [0.5 * one[m], 0.5 * one[m], 0.25 * h[m], -0.25 * h[m]]
    lo.append(np.full(m.size, -np.inf))
    hi.append(np.maximum(x_top[:-1], x_top[1:])[m])
    row += m.size
    idx = np.arange(n1)
    free = ~stops if held is None else ~(stops | held)
    for j in range(3):
        tj, kj = tangent[:, j], kn[:, j]
        i = idx[((np.abs(tj) > 1e-12) | (np.abs(kj) > 1e-12)) & free]  # at rest x = a = 0 hold it
        rr = row + np.arange(i.size)
        r += [rr, rr]
        cc += [i, n1 + i]
        v += [kj[i] / acc[j], tj[i] / acc[j]]
        lo.append(np.full(i.size, -1.0))
        hi.append(np.ones(i.size))
        row += i.size
    v, r, cc = np.concatenate(v), np.concatenate(r), np.concatenate(cc)
    a = coo_matrix((v[v != 0.0], (r[v != 0.0], cc[v != 0.0])), shape=(row, 2 * n1)).tocsc()
    return a, np.concatenate(lo), np.concatenate(hi)


def _solve_lp(a, row_lo, row_hi, cost, col_lo, col_hi, basis=None):
    """min cost·z under the rows and bounds with HiGHS (the ``highspy`` package's solver class, which
    keeps the basis between solves: linprog starts every solve cold), from ``basis`` if given →
    (z or None, the final basis). Without presolve first (HIGHS_OPTIONS: faster from a basis); HiGHS's
    defaults if that ends without an optimum (random curve 11 on slow-y: status "Unknown" without
    presolve). ``highspy._Highs``, not ``highspy.Highs``: the latter prints a banner on construction."""
    import highspy

    a.sort_indices()
    for options, start in ((HIGHS_OPTIONS, basis), ({}, None)):
        h = highspy._Highs()
        h.setOptionValue("output_flag", False)
        for key, value in options.items():
            h.setOptionValue(key, value)
        h.passModel(int(a.shape[1]), int(a.shape[0]), int(a.nnz), 1, 1, 0.0, np.asarray(cost, dtype=float),
                    np.asarray(col_lo, dtype=float), np.asarray(col_hi, dtype=float), row_lo, row_hi,
                    a.indptr[:-1].astype(np.int32), a.indices.astype(np.int32), a.data.astype(float),
                    np.zeros(a.shape[1], dtype=np.int32))
        if start is not None:
            h.setBasis(start)
        h.run()
        if h.getModelStatus() == highspy.HighsModelStatus.kOptimal:
            return np.asarray(h.getSolution().col_value), h.getBasis()
    return None, None


def _weights(s, x_hat, floor_x):
    """w_i = h̄_i / x̂_i^{3/2}: −dT/dx_i of T = Σ h̄_i/√x_i (h̄ the half sums of the neighbouring
    steps), x̂ clipped below at ``floor_x``."""
    h = np.diff(s)
    hbar = np.zeros(s.size)
    hbar[:-1] += 0.5 * h
    hbar[1:] += 0.5 * h
    return hbar / np.maximum(x_hat, floor_x) ** 1.5


def grid_problem(curve: Nurbs, limits: MachineLimits, cap=None, max_step_mm: float | None = None):
    """The bound's grid and limits for the LP: s, x_lim (margins, corners' caps and ``cap`` applied),
    unit tangents, κN, the full stops (bool) and the corner nodes (bool). Refined where the
    acceleration-limited passes change √x by more than REFINE_RATIO across an interval (at most
    REFINE_LEVELS halvings): the jerk rows take the larger x of an interval, which near rest and
    in a sharp dip is far above the smaller."""
    from fuzzyfeed.slw.bound import _evaluate, _grid_raw, insert_sorted
    from fuzzyfeed.slw.preprocess import corners

    s, x_lim, tangent, kn, raw = _grid_raw(curve, limits, max_step_mm)
    corner = np.zeros(s.size, dtype=bool)
    s_c, _ = corners(curve, limits)
    if s_c.size:
        corner[np.clip(np.searchsorted(s, s_c), 0, s.size - 1)] = True
    min_ds = _min_step(s[-1])
    for _ in range(REFINE_LEVELS):
        lim = _limit(s, x_lim, cap)
        x = _start(s, lim, tangent, kn, limits)
        v = np.sqrt(np.maximum(x, 0.0))
        lo, hi = np.minimum(v[:-1], v[1:]), np.maximum(v[:-1], v[1:])
        split = (hi > REFINE_RATIO * lo) & (np.diff(s) > 2.0 * min_ds)
        if not split.any():
            break
        mid = 0.5 * (s[:-1][split] + s[1:][split])
        xm, tm, km = _evaluate(curve, limits, mid)
        s, (x_lim, tangent, kn, corner) = insert_sorted(s, mid, (x_lim, xm), (tangent, tm), (kn, km),
                                                        (corner, np.zeros(mid.size, dtype=bool)))
    keep = _spaced(s, corner, min_ds)
    s, x_lim, tangent, kn, corner = s[keep], x_lim[keep], tangent[keep], kn[keep], corner[keep]
    x_lim = _limit(s, x_lim, cap)
    stops = x_lim <= 0.0
    stops[0] = stops[-1] = True
    x_lim[stops] = 0.0
    return s, x_lim, tangent, kn, stops, corner


def _min_step(length: float) -> float:
    """The least grid step: twice phase_ticks' merge distance (nodes closer are merged there)."""
    from fuzzyfeed.slw.phase_ticks import MERGE_MM, MERGE_RTOL

    return 2.0 * min(MERGE_MM, MERGE_RTOL * length)


def _spaced(s: np.ndarray, keep_first: np.ndarray, min_ds: float) -> np.ndarray:
    """Nodes to keep so that no two are closer than ``min_ds`` (a knot's left point 1e-9·L before
    it, the refinement's last halvings): of a close pair the later is dropped, unless it is the end
    or in ``keep_first`` (a corner), then the earlier; the ends always kept."""
    keep = np.ones(s.size, dtype=bool)
    last = 0
    for i in range(1, s.size):
        if s[i] - s[last] >= min_ds:
            last = i
        elif i == s.size - 1 or keep_first[i]:
            if last > 0:
                keep[last] = False
            last = i
        else:
            keep[i] = False
    return keep


def _limit(s, x_lim, cap):
    """x_lim under the feed margin and ``cap``: at each node the lowest cap over its two intervals
    (a FeedCap is linear between its points, so its least on an interval is at an end or one of
    its points; a repair's dip narrower than the grid step is not stepped over)."""
    if cap is not None:
        at = np.asarray(cap(s), dtype=float)
        low = np.minimum(at[:-1], at[1:])
        points = getattr(cap, "s_mm", None)
        if points is not None and low.size:
            k = np.clip(np.searchsorted(s, points, side="right") - 1, 0, low.size - 1)
            np.minimum.at(low, k, np.asarray(cap.feed_mm_s, dtype=float))
            at = np.minimum(at, np.minimum(np.concatenate([[np.inf], low]), np.concatenate([low, [np.inf]])))
        x_lim = np.minimum(x_lim, at ** 2)
    return FEED_MARGIN ** 2 * x_lim


def _start(s, x_lim, tangent, kn, limits: MachineLimits):
    """The acceleration-limited passes under the margins: above every feasible x."""
    import fuzzyfeed.slw._kernels as _kernels

    acc = ACC_MARGIN * np.asarray(limits.axis_acc_mm_s2, dtype=float)
    return _kernels.phase_plane_passes(np.diff(s), np.ascontiguousarray(x_lim), np.ascontiguousarray(tangent),
                                       np.ascontiguousarray(kn), acc)


def rest_step_limit(s: np.ndarray, stops: np.ndarray, jerk: float) -> np.ndarray:
    """x allowed at each node: inf, but next to a rest (h the step to it) (4.5·J·h²)^{2/3}, the
    constant-jerk start x_1 = 1.5·h·a_1 with J_r = 2x^{3/2}/(9h²) ≤ J."""
    out = np.full(s.size, np.inf)
    h = np.diff(s)
    start, stop = stops[:-1] & ~stops[1:], ~stops[:-1] & stops[1:]
    out[1:][start] = np.cbrt(4.5 * jerk * h[start] ** 2) ** 2
    out[:-1][stop] = np.minimum(out[:-1][stop], np.cbrt(4.5 * jerk * h[stop] ** 2) ** 2)
    return out


def slow_limit(s: np.ndarray, slow: np.ndarray, v0: np.ndarray, a0: float, jerk: float) -> np.ndarray:
    """The fastest x at distance d from the nearest slow point on either side (a full stop or a
    corner: feed v0 there, |a| ≤ a0), under the jerk alone: s ≥ J·t³/6 gives t ≤ (6d/J)^{1/3} and
    v ≤ v0 + a0·t + J·t²/2. An upper bound on every feasible x; the jerk rows' tangents are taken
    below it (next to a corner passed at 0.45 mm/s, a tangent at 1 % of the command feed's x held
    the feed at 0.76 mm/s where the window runs 1.9)."""
    idx = np.flatnonzero(slow)
    out = np.full(s.size, np.inf)
    if idx.size == 0:
        return out
    for side in ("left", "right"):
        k = np.searchsorted(s[idx], s, side="right") - 1 if side == "left" else np.searchsorted(s[idx], s, side="left")
        ok = (k >= 0) & (k < idx.size)
        j = idx[np.clip(k, 0, idx.size - 1)]
        t = np.cbrt(6.0 * np.abs(s - s[j]) / jerk)
        v = v0[j] + (a0 * (v0[j] > 0)) * t + 0.5 * jerk * t * t
        out = np.where(ok, np.minimum(out, v * v), out)
    return out


def _line_search(s, x0, a0, x1, a1, jerk: float, steps: int = 12):
    """The point of the segment (x0, a0) → (x1, a1) with the least time (T is convex in x along
    it; golden-section search). Both ends keep the rows whose tangents are at x0, so every point
    between does."""
    g = (np.sqrt(5.0) - 1.0) / 2.0
    lo, hi = 0.0, 1.0
    f = lambda lam: profile_time(s, x0 + lam * (x1 - x0), jerk)  # noqa: E731
    m1, m2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(m1), f(m2)
    for _ in range(steps):
        if f1 <= f2:
            hi, m2, f2 = m2, m1, f1
            m1 = hi - g * (hi - lo)
            f1 = f(m1)
        else:
            lo, m1, f1 = m1, m2, f2
            m2 = lo + g * (hi - lo)
            f2 = f(m2)
    lam = min([(f(1.0), 1.0), (f1, m1), (f2, m2)])[1]
    return x0 + lam * (x1 - x0), a0 + lam * (a1 - a0)


def solve_grid(s, x_lim, tangent, kn, stops, corner, limits: MachineLimits, max_iter: int = MAX_ITER,
               log: list | None = None, start=None, end=None, seed=None, exact_seed: bool = False):
    """Sequential LP on a prepared grid → (x, a) at the nodes, every iterate within every limit
    (the convex-concave procedure: the jerk rows' tangents at the last iterate). ``log``
    (optional) receives each iteration's time.

    A piece of a longer path (slw/optimal_pieces.py): ``start`` / ``end`` (optional) the state
    (x, a) held at the first / last node instead of rest (x = 0 holds a rest); ``seed`` (optional)
    (x, a) for the first tangent points where finite: at the larger of its x and the passes', or
    with ``exact_seed`` at its own x (a solution over the same nodes: with the tangents at itself
    it keeps every jerk row, so the first LP is feasible there; the passes converge faster: the
    rows hold x ≤ 3c, and a seed that slows to a rest holds the first LPs near it)."""
    n1 = s.size
    if n1 > MAX_NODES:
        raise RuntimeError(f"{n1} grid nodes, over the LP's budget of {MAX_NODES}")
    max_iter = min(max_iter, max(MIN_ITER, WORK_BUDGET // n1))
    stops, x_lim, held = stops.copy(), x_lim.copy(), np.zeros(n1, dtype=bool)
    for node, state in ((0, start), (n1 - 1, end)):
        if state is not None:
            stops[node] = state[0] <= 0.0
            held[node] = not stops[node]
            x_lim[node] = max(float(state[0]), x_lim[node]) if held[node] else 0.0
    feed = limits.feed_mm_s
    acc = ACC_MARGIN * np.asarray(limits.axis_acc_mm_s2, dtype=float)
    a_max = float(np.max(limits.axis_acc_mm_s2))
    a_lo, a_hi = np.full(n1, -a_max), np.full(n1, a_max)
    corner_acc = CORNER_ACC * float(np.min(limits.axis_acc_mm_s2))
    a_lo[corner], a_hi[corner] = -corner_acc, corner_acc
    a_lo[stops] = a_hi[stops] = 0.0
    jerk = JERK_MARGIN * limits.jerk_mm_s3
    slow = stops | corner
    x_lim = np.minimum(x_lim, slow_limit(s, slow, np.sqrt(np.where(slow, x_lim, 0.0)), corner_acc, jerk))
    x_lim = np.minimum(x_lim, rest_step_limit(s, stops, jerk))
    col_lo = np.concatenate([np.zeros(n1), a_lo])
    col_hi = np.concatenate([x_lim, a_hi])
    x_hat = _start(s, x_lim, tangent, kn, limits)
    for node, state in ((0, start), (n1 - 1, end)):
        if state is not None and held[node]:
            col_lo[node] = col_hi[node] = x_hat[node] = state[0]
            col_lo[n1 + node] = col_hi[n1 + node] = state[1]
    a_hat = np.zeros(n1)
    if seed is not None:
        x_hat = np.where(np.isfinite(seed[0]), seed[0] if exact_seed else np.maximum(seed[0], x_hat), x_hat)
        a_hat = np.where(np.isfinite(seed[1]), seed[1], a_hat)
    floor_x = WEIGHT_FLOOR * feed ** 2
    best, best_t, t_prev, basis = None, np.inf, np.inf, None
    for it in range(max_iter):
        c_floor = np.maximum(TANGENT_FLOOR * x_lim, floor_x)
        a_mat, row_lo, row_hi = _rows(s, tangent, kn, stops, x_hat, a_hat, c_floor, limits.jerk_mm_s3, acc,
                                      x_lim, held)
        cost = np.concatenate([-_weights(s, x_hat, floor_x), np.zeros(n1)])
        z, basis = _solve_lp(a_mat, row_lo, row_hi, cost, col_lo, col_hi, basis)
        if z is None:
            if best is None:
                raise RuntimeError("the feed LP found no optimum")
            break
        x, a = np.clip(z[:n1], 0.0, None), z[n1:]
        if best is not None and LINE_SEARCH:  # the segment to the last iterate keeps every row
            x, a = _line_search(s, best[0], best[1], x, a, limits.jerk_mm_s3)
        t = profile_time(s, x, limits.jerk_mm_s3)
        if log is not None:
            log.append(t)
        if best is None or t < best_t:
            best, best_t = (x, a), t
        if abs(t_prev - t) <= T_RTOL * t:
            break
        t_prev = t
        x_hat, a_hat = x, a
    return best


def optimal_profile(curve: Nurbs, limits: MachineLimits, cap=None, max_step_mm: float | None = None,
                    log: list | None = None):
    """The jerk-limited time-optimal feed of ``curve`` → (s_grid, x_grid, a_grid): arc lengths (mm),
    x = v² (mm²/s²) and the tangential acceleration (mm/s²) at the nodes; ``cap`` (optional) a
    callable feed limit of s (mm/s, e.g. a :class:`~fuzzyfeed.slw.feed_cap.FeedCap`)."""
    s, x_lim, tangent, kn, stops, corner = grid_problem(curve, limits, cap, max_step_mm)
    x, a = solve_grid(s, x_lim, tangent, kn, stops, corner, limits, log=log)
    return s, x, a
