"""The one interpolator every feed profile is executed through: arc-length targets → parameters.

A planner gives the arc length s_k the tool should have reached at each servo tick k·Ts (s_0 = 0,
s_K = L). The interpolator turns them into curve parameters u_k; the machine then moves along the
chords C(u_k) → C(u_k+1). Methods:

``taylor1``     u₊ = u + ΔL/|C′| (first-order Taylor; seed 000's baseline, 6.691 % fluctuation).
``taylor2``     u₊ = u + ΔL/|C′| − ΔL²(C′·C″)/(2|C′|⁴) (second-order Taylor, DESIGN §7).
``compensated`` taylor2 prediction corrected once by the ratio of commanded to obtained chord
                length (parameter compensation after Yeh & Hsu, CAD 34 (2002); seed 000: 0.035 %).
``arc``         u_k = u(s_k) exactly (Newton on s(u)); the chord is then shorter than the arc by
                ≈ ΔL³κ²/24, which is the whole remaining fluctuation.
``best``        chord-exact: every chord |C(u_k+1) − C(u_k)| equals μ·ΔL_k with one global μ ≈ 1
                that makes the last point land exactly on the path's end. Vectorised: u(s) by
                Newton on the arc length, re-targeted twice by the accumulated arc−chord deficit.

All methods end exactly at the path's end (terminal-error compensation, seed 000): the sequential
ones clamp at the end of the domain and put the last tick on it.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.geometry._kernels import nurbs_compiled
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.geometry.polyline_chords import pad3

#: Ticks per chunk of the chord-exact interpolation's curve evaluations (~300 B per tick each).
CHUNK_TICKS = 16384

METHODS = ("taylor1", "taylor2", "compensated", "arc", "best")

#: The compiled chord-exact interpolator's two whole inversions u(s) chain each tick's first
#: residual from the last tick's converged point when its first guess lies within this fraction of
#: their table interval (geometry/_arc_jit.param_at: 3 curve derivatives instead of 8). The 3-point
#: rule over 5 % of an interval is below the table's own accuracy (ARC_LENGTH_RTOL of the scale):
#: against a 16-fold finer quadrature the chained u(s) is no further from s than the unchained one
#: plus the Newton tolerance 1e-14·max(L, 1) (tests/test_arc_chain.py; 10 % was 6× further).
CHAIN = 0.05


def _check_targets(curve: Nurbs, s_mm: np.ndarray) -> np.ndarray:
    s = np.asarray(s_mm, dtype=float)
    if s.ndim != 1 or s.size < 2:
        raise InputError(f"s_mm: shape {s.shape}; need a 1-D array of at least 2 arc-length targets")
    if not np.isfinite(s).all():
        i = int(np.argmax(~np.isfinite(s)))
        raise InputError(f"s_mm[{i}] = {s[i]}; arc-length targets must be finite")
    steps = np.diff(s)
    if (steps < 0).any():
        i = int(np.argmax(steps < 0)) + 1
        raise InputError(f"s_mm[{i}] = {s[i]!r} < s_mm[{i - 1}] = {s[i - 1]!r}; targets must not decrease")
    total = curve.length
    tol = 1e-9 * max(total, 1.0)
    if abs(s[0]) > tol or abs(s[-1] - total) > tol:
        raise InputError(f"s_mm runs from {s[0]!r} to {s[-1]!r}; it must run from 0 to the path length "
                         f"{total!r} mm")
    s = s.copy()
    s[0], s[-1] = 0.0, total
    return s


def interpolate_u(curve: Nurbs, s_mm: np.ndarray, method: str = "best") -> np.ndarray:
    """Parameters u_k for the arc-length targets ``s_mm`` (one per servo tick, 0 … L).

    See the module docstring for the methods. u_0 and u_K are the ends of the domain exactly.
    """
    if method not in METHODS:
        raise InputError(f"method = {method!r}; use one of {', '.join(METHODS)}")
    s = _check_targets(curve, s_mm)
    if method == "arc":
        u = np.asarray(curve.param_at_length(s), dtype=float)
    elif method == "best":
        u = _chord_exact(curve, s)
    else:
        u = _sequential(curve, s, method)
    lo, hi = curve.domain
    u = np.clip(u, lo, hi)
    u[0], u[-1] = lo, hi
    return np.maximum.accumulate(u)



def _chords(curve: Nurbs, u: np.ndarray) -> np.ndarray:
    pts = curve.evaluate(u, order=0)[0]
    return np.linalg.norm(np.diff(pts, axis=0), axis=1)


def _chord_exact(curve: Nurbs, s: np.ndarray, iterations: int = 40) -> np.ndarray:
    """Chord-exact parameters: arc targets shifted by the accumulated arc − chord deficit.

    Each chord is shorter than its arc by d_k ≈ ΔL_k³κ²/24; retargeting the arc length to
    s′_k = Σ_{i≤k} (μ·ΔL_i + d_i), μ = (L − Σd)/L, makes every chord μ·ΔL_k and keeps s′_K = L.
    u(s_k) is solved once by Newton on s(u); each retargeting moves u by the second-order Taylor
    step of the change in target (DESIGN §7), and the fixed point on d converges in a few passes
    (it stops once every chord is within 1e-13 of the longest step, or once a pass gains less than
    10 %; the first pass solves u(s) anew).
    The curve is evaluated in chunks of :data:`CHUNK_TICKS` ticks (memory bounded per tick).
    """
    total = s[-1]
    steps = np.diff(s)
    n = s.size
    lo, hi = curve.domain
    target = s
    chords = np.empty(n - 1)
    deficit = np.empty(n - 1)
    at_knot = np.zeros(n - 1, dtype=bool)
    sp2 = np.empty(n)     # |C′|²
    d1d2 = np.empty(n)    # C′·C″
    previous = np.inf
    # a tangent can break only at a knot of multiplicity ≥ p (every knot of a polyline): the
    # ticks whose parameter interval holds one are the only ones whose deficit is capped below
    hard = _c0_knots(curve)
    if nurbs_compiled(n):   # every pass one compiled loop over the ticks (geometry/_chord_jit.py)
        return _chord_exact_compiled(curve, s, curve.param_at_length(s, chain=CHAIN), hard, iterations)
    u = np.ascontiguousarray(curve.param_at_length(s), dtype=float)
    first = True
    for _ in range(iterations):
        for c0 in range(0, n - 1, CHUNK_TICKS):
            c1 = min(c0 + CHUNK_TICKS, n - 1)      # chords c0 … c1 − 1 need points c0 … c1
            pts, d1, d2 = curve.evaluate(u[c0:c1 + 1], order=2)
            ch = np.linalg.norm(np.diff(pts, axis=0), axis=1)
            chords[c0:c1] = ch
            dl = np.diff(target[c0:c1 + 1])
            # only the deficit the curvature explains (ΔL³κ²/24, with margin): across a true corner
            # (a tangent break) the chord cuts the corner and retargeting would make the tick jump
            d1n = np.linalg.norm(d1, axis=1)
            with np.errstate(divide="ignore", invalid="ignore"):
                kap = np.linalg.norm(np.cross(pad3(d1), pad3(d2)), axis=1) / d1n ** 3
            kap = np.nan_to_num(kap, nan=0.0, posinf=0.0)
            part = np.maximum(dl - ch, 0.0)
            capped = np.minimum(part, dl ** 3 * np.maximum(kap[:-1], kap[1:]) ** 2 / 12.0 + 1e-3 * part)
            # elsewhere the curve is smooth, and the whole deficit is its own turn: a curvature
            # peak between two ticks (a near-cusp of radius 0.3 µm, passed at 0.45 mm/s) left a
            # chord 10 % short, and the tangential jerk along the chords at 9 × J
            corner = _holds_knot(hard, u[c0:c1 + 1])
            at_knot[c0:c1] = corner
            deficit[c0:c1] = np.where(corner, capped, part)
            sp2[c0:c1 + 1] = np.einsum("ij,ij->i", d1, d1)
            d1d2[c0:c1 + 1] = np.einsum("ij,ij->i", d1, d2)
        mu = (total - deficit.sum()) / total if total > 0 else 1.0
        # in mm, not per step: the relative error of a tiny step near a stop grew while the rest
        # converged, and stopped the passes with chords 2e-5 off on butterfly (the chords'
        # jerk 0.5 % over J)
        err = np.where(at_knot, 0.0, np.abs(chords - mu * steps))  # a corner's chord cannot follow
        worst = float(err.max(initial=0.0))
        # converged, or stalled (a pass gains < 10 %): at the floating-point floor, or at a
        # corner's ticks where the chord cannot follow the arc
        if worst <= 1e-13 * float(steps.max(initial=0.0)) or worst > 0.9 * previous:
            break
        previous = worst
        new = np.concatenate([[0.0], np.cumsum(mu * steps + deficit)])
        new[-1] = total
        new = np.minimum(np.maximum.accumulate(new), total)
        shift = new - target
        target = new
        if first:
            # the first shift is the whole accumulated deficit (up to mm): u(s) anew by Newton; a
            # Taylor step that long kinks at a knot (C‴ jumps) and left chords 1e-5 off there
            u = np.asarray(curve.param_at_length(target), dtype=float)
            first = False
            # and the next pass is not judged against this one: a tick just short of a true corner
            # whose first-pass chord held the corner got that chord's cut as its retarget and
            # overshot by it (1.5e-7 mm), the next pass read as a stall, and the tick's chord
            # stayed long: the chords' jerk 1.2 % over J two ticks before the corner
            # (pycut_cnc1310_backlash.nc#1, issue 38)
            previous = np.inf
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            du = np.where(sp2 > 0, shift / np.sqrt(sp2) - shift * shift * d1d2 / (2.0 * sp2 * sp2), 0.0)
        u = np.clip(u + du, lo, hi)
        # where a chord is still off by more than 1e-9 of its step (a near-cusp, the parameter
        # speed falling tenfold within a tick), the Taylor step is not to be trusted: Newton there
        slow = np.flatnonzero(err > 1e-9 * steps)
        if slow.size:
            idx = np.unique(np.concatenate([slow, slow + 1]))
            u[idx] = np.asarray(curve.param_at_length(target[idx]), dtype=float)
    return _beside_corners(curve, u, steps, hard)


def _cap_corners(curve: Nurbs, u: np.ndarray, target: np.ndarray, at_knot: np.ndarray,
                 deficit: np.ndarray) -> None:
    """The corner chords' deficits capped in place at dl³·max(κ)²/12 + 1e-3 of it (the lines of
    :func:`_chord_exact`, on the corner chords alone: numpy's powers, the points evaluated anew)."""
    corners = np.flatnonzero(at_knot)
    if corners.size == 0:
        return
    kap = []
    for at in (corners, corners + 1):
        _, d1, d2 = curve.evaluate(u[at], order=2)
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.linalg.norm(np.cross(pad3(d1), pad3(d2)), axis=1) / np.linalg.norm(d1, axis=1) ** 3
        kap.append(np.nan_to_num(k, nan=0.0, posinf=0.0))
    dl = target[corners + 1] - target[corners]
    part = deficit[corners]
    deficit[corners] = np.minimum(part, dl ** 3 * np.maximum(kap[0], kap[1]) ** 2 / 12.0 + 1e-3 * part)


