"""The whole-path LP (slw/optimal.py) in bounded pieces: a receding horizon over its grid, and a
repair that solves again only the span around a breach.

**Receding horizon.** The grid's nodes [i0, i0 + W] are kept from the LP over
[i0, i1], i1 the first node at least :func:`stopping_distance` past i0 + W, solved with a rest held
at i1 (an artificial stop unless i1 is the path's end) and the state (x, a) of the last kept
node held at i0. The next piece starts there. Recursive feasibility: the state held at i0 came to
rest within [i0, i1_prev] in the last piece, and i1 ≥ i1_prev, so that motion (rest after
i1_prev) is a point of the next piece's LP; its first jerk rows take their tangents at that motion
(``seed``: 1/√x's tangent at x itself is exact there), so the first LP is feasible on the overlap. If
an LP finds no optimum all the same, the last piece is kept to its rest and the next starts from
rest (slower, never over a limit). Every LP has at most W + overlap nodes: cost and memory linear
in the path's length.

**Work.** A count, not a clock (the schedule must not depend on the machine's load): each piece
solves at most ``iterations`` LPs, ``WORK_BUDGET`` node-LPs shared over the whole path's nodes (at
least ``MIN_ITER``); a path whose least work, every node (overlaps included) ``MIN_ITER`` times, is
over ``PATH_WORK_BUDGET`` node-LPs is refused (RuntimeError: the caller keeps the window).

**Repair.** A lowered feed cap changes x_lim on a few nodes; only the span from
:func:`stopping_distance` before the first to as far after the last is solved again, with the
current profile's states held at its two ends (its first tangents at the current profile); if
that LP finds no optimum the span is doubled, and past the path's ends the whole path is solved
again in pieces.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.slw.optimal import (ACC_MARGIN, JERK_MARGIN, MAX_ITER, MIN_ITER, WORK_BUDGET, _limit,
                                   grid_problem, solve_grid)

#: Nodes kept from each piece's LP (its LP has these plus the overlap's).
PIECE_NODES = 4000
#: The overlap past the kept nodes: this many stopping distances from the command feed.
OVERLAP_STOPS = 1.5
#: The least work of a path (node-LPs) the LP takes on; over it, RuntimeError (the window kept).
PATH_WORK_BUDGET = 120_000
#: A repair's span grows by doubling at most this many times, then the whole path is solved again.
REPAIR_GROWTH = 3


def stopping_distance(limits: MachineLimits) -> float:
    """An upper bound on the distance to rest from the command feed F under the plan's margins
    with the smallest axis acceleration A and the jerk J: the seven-phase stop takes
    F/A + A/J s at most, at a feed at most F: d ≤ F·(F/A + A/J)."""
    feed = limits.feed_mm_s
    acc = ACC_MARGIN * float(np.min(limits.axis_acc_mm_s2))
    jerk = JERK_MARGIN * limits.jerk_mm_s3
    return feed * (feed / acc + acc / jerk)


def iterations(n_nodes: int) -> int:
    """LPs per piece: WORK_BUDGET node-LPs over the path's nodes, within [MIN_ITER, MAX_ITER]."""
    return min(MAX_ITER, max(MIN_ITER, WORK_BUDGET // max(n_nodes, 1)))


def least_nodes(length_mm: float, max_step_mm: float | None = None) -> int:
    """The uniform nodes of the bound's grid (bound.uniform_intervals + 1); knots, corners and
    refinements only add to them, and the LP's spacing (optimal._spaced) drops at most one of a pair
    closer than a few µm, so the grid has at least half this many nodes (pieced_profile's early
    refusal counts half)."""
    from fuzzyfeed.slw.bound import uniform_intervals

    return uniform_intervals(length_mm, max_step_mm) + 1


def _piece_end(s: np.ndarray, keep: int, overlap_mm: float) -> int:
    """The last node of the piece whose kept part ends at node ``keep``."""
    return int(min(np.searchsorted(s, s[keep] + overlap_mm, side="left"), s.size - 1))


def solve_pieces(s, x_lim, tangent, kn, stops, corner, limits: MachineLimits,
                 piece_nodes: int | None = None, log: list | None = None, progress=None):
    """(x, a) at the grid's nodes by the receding horizon (module doc), ``piece_nodes`` kept a piece
    (default PIECE_NODES); ``log`` (optional) receives (first node, last node, LPs solved) per piece
    (0 LPs: an LP found no optimum and the last piece was kept to its rest); ``progress``
    (optional) is called with the arc length planned so far after each piece."""
    n = s.size
    piece_nodes = PIECE_NODES if piece_nodes is None else piece_nodes
    overlap = OVERLAP_STOPS * stopping_distance(limits)
    ends, i0 = [], 0
    while True:  # the pieces' (first, kept, last) nodes: they depend on the grid alone
        k = min(i0 + piece_nodes, n - 1)
        i1 = n - 1 if k == n - 1 else max(_piece_end(s, k, overlap), k + 1)
        ends.append((i0, k, i1))
        if k == n - 1:
            break
        i0 = k
    work = MIN_ITER * sum(i1 - i0 + 1 for i0, _, i1 in ends)
    if len(ends) > 1 and work > PATH_WORK_BUDGET:
        raise RuntimeError(f"{n} grid nodes in {len(ends)} pieces: {work} node-LPs at the least, over the "
                           f"LP's budget of {PATH_WORK_BUDGET}")
    iters = iterations(n)
    x, a = np.zeros(n), np.zeros(n)
    i0, state, last = 0, None, None  # the state held at node i0; the last piece (i0, i1, x, a)
    while True:
        k = min(i0 + piece_nodes, n - 1)
        i1 = n - 1 if k == n - 1 else max(_piece_end(s, k, overlap), k + 1, 0 if last is None else last[1])
        piece = slice(i0, i1 + 1)
        st, xl = stops[piece].copy(), x_lim[piece].copy()
        st[-1], xl[-1] = True, 0.0
        seed = None
        if last is not None:  # the last piece's motion over the overlap
            seed = np.full((2, i1 - i0 + 1), np.nan)
            over = last[1] - i0 + 1
            seed[0, :over], seed[1, :over] = last[2][i0 - last[0]:], last[3][i0 - last[0]:]
        lp_log: list = []
        try:
            xs, as_ = _solve_seeded(s[piece], xl, tangent[piece], kn[piece], st, corner[piece], limits,
                                    max_iter=iters, log=lp_log, start=state, seed=seed)
        except RuntimeError:
            if last is None:
                raise
            j0, j1, xp, ap = last  # the last piece kept to its rest; the next starts from rest there
            x[i0:j1 + 1], a[i0:j1 + 1] = xp[i0 - j0:], ap[i0 - j0:]
            if log is not None:
                log.append((i0, j1, 0))
            i0, state, last = j1, (0.0, 0.0), None
            continue
        if log is not None:
            log.append((i0, i1, len(lp_log)))
        x[i0:k + 1], a[i0:k + 1] = xs[:k - i0 + 1], as_[:k - i0 + 1]
        if progress is not None:
            progress(float(s[k]))
        if k == n - 1:
            return x, a
        state, last, i0 = (float(xs[k - i0]), float(as_[k - i0])), (i0, i1, xs, as_), k


def _solve_seeded(*args, seed=None, **kwargs):
    """:func:`solve_grid` with the first tangents above the seed (faster), and if that LP finds no
    optimum at the seed itself (where the seed keeps every row)."""
    try:
        return solve_grid(*args, seed=seed, **kwargs)
    except RuntimeError:
        if seed is None:
            raise
        return solve_grid(*args, seed=seed, exact_seed=True, **kwargs)


def refused_on_length(length_mm: float, max_step_mm: float | None = None, piece_nodes: int | None = None) -> str:
    """Why the work budget refuses a path of ``length_mm`` on its length alone (half of
    :func:`least_nodes`, as :func:`solve_pieces` would count them), or "" when it may not."""
    least = least_nodes(length_mm, max_step_mm)
    keep = PIECE_NODES if piece_nodes is None else piece_nodes
    if least // 2 > keep + 1 and MIN_ITER * (least // 2) > PATH_WORK_BUDGET:
        return (f"a path of {length_mm:.6g} mm: at least {least} grid nodes, {MIN_ITER * least} node-LPs "
                f"at the least, over the LP's budget of {PATH_WORK_BUDGET}")
    return ""


def pieced_profile(curve, limits: MachineLimits, cap=None, max_step_mm: float | None = None,
                   piece_nodes: int | None = None, log: list | None = None, progress=None):
    """:func:`fuzzyfeed.slw.optimal.optimal_profile` by pieces → (s_grid, x_grid, a_grid), plus the
    grid problem (for :func:`repair`). A path the work budget refuses on its length alone
    (:func:`least_nodes`) is refused before its grid is built (~1 s on a 24 m cut). ``progress``:
    :func:`solve_pieces`'."""
    why = refused_on_length(float(curve.length), max_step_mm, piece_nodes)
    if why:
        raise RuntimeError(why)
    grid = grid_problem(curve, limits, cap, max_step_mm)
    x, a = solve_pieces(*grid, limits, piece_nodes=piece_nodes, log=log, progress=progress)
    return grid, x, a


def repair(grid, x: np.ndarray, a: np.ndarray, cap, limits: MachineLimits, piece_nodes: int | None = None):
    """The profile (x, a) under the lowered feed cap ``cap``: the grid's x_lim lowered by it, and
    only the span around the nodes it lowers solved again (module doc) → (grid, x, a)."""
    piece_nodes = PIECE_NODES if piece_nodes is None else piece_nodes
    s, x_lim, tangent, kn, stops, corner = grid
    lowered = np.minimum(x_lim, _limit(s, np.full(s.size, np.inf), cap))
    lowered[stops] = 0.0
    changed = np.flatnonzero(lowered < x_lim)
    grid = (s, lowered, tangent, kn, stops, corner)
    if changed.size == 0:
        return grid, x, a
    reach = stopping_distance(limits)
    for _ in range(REPAIR_GROWTH + 1):
        lo = int(np.searchsorted(s, s[changed[0]] - reach, side="right")) - 1
        hi = int(np.searchsorted(s, s[changed[-1]] + reach, side="left"))
        lo, hi = max(lo, 0), min(hi, s.size - 1)
        if lo == 0 and hi == s.size - 1 or hi - lo + 1 > piece_nodes + piece_nodes // 2:
            break
        span = slice(lo, hi + 1)
        try:
            xs, as_ = _solve_seeded(s[span], lowered[span], tangent[span], kn[span], stops[span], corner[span],
                                    limits, max_iter=iterations(s.size),
                                    start=None if lo == 0 else (x[lo], a[lo]),
                                    end=None if hi == s.size - 1 else (x[hi], a[hi]), seed=(x[span], a[span]))
        except RuntimeError:
            reach *= 2.0
            continue
        x, a = x.copy(), a.copy()
        x[span], a[span] = xs, as_
        return grid, x, a
    x, a = solve_pieces(*grid, limits, piece_nodes=piece_nodes)
    return grid, x, a
