"""Curvature of a point sequence (G1 chain, CSV point list, DXF polyline) that sees the path, not
the rounding of its coordinates.

A polyline written by a CAM post is a path known only within the rounding of its coordinates
(3–4 decimals): the three-point curvature (seed 002, eq. 4–9) of such points is mostly rounding
noise, and a polygon's corner is not a circle through three points. Here (DESIGN §3, "Feeds in a
program"):

1. **Rounding.** The coordinates' quantum q is read from the values (the coarsest 10⁻ᵈ mm, d ≥ 2,
   or 25.4·10⁻ᵈ mm, d ≥ 4, that ≥ 90 % of the coordinates are multiples of: what a post printing
   d decimals in mm or inch produces; integer coordinates count as 2 decimals, since a coarser
   rounding is no CAM output but a drawing's round numbers); a point is then known within
   ``tolerance`` = q/2·√dim. Without a quantum (full-precision floats) the tolerance is float noise. A tolerance the user gives wins.
2. **Tiny moves.** Consecutive points within P/10 of a first one are one vertex (duplicate points,
   a 0.1 µm jog): a controller blending within P does not see them. A longer reversal stays.
3. **Lines and arcs within the rounding.** Maximal runs of ≥ :data:`MIN_RUN` vertices that one
   straight line or one circle (least squares, geometric refinement; planar within the tolerance
   for 3-D points) passes within 1.5·tolerance of, without any vertex turning by 90° or more and
   with every chord's sagitta on the circle ≤ P, get that line's κ = 0 or that circle's κ = 1/R —
   a circle written as rounded G1 moves gets one constant κ, as its NURBS has.
4. **Every other vertex is blended as the controller blends it** (LinuxCNC G64 P: a blend arc
   within the path tolerance P, tangent to both chords): with turning angle θ (0 when θ is within
   the rounding's own angle tolerance·(1/a + 1/b)), the blend radius is
   r = min(P·cos(θ/2)/(1 − cos(θ/2)), (a + b)/4 / tan(θ/2)) — the first is the arc whose middle
   stays within P of the corner, the second the arc through the chords' mid-region of a smooth
   curve (≈ 1/κ for a finely sampled curve). κ = 1/r. Where the first bound is the smaller, the
   vertex is a **corner**: the controller leaves the polyline by P there. A reversal (θ = 180°)
   has r = 0; κ is capped at :data:`KAPPA_MAX_1_MM` (the planners crawl there: √(A/κ) ≈ 0.3 mm/s at 1000 mm/s²), never NaN.
   Where two runs meet, θ is the angle between their fitted tangents. Where arc runs of similar
   κ meet without a break (a free-form curve cut into arcs), κ is interpolated linearly in arc
   length between the runs' middles rather than left as steps.

Full-precision points (no quantum found, no tolerance given) have no rounding to see through:
each vertex gets the circle through it and its neighbours (exact on circles and lines), or the
blend within P where that is tighter; runs of equal circles get one κ (:func:`_exact_curvature`).

Ends of an open path take the κ of their run, or 0 on a free end segment. A closed path (last
point = first) blends its seam like any vertex.

The run search of step 3 (greedy, numpy or numba-compiled) is :mod:`fuzzyfeed.geometry.polyline_runs`;
the vertices, chords and turning angles :mod:`fuzzyfeed.geometry.polyline_chords`.

A sequence longer than :data:`WINDOW_VERTICES` (a cut of 10⁶ G1 moves) is fitted window after
window, with the whole sequence's result bit for bit and memory bounded by the window: the global
quantities are cheap first passes (the rounding quantum counted in chunks, the merge clusters, the
extent); the run search resumes window after window with the last run carried
(:func:`~fuzzyfeed.geometry.polyline_runs.line_arc_runs_windowed`); the per-vertex pass needs of
other windows only the runs (their meets' tangent breaks, the smooth chains and their middles' arc
length, one cumulative sum carried). The full-precision branch (no quantum) is not windowed. Points
given in chunks (a cut read from its file) are fitted so by
:func:`fuzzyfeed.geometry.polyline_stream.fit_chunks`, without the whole array.
"""