def _chord_exact_compiled(curve: Nurbs, s: np.ndarray, u: np.ndarray, hard: np.ndarray,
                          iterations: int) -> np.ndarray:
    """:func:`_chord_exact` with each pass one compiled loop over the ticks (the curve evaluated
    tick by tick, the span and the corner knot carried from the last tick; the retargeting and the
    Taylor step in one more loop): the same operations in the same order, no array per term."""
    from fuzzyfeed.geometry._kernels import chord_kernels

    terms, pass_error, retarget = chord_kernels()
    total = s[-1]
    steps = np.diff(s)
    top = float(steps.max(initial=0.0))
    n = s.size
    lo, hi = curve.domain
    spans, coeffs = curve._spans, curve._coeffs
    u = np.ascontiguousarray(u, dtype=float)
    target = s.copy()
    chords = np.empty(n - 1)
    deficit = np.empty(n - 1)
    at_knot = np.zeros(n - 1, dtype=bool)
    sp2 = np.empty(n)     # |C′|²
    d1d2 = np.empty(n)    # C′·C″
    redo = np.zeros(n, dtype=bool)
    previous = np.inf
    first = True
    settled = False       # the last pass evaluated the final u (its corner flags are u's)
    for _ in range(iterations):
        bad = terms(spans, coeffs, lo, hi, u, target, hard, chords, deficit, at_knot, sp2, d1d2)
        if bad >= 0:
            curve.evaluate(u[bad:bad + 1], order=0)     # the curve's own error for the point
        _cap_corners(curve, u, target, at_knot, deficit)
        mu = (total - deficit.sum()) / total if total > 0 else 1.0
        worst = pass_error(chords, steps, at_knot, mu)
        if worst <= 1e-13 * top or worst > 0.9 * previous:
            settled = True
            break
        previous = worst
        if first:   # see _chord_exact: u(s) anew by Newton after the first shift
            retarget(steps, deficit, mu, total, target, u, sp2, d1d2, chords, at_knot, lo, hi, False, redo)
            u = np.ascontiguousarray(curve.param_at_length(target, chain=CHAIN), dtype=float)
            first = False
            previous = np.inf
            continue
        if retarget(steps, deficit, mu, total, target, u, sp2, d1d2, chords, at_knot, lo, hi, True, redo):
            idx = np.flatnonzero(redo)
            u[idx] = np.asarray(curve.param_at_length(target[idx]), dtype=float)
    return _beside_corners(curve, u, steps, hard, knot=at_knot if settled else None)


