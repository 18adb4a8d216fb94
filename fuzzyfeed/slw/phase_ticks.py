"""Servo ticks from a feed profile x(s) = v(s)² on an arc-length grid (issue 38, the tick half).

A planner over the whole path (a phase-plane or LP parameterisation) gives x_k = v_k² ≥ 0 on a grid
0 = s_0 < … < s_n = L, x = 0 at both ends and at every full stop, and best also its nodal tangential
accelerations a_k. :func:`ticks_from_phase` turns it into the tick rows (t, s, v, a, j) at t_k = k·Ts
that :func:`fuzzyfeed.slw.trajectory.schedule` interpolates and checks, with the conventions of its
window sampling: the first tick at s = 0 at rest, the last at ⌈T/Ts⌉·Ts exactly on L at rest
(terminal-error compensation, seed 000), s non-decreasing, v = a = j = 0 after the end.

**The motion between two nodes** joins (s_k, v_k, a_k) to (s_k+1, v_k+1, a_k+1) (s, v and a continuous:
a C² motion), by the law of the smaller largest |jerk| of two (with J given: of the smaller
excursion of a beyond [a_k, a_k+1] within J, then of the smaller jerk):

* two constant-jerk pieces in time (:func:`_two_jerks`): the second a share γ of the interval's
  time T, T the root of a quadratic (the moments of j), γ chosen (:func:`_cost`) with the jerk
  limit J (``jerk_mm_s3``) as the split within J whose acceleration leaves [a_k, a_k+1] least,
  then the least jerk; without it as the least max(|j1|, |j2|) with such an excursion weighed in.
  Exact for any motion of constant jerk over the interval (the jerk-limited start s = J·t³/6 from
  a rest is one) and, given J, for one that switches jerk once inside it (a seven-phase profile's
  grid values with their own a and J give back that profile to rounding);
* with J given, where the two jerks leave [a_k, a_k+1], three pieces ±J, 0, ∓J through a plateau
  a_p (:func:`_ramp`): a whole seven-phase ramp inside one interval;
* a linear in s (da/ds = c on each half, knot at the midpoint with a_m = 2ā − (a_k + a_k+1)/2,
  ā = (x_k+1 − x_k)/(2h), so x interpolates x_k+1 exactly): j = c·v, i.e. s‴ = c·s′, in closed form
  (cosh/cos, :func:`_linear_state`), durations by a safeguarded Newton. With a planner's trapezoid
  relation h(a_k + a_k+1) = x_k+1 − x_k, a is linear over the interval and |j| ≤ √(max x)·|Δa|/h.

**Nodal accelerations** (:func:`nodal_accelerations`): ``a_grid`` where given; without it the
three-point x'_k/2 (a weak estimate: on a sampled seven-phase move the jerk reaches 1.06-2.8 × J and
the acceleration 1.3 × A; pass a_grid and J). At a rest node a = 0; beside one, a is the given value
if a motion from rest reaches it within J (or within the constant-jerk start's own jerk: a
planner's trapezoid value x/h needs 2.94 × that), else ±2x/(3h) (the constant-jerk start s = J_r·t³/6 with
J_r = 2x^{3/2}/(9h²), duration 3h/√x; a planner matches it with x_1 = (3/2)·h_0·a_1 and
x_1 ≤ (4.5·J·h_0²)^{2/3}).

**What it guarantees** (to rounding; tests/test_phase_ticks.py): the ticks pass every node's
(s, v, a); without J the realised |jerk| on every interval is at most the smaller of the two laws'
bounds (the constant-jerk split's own max|j|, or √(max x on a half)·|da/ds| of the linear-in-s
interpolant: for a planner's linear-a profile its own jerk constraint, checked on random profiles);
with J, the law of the smaller score (relative excursion of a + 1000 × relative excess of the
jerk over J), on a tie the smaller jerk: so the linear law's bound again where both keep a within
its nodal values and J. |a| between nodes is within the pieces' extremes (linear in t on a
constant-jerk piece). Measured (benchmarks/phase_ticks_roundtrip.py): the window's own schedules
resampled at 0.25 mm plus its junctions, with a and J, come back in the window's time with its
feed, acceleration and jerk ratios (≤ 1.0000); topp10's LP profiles at their own margins. Each
tick is the motion at k·Ts and the tick check's finite differences are weighted means of it
(Δ³s/Ts³ is a B-spline mean of j, s being C²), so the ticks' feed, acceleration and jerk stay
within the motion's own maxima.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.errors import InputError

#: A node with x ≤ REST_RTOL·max(x) is a full stop (an LP's rounding of 0).
REST_RTOL = 1e-12
#: Most servo periods a schedule may have, the window's or the LP's (≈ 14 h at 1 ms).
MAX_TICKS = 5e7
#: Grid steps shorter than min(MERGE_MM, MERGE_RTOL·L) are merged with their neighbour (merge_close).
MERGE_MM, MERGE_RTOL = 1e-4, 1e-5
#: Ticks evaluated together (a bounded working set).
TICK_CHUNK = 1 << 16
#: Below this |c·τ²| the state functions are summed as series (no cancellation in cosh − 1).
_SERIES_Z = 0.1
_NEWTON_STEPS = 60

# piece kinds: a linear in s (da/ds = c), or constant jerk in time
_LINEAR, _CUBIC = 0, 1


def _state_functions(z: np.ndarray, tau: np.ndarray):
    """C = cosh√z, S1 = τ·sinh√z/√z, S2 = τ²·(cosh√z − 1)/z for z = c·τ² (cos/sin for z < 0): the
    solution s = v0·S1 + a0·S2, v = v0·C + a0·S1 of s‴ = c·s′ (entire in z; series near 0)."""
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < _SERIES_Z
    c0, c1, c2 = np.ones_like(z), np.ones_like(z), np.full_like(z, 0.5)
    term0, term1, term2 = np.ones_like(z), np.ones_like(z), np.full_like(z, 0.5)
    zs = np.where(small, z, 0.0)
    for n in range(1, 9):  # Σ zⁿ/(2n)!, Σ zⁿ/(2n+1)!, Σ zⁿ/(2n+2)!
        term0 = term0 * zs / ((2 * n - 1) * (2 * n))
        term1 = term1 * zs / ((2 * n) * (2 * n + 1))
        term2 = term2 * zs / ((2 * n + 1) * (2 * n + 2))
        c0, c1, c2 = c0 + term0, c1 + term1, c2 + term2
    big = ~small
    if big.any():
        zb = np.minimum(z[big], 1e4)  # cosh(100): far beyond any real piece
        w = np.sqrt(np.abs(zb))
        pos = zb > 0
        ch = np.where(pos, np.cosh(w), np.cos(w))
        sh = np.where(pos, np.sinh(w), np.sin(w)) / w
        c0[big], c1[big], c2[big] = ch, sh, (ch - 1.0) / zb
    return c0, tau * c1, tau * tau * c2


def _linear_state(v0, a0, c, tau):
    """s − s0, v, a, j at τ into a piece where a is linear in s (da/ds = c): s''' = c·s'."""
    C, S1, S2 = _state_functions(c * tau * tau, tau)
    v = v0 * C + a0 * S1
    return v0 * S1 + a0 * S2, v, a0 * C + c * v0 * S1, c * v


def _cubic_state(v0, a0, jerk, tau):
    """s − s0, v, a, j at τ into a constant-jerk piece."""
    return (v0 * tau + a0 * tau * tau / 2.0 + jerk * tau ** 3 / 6.0, v0 + a0 * tau + jerk * tau * tau / 2.0,
            a0 + jerk * tau, np.full_like(tau, jerk) if np.ndim(tau) else jerk)


def _linear_durations(x0, a0, c, length):
    """Time to travel ``length`` on x = x0 + 2a0σ + cσ² (> 0 on the piece): the root of
    s(τ) = length of :func:`_linear_state`, by Newton safeguarded by bisection on the bracket
    [length/√max x, length/√min x] (τ is below the root iff s < length and v > 0: the closed form
    runs on past the piece, where it may turn back)."""
    x1 = x0 + 2.0 * a0 * length + c * length * length
    lo_x = np.minimum(x0, x1)
    hi_x = np.maximum(x0, x1)
    inside = (c != 0.0) & (-a0 / np.where(c != 0.0, c, 1.0) > 0.0) & (-a0 / np.where(c != 0.0, c, 1.0) < length)
    ext = x0 - a0 * a0 / np.where(c != 0.0, c, 1.0)
    lo_x = np.where(inside, np.minimum(lo_x, ext), lo_x)
    hi_x = np.where(inside, np.maximum(hi_x, ext), hi_x)
    v0 = np.sqrt(x0)
    lo, hi = length / np.sqrt(hi_x), length / np.sqrt(lo_x)
    tau = np.clip(2.0 * length / (v0 + np.sqrt(x1)), lo, hi)
    for _ in range(_NEWTON_STEPS):
        s, v, _, _ = _linear_state(v0, a0, c, tau)
        f = s - length
        below = (f < 0.0) & (v > 0.0)   # past the root s rises above length, then v < 0 (reversal)
        lo, hi = np.where(below, tau, lo), np.where(below, hi, tau)
        step = tau - f / np.where(v > 0.0, v, np.inf)
        nxt = np.where((step > lo) & (step < hi), step, 0.5 * (lo + hi))
        done = np.abs(nxt - tau) <= 4e-16 * tau
        tau = nxt
        if done.all():
            break
    return tau


def _check_grid(s_grid, x_grid, ts_s, a_grid):
    s = np.asarray(s_grid, dtype=float)
    x = np.asarray(x_grid, dtype=float)
    if s.ndim != 1 or x.shape != s.shape or s.size < 2:
        raise InputError(f"ticks_from_phase: s_grid {s.shape} and x_grid {x.shape} must be two 1-D arrays "
                         "of the same length ≥ 2")
    if not (np.isfinite(s).all() and np.isfinite(x).all()):
        raise InputError("ticks_from_phase: s_grid and x_grid must be finite")
    if not np.all(np.diff(s) > 0.0):
        raise InputError("ticks_from_phase: s_grid must be strictly increasing")
    if not (np.isfinite(ts_s) and ts_s > 0.0):
        raise InputError(f"ticks_from_phase: servo period {ts_s!r} s; must be > 0")
    top = float(x.max())
    if top <= 0.0 or x.min() < -1e-9 * top:
        raise InputError("ticks_from_phase: x_grid = v² must be ≥ 0 and positive somewhere")
    x = np.where(x <= REST_RTOL * top, 0.0, x)
    if x[0] != 0.0 or x[-1] != 0.0:
        raise InputError("ticks_from_phase: the profile must start and end at rest (x = 0 at both ends)")
    a = None
    if a_grid is not None:
        a = np.array(a_grid, dtype=float)
        if a.shape != s.shape or not np.isfinite(a).all():
            raise InputError(f"ticks_from_phase: a_grid {a.shape} must be finite, one value per grid point")
    return s, x, a


def merge_close(s: np.ndarray, x: np.ndarray, a: np.ndarray | None):
    """The grid without the nodes closer than min(MERGE_MM, MERGE_RTOL·L) to the one before (a
    rest node kept, its moving neighbour dropped instead; of two rests one): over a step of 1e-9·L
    the two-jerk fit divides rounding by T² (a jerk of 250 × J measured on a knot's left point)."""
    h_min = min(MERGE_MM, MERGE_RTOL * float(s[-1] - s[0]))
    while s.size > 2:
        close = np.flatnonzero(np.diff(s) < h_min)      # interval k too short: drop node k or k + 1
        if close.size == 0:
            break
        rest, last = x == 0.0, s.size - 1
        both = rest[close] & rest[close + 1]      # two rests a hair apart: one rest
        drop = np.where((rest[close + 1] & ~both) | (close + 1 == last), close, close + 1)
        drop = np.unique(drop[(drop > 0) & (drop < last) & (~rest[drop] | both)])
        drop = drop[np.concatenate([[True], np.diff(drop) > 1])] if drop.size else drop  # not two neighbours
        if drop.size == 0:
            break
        keep = np.ones(s.size, dtype=bool)
        keep[drop] = False
        s, x, a = s[keep], x[keep], (None if a is None else a[keep])
    return s, x, a


def _joins_rest(h, v, a, a_law, jerk: float | None):
    """Whether a motion from rest over h (two constant jerks) reaches (v, a) with a jerk at most
    that of the constant-jerk start to (v, ``a_law``) or within ``jerk`` (a stop mirrored: a
    negated). A planner's trapezoid value a = x/h is reached only at 2.94 × the jerk."""
    zero = np.zeros_like(h)
    given = _time_halves(h, zero, v, zero, a, jerk)[4]
    law = 2.0 * v ** 3 / (9.0 * h * h)
    within = np.inf if jerk is None else jerk * (1.0 + 1e-6)
    return np.isfinite(given) & ((given <= law * (1.0 + 1e-9)) | (given <= within))


def nodal_accelerations(s: np.ndarray, x: np.ndarray, a_grid: np.ndarray | None = None,
                        jerk: float | None = None) -> np.ndarray:
    """a_k at the nodes: 0 at rest; ``a_grid`` where given and joinable to a neighbouring rest
    (:func:`_joins_rest`), else beside a rest ±2x/(3h) (the constant-jerk start/stop's end value)
    and 0 at a single moving node between two rests; elsewhere without ``a_grid`` the three-point
    x'_k/2. Raises InputError for x = 0 on a whole interval (never passed)."""
    h = np.diff(s)
    rest = x == 0.0
    if (rest[:-1] & rest[1:]).any():
        k = int(np.flatnonzero(rest[:-1] & rest[1:])[0])
        raise InputError(f"ticks_from_phase: x = 0 on the whole interval [{s[k]:.6g}, {s[k + 1]:.6g}] mm; "
                         "a stretch at rest is never passed")
    if a_grid is None:
        slope = np.diff(x) / (2.0 * h)
        a = np.zeros_like(x)
        a[1:-1] = (h[1:] * slope[:-1] + h[:-1] * slope[1:]) / (h[:-1] + h[1:])
    else:
        a = a_grid.copy()
    a[rest] = 0.0
    after = np.flatnonzero(rest[:-1]) + 1     # nodes just after a rest (a start)
    before = np.flatnonzero(rest[1:])         # nodes just before a rest (a stop)
    v = np.sqrt(x)
    start = 2.0 * x[after] / (3.0 * h[after - 1])
    stop = -2.0 * x[before] / (3.0 * h[before])
    if a_grid is not None:   # the planner's own a where a rest joins it within J (or the rest law's jerk)
        keep_after = _joins_rest(h[after - 1], v[after], a[after], start, jerk)
        keep_before = _joins_rest(h[before], v[before], -a[before], -stop, jerk)
        after, start = after[~keep_after], start[~keep_after]
        before, stop = before[~keep_before], stop[~keep_before]
    a[after], a[before] = start, stop
    a[np.intersect1d(after, before)] = 0.0    # a peak between two stops
    return a


def _two_jerks(h, v0, v1, a0, a1, gamma):
    """Two constant-jerk pieces from (v0, a0) to (v1, a1) over h, the second γ of the time T: the
    moments ∫j = Δa, ∫(T − t)j = Δv − a0T, ∫(T − t)²j/2 = h − v0T − a0T²/2 give
    ((2γ − 1)a0 + γΔa)·T² − (6v0 + 2(1 + γ)Δv)·T + 6h = 0 (its smallest positive root), then with
    P = 2(Δv − a0T)/T², Q = Δa/T: j1 = (P − γQ)/(1 − γ), j2 = ((1 + γ)Q − P)/γ.
    → T, j1, j2, the largest |j| (inf where no such motion keeps v ≥ 0) and the excursion of a
    beyond [min(a0, a1), max(a0, a1)] at the junction, relative to max(|a0|, |a1|)."""
    da, dv = a1 - a0, v1 - v0
    qa = (2.0 * gamma - 1.0) * a0 + gamma * da
    qb = 6.0 * v0 + 2.0 * (1.0 + gamma) * dv
    disc = qb * qb - 24.0 * qa * h
    den = qb + np.sqrt(np.maximum(disc, 0.0))
    ok = (disc >= 0.0) & (den > 0.0)
    T = np.where(ok, 12.0 * h / np.where(ok, den, 1.0), 1.0)
    P, Q = 2.0 * (dv - a0 * T) / (T * T), da / T
    beta = 1.0 - gamma
    j1, j2 = (P - gamma * Q) / beta, ((1.0 + gamma) * Q - P) / gamma
    t1, t2 = beta * T, gamma * T
    vm, am = v0 + a0 * t1 + j1 * t1 * t1 / 2.0, a0 + j1 * t1
    slack = -1e-9 * np.maximum(v0, v1)   # a stop's own v = 0 at its end, rounded
    for vb, ab, jb, tb in ((v0, a0, j1, t1), (vm, am, j2, t2)):  # v = vb + ab·t + jb·t²/2 ≥ 0
        safe = np.where(jb != 0.0, jb, 1.0)
        t_min = -ab / safe
        dips = (jb > 0.0) & (t_min > 0.0) & (t_min < tb)
        ok &= ~dips | (vb - ab * ab / (2.0 * safe) >= slack)
    ok &= np.isfinite(j1) & np.isfinite(j2) & (T > 0.0)
    with np.errstate(invalid="ignore"):
        out = np.maximum(np.maximum(am - np.maximum(a0, a1), np.minimum(a0, a1) - am), 0.0)
    # relative to the larger nodal |a| or the mean acceleration |Δv|·(v0 + v1)/(2h), whichever is larger
    excursion = out / (np.maximum(np.maximum(np.abs(a0), np.abs(a1)), np.abs(dv) * (v0 + v1) / (2.0 * h)) + 1e-300)
    return T, j1, j2, np.where(ok, np.maximum(np.abs(j1), np.abs(j2)), np.inf), excursion


#: The share of the time in the second piece: a grid of GAMMAS, then golden sections around the best.
GAMMAS = np.arange(1, 64) / 64.0
_GOLDEN_STEPS = 40
#: Without a jerk limit, an excursion of a beyond its nodal values by 1 % weighs as 10 % more jerk.
EXCURSION_WEIGHT = 10.0
#: Intervals fitted together (a bounded working set: GAMMAS.size floats an interval, a few dozen times).
_FIT_CHUNK = 4096


def _cost(fit, jerk: float | None):
    """What the split γ minimises: with the jerk limit J, the excursion of a among the splits
    within J, then the jerk; else the least jerk with excursions weighed in. (The least time
    instead of the least jerk used up a planner's margin: 1.0000 × J on its 0.98 J plans.)"""
    _, _, _, top, excursion = fit
    with np.errstate(invalid="ignore", over="ignore"):
        if jerk is None:
            cost = top * (1.0 + EXCURSION_WEIGHT * excursion)
        else:
            cost = excursion + 1e3 * np.maximum(top / jerk - 1.0, 0.0) + 1e-9 * top / jerk
    return np.where(np.isfinite(top) & np.isfinite(cost), cost, np.inf)


def _time_halves(h, v0, v1, a0, a1, jerk: float | None = None):
    """Per interval the two constant-jerk pieces (:func:`_two_jerks`) of the least :func:`_cost`
    over the time split γ (a grid, then golden sections): a motion of constant jerk over the
    interval is found exactly (γ = 1/2, j1 = j2), one that switches jerk once inside it to rounding.
    → T, γ, j1, j2, the largest |j| (inf: none), a chunk of intervals at a time."""
    n = np.size(h)
    out = [np.empty(n) for _ in range(5)]
    for lo in range(0, n, _FIT_CHUNK):
        m = slice(lo, lo + _FIT_CHUNK)
        flat = [np.asarray(arr, dtype=float)[m] for arr in (h, v0, v1, a0, a1)]
        cost = _cost(_two_jerks(*(arr[:, None] for arr in flat), GAMMAS[None, :]), jerk)
        best = np.argmin(cost, axis=1)
        gamma, top = GAMMAS[best], cost[np.arange(best.size), best]
        left, right = np.maximum(gamma - 1.0 / 64.0, 1e-4), np.minimum(gamma + 1.0 / 64.0, 1.0 - 1e-4)
        ratio = (np.sqrt(5.0) - 1.0) / 2.0
        g1, g2 = right - ratio * (right - left), left + ratio * (right - left)
        f1, f2 = _cost(_two_jerks(*flat, g1), jerk), _cost(_two_jerks(*flat, g2), jerk)
        for _ in range(_GOLDEN_STEPS):
            go_left = f1 <= f2
            right, left = np.where(go_left, g2, right), np.where(go_left, left, g1)
            g2n = np.where(go_left, g1, left + ratio * (right - left))
            g1n = np.where(go_left, right - ratio * (right - left), g2)
            f2n = np.where(go_left, f1, _cost(_two_jerks(*flat, g2n), jerk))
            f1n = np.where(go_left, _cost(_two_jerks(*flat, g1n), jerk), f2)
            g1, g2, f1, f2 = g1n, g2n, f1n, f2n
        g_ref, f_ref = np.where(f1 <= f2, g1, g2), np.minimum(f1, f2)
        gamma = np.where(f_ref < top * (1.0 - 1e-12), g_ref, gamma)   # costs are ≥ 0
        T, j1, j2, worst, _ = _two_jerks(*flat, gamma)
        for arr, val in zip(out, (T, gamma, j1, j2, worst)):
            arr[m] = val
    return tuple(out)


def _ramp(h, v0, v1, a0, a1, jerk: float, side):
    """Three pieces, jerk ±J, 0, ∓J, through a plateau a_p beyond the nodal a's (``side`` +1: above
    max(a0, a1, 0), −1: below min(a0, a1, 0)): the seven-phase ramp inside one interval, which two
    jerks follow only with an excursion of a. With t1 = |a_p − a0|/J, t3 = |a1 − a_p|/J and the
    plateau t2 = (Δv − (a0 + a_p)t1/2 − (a_p + a1)t3/2)/a_p ≥ 0, the distance falls as |a_p| grows:
    a_p by bisection on it, from the nodal edge to the plateau-free a_p² = (2J|Δv| + a0² + a1²)/2.
    → t1, t2, t3, a_p (NaN where h is out of reach)."""
    edge = np.where(side > 0, np.maximum(np.maximum(a0, a1), 0.0), np.minimum(np.minimum(a0, a1), 0.0))
    dv = v1 - v0
    far = side * np.sqrt(np.maximum((2.0 * jerk * np.abs(dv) + a0 * a0 + a1 * a1) / 2.0, 0.0))

    def shape(ap):
        t1, t3 = np.abs(ap - a0) / jerk, np.abs(a1 - ap) / jerk
        j1, j3 = np.sign(ap - a0) * jerk, np.sign(a1 - ap) * jerk
        with np.errstate(invalid="ignore", divide="ignore"):
            t2 = (dv - (a0 + ap) * t1 / 2.0 - (ap + a1) * t3 / 2.0) / ap
        va = v0 + (a0 + ap) * t1 / 2.0
        vb = va + ap * t2
        d = (v0 * t1 + a0 * t1 * t1 / 2.0 + j1 * t1 ** 3 / 6.0 + va * t2 + ap * t2 * t2 / 2.0
             + vb * t3 + ap * t3 * t3 / 2.0 + j3 * t3 ** 3 / 6.0)
        return t1, t2, t3, d

    lo, hi = edge + side * 1e-12 * (np.abs(edge) + np.abs(far)), far
    d_lo, d_hi = shape(lo)[3], shape(hi)[3]
    reach = (side * dv > 0.0) & np.isfinite(d_lo) & np.isfinite(d_hi) & (d_hi <= h) & (h <= d_lo)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        long = shape(mid)[3] > h          # still too far: a deeper plateau
        lo, hi = np.where(long, mid, lo), np.where(long, hi, mid)
    ap = 0.5 * (lo + hi)
    t1, t2, t3, _ = shape(ap)
    ok = reach & (t2 >= 0.0) & (np.minimum(v0, v1) >= 0.0)
    return tuple(np.where(ok, arr, np.nan) for arr in (t1, t2, t3, ap))


def _linear_halves(h, x, a):
    """Per interval the two halves of the linear-in-s law: the midpoint knot's x and a, and per half
    (x0, a0, slope c, length) with the half's jerk bound √(max x on it)·|c| (inf where x reaches 0
    inside: the law cannot pass there)."""
    a_mid = np.diff(x) / h - 0.5 * (a[:-1] + a[1:])
    x_mid = x[:-1] + 0.5 * h * (a[:-1] + a_mid)
    x0 = np.stack([x[:-1], x_mid], axis=1)
    a0 = np.stack([a[:-1], a_mid], axis=1)
    c = np.stack([(a_mid - a[:-1]) / (0.5 * h), (a[1:] - a_mid) / (0.5 * h)], axis=1)
    length = np.stack([0.5 * h, 0.5 * h], axis=1)
    x1 = x0 + 2.0 * a0 * length + c * length * length
    sig = -a0 / np.where(c != 0.0, c, 1.0)
    inside = (c != 0.0) & (sig > 0.0) & (sig < length)
    ext = np.where(inside, x0 + a0 * sig, x0)         # x at a = 0 inside: a valley (c > 0) or a hump
    top = np.maximum(np.maximum(x0, x1), ext)
    low = np.minimum(np.minimum(x0, x1), ext)
    bound = np.where(low > 0.0, np.sqrt(np.maximum(top, 0.0)) * np.abs(c), np.inf).max(axis=1)
    return x0, a0, c, length, bound


def _pieces(s: np.ndarray, x: np.ndarray, a: np.ndarray, jerk: float | None = None):
    """The motion's pieces in path order (two per interval): kind, start s, v, a, c (da/ds of a
    linear piece) or jerk (a cubic piece), duration. Per interval the law of the smaller jerk: two
    constant jerks (:func:`_time_halves`) or a linear in s (:func:`_linear_halves`)."""
    h = np.diff(s)
    v = np.sqrt(x)
    T, gamma, j1, j2, top = _time_halves(h, v[:-1], v[1:], a[:-1], a[1:], jerk)
    x0, a_lin, c_lin, length, bound = _linear_halves(h, x, a)
    timed = np.isfinite(top) & ~(top > bound)
    if jerk is not None:   # with J: the law whose a leaves the nodal values least, within J; then the jerk
        excursion = _two_jerks(h, v[:-1], v[1:], a[:-1], a[1:], gamma)[4]
        scale = np.maximum(np.maximum(np.abs(a[:-1]), np.abs(a[1:])), np.abs(np.diff(v)) * (v[:-1] + v[1:]) / (2.0 * h))
        hi, lo = np.maximum(a[:-1], a[1:]), np.minimum(a[:-1], a[1:])
        out = np.maximum(np.maximum(a_lin[:, 1] - hi, lo - a_lin[:, 1]), 0.0)   # the midpoint knot's
        with np.errstate(invalid="ignore"):
            score_two = excursion + 1e3 * np.maximum(top / jerk - 1.0, 0.0)
            score_lin = out / (scale + 1e-300) + 1e3 * np.maximum(bound / jerk - 1.0, 0.0)
        timed = np.isfinite(top) & ((score_two < score_lin - 1e-9) | (~(score_two > score_lin + 1e-9) & ~(top > bound)))
    if not (timed | np.isfinite(bound)).all():
        i = int(np.flatnonzero(~(timed | np.isfinite(bound)))[0])
        raise InputError(f"ticks_from_phase: no motion with x > 0 joins the grid points at s = {s[i]:.6g} and "
                         f"{s[i + 1]:.6g} mm (their x and a disagree); a stop must be a grid point with x = 0")
    kind = np.where(np.stack([timed, timed, timed], axis=1), _CUBIC, _LINEAR).astype(np.int8)
    t1 = (1.0 - gamma) * T
    s_tm = s[:-1] + v[:-1] * t1 + a[:-1] * t1 * t1 / 2.0 + j1 * t1 ** 3 / 6.0
    v_tm = v[:-1] + a[:-1] * t1 + j1 * t1 * t1 / 2.0
    a_tm = a[:-1] + j1 * t1
    s0 = np.stack([s[:-1], np.where(timed, s_tm, s[:-1] + 0.5 * h), s[1:]], axis=1)
    v0 = np.where(timed[:, None], np.stack([v[:-1], v_tm, v[1:]], axis=1),
                  np.stack([np.sqrt(np.maximum(x0[:, 0], 0.0)), np.sqrt(np.maximum(x0[:, 1], 0.0)), v[1:]], axis=1))
    a0 = np.where(timed[:, None], np.stack([a[:-1], a_tm, a[1:]], axis=1),
                  np.stack([a_lin[:, 0], a_lin[:, 1], a[1:]], axis=1))
    c = np.where(timed[:, None], np.stack([j1, j2, np.zeros_like(j1)], axis=1),
                 np.stack([c_lin[:, 0], c_lin[:, 1], np.zeros_like(j1)], axis=1))
    duration = np.stack([t1, gamma * T, np.zeros_like(T)], axis=1)
    if (~timed).any():
        k = np.flatnonzero(~timed)
        duration[k, :2] = _linear_durations(x0[k].ravel(), a_lin[k].ravel(), c_lin[k].ravel(),
                                            length[k].ravel()).reshape(-1, 2)
    if jerk is not None:   # a whole ramp (±J, 0, ∓J) inside an interval: three pieces, no excursion
        _, _, _, _, excursion = _two_jerks(h, v[:-1], v[1:], a[:-1], a[1:], gamma)
        k = np.flatnonzero(timed & (excursion > 1e-9))
        if k.size:
            side = np.where(a_tm[k] > np.maximum(a[:-1][k], a[1:][k]), 1.0, -1.0)
            r1, r2, r3, ap = _ramp(h[k], v[:-1][k], v[1:][k], a[:-1][k], a[1:][k], jerk, side)
            scale = np.maximum(np.maximum(np.abs(a[:-1][k]), np.abs(a[1:][k])),
                               np.abs(v[1:][k] - v[:-1][k]) * (v[:-1][k] + v[1:][k]) / (2.0 * h[k])) + 1e-300
            edge = np.where(side > 0, np.maximum(a[:-1][k], a[1:][k]), np.minimum(a[:-1][k], a[1:][k]))
            better = np.isfinite(ap) & (np.abs(ap - edge) / scale < excursion[k])
            k, r1, r2, r3, ap = k[better], r1[better], r2[better], r3[better], ap[better]
            j_1 = np.sign(ap - a[:-1][k]) * jerk
            j_3 = np.sign(a[1:][k] - ap) * jerk
            va = v[:-1][k] + (a[:-1][k] + ap) * r1 / 2.0
            sa = s[:-1][k] + v[:-1][k] * r1 + a[:-1][k] * r1 * r1 / 2.0 + j_1 * r1 ** 3 / 6.0
            vb, sb = va + ap * r2, sa + va * r2 + ap * r2 * r2 / 2.0
            kind[k] = _CUBIC
            s0[k] = np.stack([s[:-1][k], sa, sb], axis=1)
            v0[k] = np.stack([v[:-1][k], va, vb], axis=1)
            a0[k] = np.stack([a[:-1][k], ap, ap], axis=1)
            c[k] = np.stack([j_1, np.zeros_like(ap), j_3], axis=1)
            duration[k] = np.stack([r1, r2, r3], axis=1)
    return tuple(arr.ravel() for arr in (kind, s0, v0, a0, c, duration))


def ticks_from_phase(s_grid, x_grid, ts_s: float, a_grid=None, jerk_mm_s3: float | None = None):
    """(t, s, v, a, j) at t_k = k·Ts, k = 0 … ⌈T/Ts⌉, of the profile x(s) = v² on the grid (module
    docstring: the interpolant, the rest laws, what holds). ``a_grid`` optional nodal accelerations
    (a planner's own; replaced beside rest nodes where no motion from rest reaches them);
    ``jerk_mm_s3`` optional jerk limit J: between two nodes, among the motions within J the one whose
    a leaves the nodal values least. The last tick is on s = L at rest."""
    s, x, a_in = _check_grid(s_grid, x_grid, float(ts_s), a_grid)
    if jerk_mm_s3 is not None and not (np.isfinite(jerk_mm_s3) and jerk_mm_s3 > 0.0):
        raise InputError(f"ticks_from_phase: jerk_mm_s3 = {jerk_mm_s3!r}; must be > 0")
    s, x, a_in = merge_close(s, x, a_in)
    a = nodal_accelerations(s, x, a_in, jerk_mm_s3)
    kind, s0, v0, a0, c, duration = _pieces(s, x, a, jerk_mm_s3)
    starts = np.concatenate([[0.0], np.cumsum(duration)])
    t_end = float(starts[-1])
    if not np.isfinite(t_end) or t_end / ts_s > MAX_TICKS:
        raise InputError(f"the profile needs {t_end:.4g} s = {t_end / ts_s:.4g} servo periods (more than "
                         f"{MAX_TICKS:.0e})")
    total = float(s[-1])
    k_last = max(int(np.ceil(t_end / ts_s - 1e-9)), 1)
    t = np.arange(k_last + 1) * ts_s
    pos, vel, acc, jerk = (np.zeros(t.size) for _ in range(4))
    for lo in range(0, t.size, TICK_CHUNK):
        m = slice(lo, lo + TICK_CHUNK)
        at = np.clip(np.searchsorted(starts, t[m], side="right") - 1, 0, kind.size - 1)
        tau = np.clip(t[m] - starts[at], 0.0, duration[at])
        lin = kind[at] == _LINEAR
        ds, v, acc_m, j = _linear_state(v0[at], a0[at], np.where(lin, c[at], 0.0), tau)
        cs, cv, ca, cj = _cubic_state(v0[at], a0[at], np.where(lin, 0.0, c[at]), tau)
        pos[m] = s0[at] + np.where(lin, ds, cs)
        vel[m] = np.where(lin, v, cv)
        acc[m] = np.where(lin, acc_m, ca)
        jerk[m] = np.where(lin, j, cj)
    after = t >= t_end
    pos[after], vel[after], acc[after], jerk[after] = total, 0.0, 0.0, 0.0
    pos[0] = s[0]
    pos = np.minimum(np.maximum.accumulate(pos), total)
    pos[-1] = total
    np.maximum(vel, 0.0, out=vel)
    return t, pos, vel, acc, jerk