from __future__ import annotations

import contextvars
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.geometry.polyline_chords import (WINDOW_VERTICES, Chords, Window, angle_between,
                                                arc_lengths, merge_tiny_moves, pad3)
from fuzzyfeed.geometry.polyline_runs import (FIT_SLACK, MIN_RUN, Runs, line_arc_runs, line_arc_runs_windowed,
                                              tangent_of)

#: Default path tolerance P (mm) of the controller's corner blend (LinuxCNC G64 P0.01).
DEFAULT_PATH_TOLERANCE_MM = 0.01
#: Curvature cap (1/mm): a blend radius of 0.1 µm. A reversal gets it (every planner stops there).
KAPPA_MAX_1_MM = 1.0e4
#: Share of coordinates that must be multiples of a quantum for it to be taken as the rounding.
QUANTUM_SHARE = 0.9
#: (point tolerance, path tolerance P) in mm used where a caller passes None (the CLI's
#: ``--point-tolerance`` / ``--path-tolerance``); None entries keep the defaults.
TOLERANCES: contextvars.ContextVar[tuple[float | None, float | None]] = \
    contextvars.ContextVar("polyline_tolerances", default=(None, None))


@dataclass(frozen=True, eq=False)
class PolylineCurvature:
    """Per point: κ (1/mm), unit tangent (N, 3), corner flag; and the tolerances used (mm)."""

    curvature: np.ndarray
    tangent: np.ndarray
    corner: np.ndarray
    tolerance_mm: float
    path_tolerance_mm: float
    quantum_mm: float | None


#: The roundings :func:`rounding_quantum` tries, coarsest first (mm).
QUANTUM_CANDIDATES = tuple(sorted({10.0 ** -d for d in range(2, 10)} | {25.4 * 10.0 ** -d for d in range(4, 11)},
                                  reverse=True))