def _beside_corners(curve: Nurbs, u: np.ndarray, steps: np.ndarray, hard: np.ndarray,
                    rounds: int = 60, knot: np.ndarray | None = None) -> np.ndarray:
    """``u`` with the chords beside a corner's chord in the ratio to their ``steps`` of the smooth
    chord beyond them: where the
    fixed point stalls with a tick that crossed the corner between passes, the smooth chord next
    to the corner's keeps the corner's cut as its retarget (up to 6e-3 mm). The tick shared with
    the corner's chord is moved, on its own side of the corner knot, until the chord from its
    other end has the wanted length (bisection: the distance from a point grows along a smooth
    piece shorter than a servo step); the corner's chord, which cuts the corner anyway, takes the
    difference. ``knot``: the chords' corner flags (:func:`_holds_knot` of ``u``) if known.
    Only the points next to corners are evaluated."""
    if hard.size == 0 or u.size < 3:
        return u
    if knot is None:
        knot = _holds_knot(hard, u)
    n = knot.size
    before = np.flatnonzero(~knot[:-1] & knot[1:])     # chord k, then the corner's chord k + 1
    after = np.flatnonzero(~knot[1:] & knot[:-1]) + 1  # the corner's chord k - 1, then chord k
    before = before[(before >= 1) & ~knot[np.maximum(before - 1, 0)]]
    after = after[(after <= n - 2) & ~knot[np.minimum(after + 1, n - 1)]]
    # the ratio chord / step the fixed point reached on the smooth chord beyond (μ up to its own
    # last digits) is the wanted one of the chord beside the corner's; points near corners only
    near = np.unique(np.concatenate([before - 1, before, before + 1, after, after + 1, after + 2]))
    # the curve's own coordinates (a 2-D curve's points had a NaN third one: every chord NaN, and
    # no tick beside a 2-D path's corner was ever moved)
    pts = curve.evaluate(u[near], order=0)[0] if near.size else np.empty((0, curve.dim))

    def point(k):
        return pts[np.searchsorted(near, k)]

    def chord(c):       # |P(c + 1) − P(c)| of chords c whose two points are near
        return np.linalg.norm(point(c + 1) - point(c), axis=1)

    def ratio(c):
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(steps[c] > 0, chord(c) / steps[c], 1.0)

    want_before = steps[before] * ratio(before - 1)
    want_after = steps[after] * ratio(after + 1)
    off_before = np.abs(chord(before) - want_before) > 1e-12 * np.maximum(steps[before], 1.0)
    off_after = np.abs(chord(after) - want_after) > 1e-12 * np.maximum(steps[after], 1.0)
    before, want_before = before[off_before], want_before[off_before]
    after, want_after = after[off_after], want_after[off_after]
    once = ~np.isin(after - 1, before + 1)              # a tick moved once
    after, want_after = after[once], want_after[once]
    u = u.copy()
    for chords, want, moving, anchor, sign in ((before, want_before, before + 1, before, 1.0),
                                               (after, want_after, after, after + 1, -1.0)):
        if chords.size == 0:
            continue
        # the bracket: from the anchor's side to the corner knot (exclusive)
        k_at = np.searchsorted(hard, u[moving], side="left" if sign > 0 else "right") - (sign < 0)
        end = hard[np.clip(k_at, 0, hard.size - 1)]
        a, b = u[anchor], end - sign * 1e-12 * (curve.domain[1] - curve.domain[0])
        p0 = point(anchor)
        length = lambda x: np.linalg.norm(curve.evaluate(x, order=0)[0] - p0, axis=1)  # noqa: E731
        ok = (length(b) >= want) & (sign * (b - a) > 0)
        a, b, want, moving, p0 = a[ok], b[ok], want[ok], moving[ok], p0[ok]
        for _ in range(rounds):
            mid = 0.5 * (a + b)
            short = length(mid) < want
            a, b = np.where(short, mid, a), np.where(short, b, mid)
        u[moving] = 0.5 * (a + b)
    return u


def _c0_knots(curve: Nurbs) -> np.ndarray:
    """Interior knot values where the unit tangent breaks: of multiplicity ≥ the degree (where it
    may) and with the tangents just before and after apart (a G1 join of a blended polyline is
    smooth: its chords' whole deficit is compensated, or their jerk jumped 5-8 × J there)."""
    knots = np.asarray(curve.knots, dtype=float)
    values, counts = np.unique(knots, return_counts=True)
    lo, hi = curve.domain
    cand = values[(counts >= curve.degree) & (values > lo) & (values < hi)]
    if cand.size == 0:
        return cand
    eps = 1e-9 * (hi - lo)
    d_in = curve.evaluate(cand - eps, order=1)[1]
    d_out = curve.evaluate(cand + eps, order=1)[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_in = d_in / np.linalg.norm(d_in, axis=1, keepdims=True)
        t_out = d_out / np.linalg.norm(d_out, axis=1, keepdims=True)
    jump = np.nan_to_num(np.abs(t_out - t_in).max(axis=1), nan=np.inf)
    return cand[jump > 1e-6]


def _holds_knot(knots: np.ndarray, u: np.ndarray) -> np.ndarray:
    """For each interval [u_k, u_k+1] of the increasing ``u``: does it hold one of ``knots``?"""
    if knots.size == 0:
        return np.zeros(max(u.size - 1, 0), dtype=bool)
    return np.searchsorted(knots, u[1:], side="right") > np.searchsorted(knots, u[:-1], side="left")


def _sequential(curve: Nurbs, s: np.ndarray, method: str) -> np.ndarray:
    """Recursive Taylor interpolation (DESIGN §7; Yeh & Hsu 2002 for the compensation)."""
    lo, hi = curve.domain
    steps = np.diff(s)
    u = np.empty(s.size)
    u[0] = lo
    cur = lo
    order = 1 if method == "taylor1" else 2
    ended = False
    for k, dl in enumerate(steps, start=1):
        if ended or dl <= 0.0:
            u[k] = cur
            continue
        _, d1, *rest = curve.evaluate(cur, order=order)
        sp2 = float(d1 @ d1)
        sp = np.sqrt(sp2)
        if sp == 0.0:  # stationary point: nudge forward along the parameter
            nxt = min(cur + 1e-9 * (hi - lo), hi)
        else:
            nxt = cur + dl / sp
            if order == 2:
                nxt -= dl * dl * float(d1 @ rest[0]) / (2.0 * sp2 * sp2)
        if method == "compensated" and nxt > cur:
            p0 = curve.evaluate(cur, order=0)[0]
            p1 = curve.evaluate(min(nxt, hi), order=0)[0]
            got = float(np.linalg.norm(p1 - p0))
            if got > 0.0:
                nxt = cur + (min(nxt, hi) - cur) * dl / got
        if nxt >= hi:
            nxt, ended = hi, True
        cur = nxt
        u[k] = cur
    return u


def feed_fluctuation(curve: Nurbs, u: np.ndarray, s_mm: np.ndarray,
                     points: np.ndarray | None = None) -> np.ndarray:
    """Per-tick feed fluctuation |ΔP_k| / ΔL_k − 1 in absolute value (Yeh & Hsu 2002).

    ΔP_k = C(u_k) − C(u_{k−1}) is the chord the machine actually moves in tick k, ΔL_k the commanded
    step s_k − s_{k−1}. Ticks excluded (NaN): a commanded step of 0, the tick that arrives at the
    path's end (the terminal-error compensation step; a sequential method may arrive a few ticks
    early) and every tick after it.
    Returns an array of length K (one value per tick); multiply by 100 for percent. ``points``,
    if given, are the ticks' positions C(u_k) already evaluated.
    """
    u = np.asarray(u, dtype=float)
    s = np.asarray(s_mm, dtype=float)
    if u.shape != s.shape or u.ndim != 1 or u.size < 2:
        raise InputError(f"u has shape {u.shape}, s_mm {s.shape}; need equal 1-D arrays of >= 2 values")
    commanded = np.diff(s)
    chords = _chords(curve, u) if points is None else np.linalg.norm(np.diff(points, axis=0), axis=1)
    out = np.full(commanded.size, np.nan)
    ok = commanded > 1e-12 * max(float(s[-1]), 1.0)
    hi = curve.domain[1]
    ok &= u[1:] < hi  # the tick arriving at the end is the terminal compensation
    ok[-1] = False
    out[ok] = np.abs(chords[ok] / commanded[ok] - 1.0)
    return out


def max_fluctuation_pct(curve: Nurbs, u: np.ndarray, s_mm: np.ndarray) -> float:
    """Largest feed fluctuation in percent over the ticks :func:`feed_fluctuation` measures."""
    f = feed_fluctuation(curve, u, s_mm)
    return float(np.nanmax(f) * 100.0) if np.isfinite(f).any() else 0.0