def quantum_counts(values: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """Of a chunk of coordinates: the finite values, and per candidate of :data:`QUANTUM_CANDIDATES`
    how many are its multiples (to 1e-6 q) and whether any is over 10¹² of it (exact integers:
    chunks' counts add up to the whole's)."""
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    count = np.zeros(len(QUANTUM_CANDIDATES), dtype=np.int64)
    big = np.zeros(len(QUANTUM_CANDIDATES), dtype=bool)
    for k, q in enumerate(QUANTUM_CANDIDATES):
        r = v / q
        if r.size and np.abs(r).max() > 1e12:
            big[k] = True
            break               # coarser candidates decide first; finer ones are over 10¹² too
        count[k] = np.count_nonzero(np.abs(r - np.round(r)) <= 1e-6)
    return v.size, count, big


def quantum_of_counts(size: int, count: np.ndarray, big: np.ndarray) -> float | None:
    """The coarsest candidate whose multiples are ≥ :data:`QUANTUM_SHARE` of ``size`` values, None at
    the first candidate over 10¹² (full-precision values) or none."""
    if size == 0:
        return None
    for q, c, b in zip(QUANTUM_CANDIDATES, count.tolist(), big.tolist()):
        if b:
            return None
        if c / size >= QUANTUM_SHARE:
            return q
    return None


def rounding_quantum(points: np.ndarray) -> float | None:
    """The coarsest q in {10⁻ᵈ : d = 2…9} ∪ {25.4·10⁻ᵈ : d = 4…10} mm that ≥ :data:`QUANTUM_SHARE` of the
    coordinates are integer multiples of (to 1e-6 q), or None (full-precision values). The counts
    are summed over chunks of :data:`WINDOW_VERTICES` points (exact integers: the same share)."""
    pts = np.asarray(points, dtype=float)
    pts = pts.reshape(len(pts), -1) if pts.ndim > 1 else pts.reshape(-1, 1)
    size, count, big = 0, np.zeros(len(QUANTUM_CANDIDATES), dtype=np.int64), np.zeros(len(QUANTUM_CANDIDATES), bool)
    for c in range(0, len(pts), WINDOW_VERTICES):
        n, k, b = quantum_counts(pts[c:c + WINDOW_VERTICES])
        size, count, big = size + n, count + k, big | b
    return quantum_of_counts(size, count, big)


def blend_curvature(theta: np.ndarray, a: np.ndarray, b: np.ndarray, path_tol: float) -> tuple[np.ndarray, np.ndarray]:
    """κ = 1/r of the controller's blend at vertices turning by ``theta`` between chords of
    lengths ``a`` and ``b`` (see the module docstring, step 4), capped at :data:`KAPPA_MAX_1_MM`;
    and whether the path-tolerance bound decides (a corner)."""
    theta = np.asarray(theta, dtype=float)
    half = 0.5 * theta
    one_minus_cos = 2.0 * np.sin(0.5 * half) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        r_tol = np.where(one_minus_cos > 0, path_tol * np.cos(half) / one_minus_cos, np.inf)
        tan_half = np.tan(half)
        r_seg = np.where(tan_half > 0, 0.25 * (a + b) / tan_half, np.inf)
        r_seg = np.where(half >= np.pi / 2 - 1e-12, 0.0, r_seg)
        r_tol = np.where(half >= np.pi / 2 - 1e-12, 0.0, r_tol)
        r = np.minimum(r_tol, r_seg)
        kappa = np.where(np.isinf(r), 0.0, np.where(r > 0, 1.0 / r, np.inf))
    corner = (r_tol < r_seg) & (theta > 0)
    return np.minimum(kappa, KAPPA_MAX_1_MM), corner


def _circumcurvature(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """1/R of the circle through three points, row-wise (0 for collinear points)."""
    d1, d2, d3 = p1 - p0, p2 - p1, p2 - p0
    den = np.linalg.norm(d1, axis=1) * np.linalg.norm(d2, axis=1) * np.linalg.norm(d3, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = 2.0 * np.linalg.norm(np.cross(d1, d2), axis=1) / den
    return np.nan_to_num(k, nan=0.0, posinf=KAPPA_MAX_1_MM)


def _exact_curvature(pts: np.ndarray, turn: np.ndarray, closed: bool, path_tol: float,
                     extent: float) -> tuple[np.ndarray, np.ndarray]:
    """Full-precision points (no rounding to see through): the circle through each vertex and its
    neighbours — exact on circles and lines — or the controller's blend within P where that is
    tighter (a corner). Runs of ≥ :data:`MIN_RUN` vertices whose circles agree to 1e-7 get their
    mean (one circle, one κ); float-noise curvature on a line is 0."""
    m = len(pts)
    k3 = np.zeros(m)
    if m > 2:
        k3[1:-1] = _circumcurvature(pts[:-2], pts[1:-1], pts[2:])
    if closed:
        k3[0] = k3[-1] = _circumcurvature(pts[-2:-1], pts[:1], pts[1:2])[0]
    k3[k3 * max(extent, 1.0) < 1e-8] = 0.0
    inf = np.full(m, np.inf)
    k_tol, _ = blend_curvature(turn, inf, inf, path_tol)
    corner = k_tol > k3
    kappa = np.minimum(np.maximum(k3, k_tol), KAPPA_MAX_1_MM)
    same = np.abs(np.diff(k3)) <= 1e-7 * np.maximum(k3[1:], k3[:-1])
    same &= ~corner[1:] & ~corner[:-1]
    group = np.concatenate([[0], np.cumsum(~same)])
    sizes = np.bincount(group)
    means = np.bincount(group, weights=k3) / sizes
    long = sizes[group] >= MIN_RUN
    kappa[long] = means[group[long]]
    if not closed:
        corner[0] = corner[-1] = False
        kappa[0] = kappa[1] if m > 2 and not corner[1] else 0.0
        kappa[-1] = kappa[-2] if m > 2 and not corner[-2] else 0.0
    return kappa, corner


def polyline_curvature(points: np.ndarray, tolerance_mm: float | None = None,
                       path_tolerance_mm: float | None = None, window: int = WINDOW_VERTICES) -> PolylineCurvature:
    """κ, tangent and corners of a point sequence (module docstring); ``tolerance_mm`` is the
    coordinates' rounding (read from the values when None), ``path_tolerance_mm`` the controller's
    blend tolerance P (default :data:`DEFAULT_PATH_TOLERANCE_MM`)."""
    given_tol, given_path = TOLERANCES.get()
    tolerance_mm = given_tol if tolerance_mm is None else tolerance_mm
    path_tolerance_mm = given_path if path_tolerance_mm is None else path_tolerance_mm
    raw = np.asarray(points, dtype=float)
    if raw.ndim != 2 or raw.shape[0] < 2 or raw.shape[1] not in (2, 3):
        raise InputError(f"points: shape {raw.shape}; need at least 2 points of 2 or 3 coordinates")
    if not np.isfinite(raw).all():
        i = int(np.argwhere(~np.isfinite(raw))[0, 0])
        raise InputError(f"points[{i}] = {raw[i].tolist()}; coordinates must be finite")
    path_tol = DEFAULT_PATH_TOLERANCE_MM if path_tolerance_mm is None else float(path_tolerance_mm)
    if not np.isfinite(path_tol) or path_tol <= 0:
        raise InputError(f"path_tolerance_mm = {path_tolerance_mm!r}; must be finite and > 0")
    extent = float(np.ptp(raw, axis=0).max()) if len(raw) > 1 else 0.0
    quantum = None
    if tolerance_mm is None:
        quantum = rounding_quantum(raw)
        tol = 0.5 * quantum * np.sqrt(raw.shape[1]) if quantum is not None else 0.0
    else:
        tol = float(tolerance_mm)
        if not np.isfinite(tol) or tol < 0:
            raise InputError(f"tolerance_mm = {tolerance_mm!r}; must be finite and >= 0")
    tol = max(tol, 1e-9 * max(1.0, extent))      # float noise at least
    pts3 = pad3(raw)
    ids, reduced = merge_tiny_moves(pts3, 0.1 * path_tol)
    m = len(reduced)
    if m == 1:   # the whole path lies within the merge distance: a point
        tangent = np.zeros((len(raw), 3))
        tangent[:, 0] = 1.0
        return PolylineCurvature(np.zeros(len(raw)), tangent, np.zeros(len(raw), bool), tol,
                                 path_tol, quantum)
    geo = Chords.of(reduced, tol)
    if tolerance_mm is None and quantum is None:
        w = geo.window(0, m)
        kappa, corner = _exact_curvature(reduced, w.turn, geo.closed, path_tol, extent)
        return _result(kappa, corner, _tangents(geo, 0, m, w), ids, tol, path_tol, quantum)
    if m <= window:
        w = geo.window(0, m)
        runs = line_arc_runs(reduced, w.turn, FIT_SLACK * tol, path_tol)
    else:
        runs = line_arc_runs_windowed(geo, FIT_SLACK * tol, path_tol, window)
    kappa = np.empty(m)
    corner = np.empty(m, dtype=bool)
    tangent = np.empty((m, 3))
    whole = _RunContext.of(geo, runs, tol)
    carry = 0.0
    for lo in range(0, m, window):
        hi = min(lo + window, m)
        w = geo.window(lo, hi)
        s, carry = arc_lengths(w, lo, hi, carry)
        kappa[lo:hi], corner[lo:hi] = _vertex_pass(geo, whole, lo, hi, w, s, tol, path_tol)
        tangent[lo:hi] = _tangents(geo, lo, hi, w)
    return _result(kappa, corner, tangent, ids, tol, path_tol, quantum)


class _RunContext(NamedTuple):
    """What the per-vertex pass needs of the runs beyond its window: each meet's tangent break
    (angle between the fitted tangents, thresholded like any vertex's turn), the seam's, and the
    chains of smooth arc runs with their middles' arc length (s summed chord after chord from the
    path's start, as one cumulative sum)."""

    runs: Runs
    meet_theta: np.ndarray          # (R-1,) at vertex last[r] == first[r+1] (else unused)
    seam_theta: float | None        # a closed path whose seam joins two runs
    chains: np.ndarray              # (C, 2) run ranges c0..c1-1 of the smooth chains (> 1 run)
    mids: np.ndarray                # (R,) s at each run's middle

    @staticmethod
    def of(geo: Chords, runs: Runs, tol: float) -> _RunContext:
        first, last, k = runs.first, runs.last, runs.kappa
        count = first.size
        meet_theta = np.zeros(max(count - 1, 0))
        seam = None
        if count:
            meet = np.flatnonzero(last[:-1] == first[1:])
            v = first[meet + 1]
            pv = geo.at(v)
            vec_in = pv - geo.at(v - 1)
            vec_out = geo.at(v + 1) - pv
            len_in, len_out = np.linalg.norm(vec_in, axis=1), np.linalg.norm(vec_out, axis=1)
            u_in, u_out = vec_in / len_in[:, None], vec_out / len_out[:, None]
            axis, center = runs.axis, runs.center
            t_in = tangent_of(axis[meet], center[meet], pv, u_in)
            t_out = tangent_of(axis[meet + 1], center[meet + 1], pv, u_out)
            theta = angle_between(t_in, t_out)
            noise = tol * FIT_SLACK * (1.0 / len_in + 1.0 / len_out)
            meet_theta[meet] = np.where(theta > noise, theta, 0.0)
            m = geo.m
            if geo.closed and first[0] == 0 and last[-1] == m - 1:   # the seam joins two runs
                t_in = tangent_of(axis[-1:], center[-1:], geo.at(np.array([m - 1])), geo.last_unit[None, :])
                t_out = tangent_of(axis[:1], center[:1], geo.at(np.array([0])), geo.first_unit[None, :])
                seam = float(angle_between(t_in, t_out)[0])
        chains = np.zeros((0, 2), dtype=int)
        mids = np.zeros(count)
        if count >= 2:
            k0, k1 = k[:-1], k[1:]
            lo_k, hi_k = np.minimum(k0, k1), np.maximum(k0, k1)
            smooth = (last[:-1] == first[1:]) & (meet_theta == 0) & (lo_k > 0) & (hi_k <= 2 * lo_k)
            ends = np.flatnonzero(~smooth) + 1                  # chain c: runs starts[c] .. ends[c] - 1
            starts = np.concatenate([[0], ends])
            ends = np.concatenate([ends, [count]])
            chains = np.column_stack([starts, ends])[ends - starts > 1]
            if chains.size:
                s_first, s_last = geo.s_at(first), geo.s_at(last)
                mids = (s_first + s_last) / 2
        return _RunContext(runs, meet_theta, seam, chains, mids)


def _vertex_pass(geo: Chords, ctx: _RunContext, lo: int, hi: int, w: Window, s: np.ndarray, tol: float,
                 path_tol: float) -> tuple[np.ndarray, np.ndarray]:
    """κ and corner flag of vertices lo..hi-1 from the runs (module docstring, steps 3-4): a run's
    inner vertices its κ, every other vertex the blend of its turn (at a meet: of the fitted
    tangents), smooth chains of arc runs interpolated in s, open ends their run's κ or 0."""
    m = geo.m
    first, last, run_k = ctx.runs.first, ctx.runs.last, ctx.runs.kappa
    r0, r1 = int(np.searchsorted(last, lo)), int(np.searchsorted(first, hi))   # runs touching lo..hi-1
    F, L, K = first[r0:r1], last[r0:r1], run_k[r0:r1]
    size = hi - lo
    kappa = np.full(size, np.nan)
    run_kappa_left = np.zeros(size)    # κ of a run ending at the vertex
    run_kappa_right = np.zeros(size)   # κ of a run starting at the vertex
    theta = w.turn.copy()
    if F.size:
        st = np.maximum(F + 1, lo) - lo
        inner = np.maximum(np.minimum(L, hi) - lo - st, 0)
        at = np.repeat(st - np.cumsum(inner) + inner, inner) + np.arange(inner.sum())
        kappa[at] = np.repeat(K, inner)
        own = F >= lo
        run_kappa_right[F[own] - lo] = K[own]
        own = L < hi
        run_kappa_left[L[own] - lo] = K[own]
        pair = np.arange(r0, r1 - 1)
        pair = pair[(last[pair] == first[pair + 1]) & (last[pair] >= lo)]
        theta[last[pair] - lo] = ctx.meet_theta[pair]
        if ctx.seam_theta is not None:
            seam = max(run_k[0], run_k[-1])
            for v in {0, m - 1} & {lo, hi - 1}:
                theta[v - lo] = ctx.seam_theta
                run_kappa_left[v - lo] = run_kappa_right[v - lo] = seam
    noise_angle = tol * FIT_SLACK * (1.0 / w.a + 1.0 / w.b)
    theta = np.where(theta > noise_angle, theta, 0.0)
    k_blend, corner = blend_curvature(theta, w.a, w.b, path_tol)
    free = np.isnan(kappa)
    kappa[free] = np.maximum(k_blend[free], np.maximum(run_kappa_left[free], run_kappa_right[free]))
    corner &= free & (k_blend >= kappa)
    if ctx.chains.size:        # smooth chains: κ linear in s between the runs' middles
        c_lo = first[ctx.chains[:, 0]] + 1
        c_hi = last[ctx.chains[:, 1] - 1]
        touch = np.flatnonzero((c_hi > lo) & (c_lo < hi))
        if touch.size:
            for c in touch.tolist():
                c0, c1 = ctx.chains[c]
                a, b = max(int(c_lo[c]), lo), min(int(c_hi[c]), hi)
                kappa[a - lo:b - lo] = np.interp(s[a - lo:b - lo], ctx.mids[c0:c1], run_k[c0:c1])
    if not geo.closed:   # open ends: no turning; the κ of their run, or 0
        if lo == 0:
            kappa[0] = run_kappa_right[0]
            corner[0] = False
        if hi == m:
            kappa[-1] = run_kappa_left[-1]
            corner[-1] = False
    return kappa, corner


def _tangents(geo: Chords, lo: int, hi: int, w: Window) -> np.ndarray:
    """Unit tangent at vertices lo..hi-1: the bisector of the chords, at a reversal (bisector ≈ 0)
    the incoming chord; the ends their chord."""
    m = geo.m
    t = np.empty((hi - lo, 3))
    v0, v1 = max(lo, 1), min(hi, m - 1)
    if v1 > v0:
        u_in, u_out = w.unit[v0 - 1 - w.c0:v1 - 1 - w.c0], w.unit[v0 - w.c0:v1 - w.c0]
        bis = u_in + u_out
        norm = np.linalg.norm(bis, axis=1)
        ok = norm > 1e-9
        t[v0 - lo:v1 - lo] = np.where(ok[:, None], bis / np.where(ok, norm, 1.0)[:, None], u_in)
    if lo == 0:
        t[0] = geo.first_unit
    if hi == m:
        t[-1] = geo.last_unit
    return t


def _result(kappa, corner, tangent, ids, tol, path_tol, quantum) -> PolylineCurvature:
    """Per-point values from the per-vertex ones (``ids``: each point's vertex; None: the same)."""
    if ids is None:
        return PolylineCurvature(kappa, tangent, corner, tol, path_tol, quantum)
    return PolylineCurvature(kappa[ids], tangent[ids], corner[ids], tol, path_tol, quantum)
