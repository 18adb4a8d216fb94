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

The run search of step 3 is greedy: from a start vertex (screened by the spread of its
circumcurvatures, :func:`_run_candidates`) the run's end is found by galloping then bisecting
on the vertex count, and neighbouring runs are merged where one fit covers both. Each candidate
run costs one line/circle fit; from :data:`COMPILED_MIN_VERTICES` vertices on these fits run as
numba-compiled scalar loops (:mod:`fuzzyfeed.geometry._polyline_jit`, cached on disk like the other
kernels, :mod:`fuzzyfeed.geometry._kernels`), below in numpy without importing numba. Both forms run the
same search; their sums run in another order, so on a near-straight stretch whose fit residual
equals the tolerance to the last bits they can cut the runs differently (both within the
tolerance of the points).

A sequence longer than :data:`WINDOW_VERTICES` (a cut of 10⁶ G1 moves) is fitted window after
window, with the whole sequence's result bit for bit and memory bounded by the window: the global
quantities are cheap first passes (the rounding quantum counted in chunks, the merge clusters, the
extent); the run search (compiled) stops before any trial that would reach a window's last vertex
and resumes in the next window from where it stopped, the last run found carried (the next may
merge into it), so each of its trials is one the whole search makes; the per-vertex pass needs of
other windows only the runs (their meets' tangent breaks, the smooth chains and their middles' arc
length, one cumulative sum carried). The full-precision branch (no quantum) is not windowed.
"""

from __future__ import annotations

import contextvars
from dataclasses import dataclass
from functools import cache
from typing import NamedTuple

import numpy as np

from fuzzyfeed.errors import InputError

#: Default path tolerance P (mm) of the controller's corner blend (LinuxCNC G64 P0.01).
DEFAULT_PATH_TOLERANCE_MM = 0.01
#: Curvature cap (1/mm): a blend radius of 0.1 µm. A reversal gets it (every planner stops there).
KAPPA_MAX_1_MM = 1.0e4
#: Fewest vertices a line/circle run must have to be taken as one (three points fit any circle).
MIN_RUN = 5
#: A run's fit may miss a point by this factor times the rounding tolerance (least squares is not
#: the minimax fit).
FIT_SLACK = 1.5
#: Vertices (after merging tiny moves) from which the run search runs numba-compiled (~0.1 s per
#: 10⁵ vertices): importing numba and LAPACK and loading the cached kernel costs ~1 s of CPU once
#: per process, what the numpy form (~0.3 ms per vertex on short runs) spends on ~4000 vertices.
COMPILED_MIN_VERTICES = 4096
#: Vertices one window of the fit holds (the run search and the per-vertex pass): a longer point
#: sequence (a cut of 10⁶ G1 moves) is fitted window after window, with the whole sequence's result
#: (:func:`_runs_windowed`, :func:`_vertex_pass`), its memory bounded by the window.
WINDOW_VERTICES = 1 << 16
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


def rounding_quantum(points: np.ndarray) -> float | None:
    """The coarsest q in {10⁻ᵈ : d = 2…9} ∪ {25.4·10⁻ᵈ : d = 4…10} mm that ≥ :data:`QUANTUM_SHARE` of the
    coordinates are integer multiples of (to 1e-6 q), or None (full-precision values). The counts
    are summed over chunks of :data:`WINDOW_VERTICES` points (exact integers: the same share)."""
    pts = np.asarray(points, dtype=float)
    pts = pts.reshape(len(pts), -1) if pts.ndim > 1 else pts.reshape(-1, 1)
    size = int(sum(int(np.isfinite(pts[c:c + WINDOW_VERTICES]).sum())
                   for c in range(0, len(pts), WINDOW_VERTICES)))
    if size == 0:
        return None
    candidates = sorted({10.0 ** -d for d in range(2, 10)} | {25.4 * 10.0 ** -d for d in range(4, 11)},
                        reverse=True)
    for q in candidates:
        count, big = 0, False
        for c in range(0, len(pts), WINDOW_VERTICES):
            v = pts[c:c + WINDOW_VERTICES].ravel()
            r = v[np.isfinite(v)] / q
            if r.size and np.abs(r).max() > 1e12:
                big = True
                break
            count += int(np.count_nonzero(np.abs(r - np.round(r)) <= 1e-6))
        if big:
            return None
        if count / size >= QUANTUM_SHARE:
            return q
    return None


def _pad3(a: np.ndarray) -> np.ndarray:
    return a if a.shape[1] == 3 else np.hstack([a, np.zeros((a.shape[0], 3 - a.shape[1]))])


def _clusters(pts: np.ndarray, merge_mm: float) -> np.ndarray:
    """Cluster id per point: a point joins the current cluster while it lies within ``merge_mm``
    of the cluster's first point."""
    step = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    ids = np.zeros(len(pts), dtype=int)
    if np.all(step >= merge_mm):
        ids[:] = np.arange(len(pts))
        return ids
    current, first = 0, pts[0]
    for i in range(1, len(pts)):
        if np.linalg.norm(pts[i] - first) >= merge_mm:
            current += 1
            first = pts[i]
        ids[i] = current
    return ids


def _circle_fit_2d(xy: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Least-squares circle: Kåsa's algebraic fit refined by two Gauss–Newton steps on the
    geometric distances (3×3 normal equations); None if the points are (numerically) collinear."""
    c0 = xy.mean(axis=0)
    p = xy - c0
    scale = np.abs(p).max()
    if scale == 0:
        return None
    x, y = p[:, 0] / scale, p[:, 1] / scale
    z = x * x + y * y
    n = float(len(x))
    sx, sy = x.sum(), y.sum()
    a = np.array([[x @ x, x @ y, sx], [x @ y, y @ y, sy], [sx, sy, n]])
    try:
        sol = np.linalg.solve(a, -np.array([x @ z, y @ z, z.sum()]))
    except np.linalg.LinAlgError:
        return None
    cx, cy = -0.5 * sol[0], -0.5 * sol[1]
    r2 = cx * cx + cy * cy - sol[2]
    if not np.isfinite(r2) or r2 <= 0 or r2 > 1e12:
        return None
    radius = np.sqrt(r2)
    for _ in range(2):
        dx, dy = x - cx, y - cy
        dist = np.sqrt(dx * dx + dy * dy)
        if np.any(dist == 0):
            return None
        jx, jy = -dx / dist, -dy / dist
        res = dist - radius
        jtj = np.array([[jx @ jx, jx @ jy, -jx.sum()], [jx @ jy, jy @ jy, -jy.sum()],
                        [-jx.sum(), -jy.sum(), n]])
        try:
            step = np.linalg.solve(jtj, -np.array([jx @ res, jy @ res, -res.sum()]))
        except np.linalg.LinAlgError:
            break
        cx, cy, radius = cx + step[0], cy + step[1], radius + step[2]
    if not np.isfinite(radius) or radius <= 0:
        return None
    return np.array([cx, cy]) * scale + c0, float(radius * scale)


@dataclass(frozen=True)
class _Fit:
    kappa: float
    center: np.ndarray | None      # 3-D centre of the circle (None for a line)
    axis: np.ndarray               # line direction, or the circle plane's normal


def _fit_run(pts: np.ndarray, tol: float, path_tol: float) -> _Fit | None:
    """A line or a circle through every point of ``pts`` within ``tol``, or None."""
    c0 = pts.mean(axis=0)
    q = pts - c0
    _, vecs = np.linalg.eigh(q.T @ q)          # principal axes, ascending variance
    axis, second, normal = vecs[:, 2], vecs[:, 1], vecs[:, 0]
    along = q @ axis
    off_line = np.linalg.norm(q - along[:, None] * axis, axis=1)
    if off_line.max() <= tol:
        return _Fit(0.0, None, axis)
    if np.abs(q @ normal).max() > tol:
        return None
    xy = np.column_stack([along, q @ second])
    vt = (axis, second)
    fit = _circle_fit_2d(xy)
    if fit is None:
        return None
    center, radius = fit
    if np.abs(np.linalg.norm(xy - center, axis=1) - radius).max() > tol:
        return None
    chords = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    if chords.max() >= 2 * radius:
        return None
    sagitta = radius - np.sqrt(radius * radius - 0.25 * chords * chords)
    if sagitta.max() > path_tol:
        return None
    return _Fit(1.0 / radius, c0 + center[0] * vt[0] + center[1] * vt[1], normal)


class _Runs(NamedTuple):
    """Runs in order (arrays, one entry per run): vertices first..last (inclusive; interiors
    disjoint, a run may start where the previous one ends), κ, circle centre (NaN for a line),
    axis (a line's direction, a circle plane's normal)."""

    first: np.ndarray
    last: np.ndarray
    kappa: np.ndarray
    center: np.ndarray
    axis: np.ndarray


class _Window(NamedTuple):
    """Chords around vertices lo..hi-1 of the reduced path: ``unit``/``chord`` of chords
    c0..c0+len-1 (chord c joins vertices c, c+1), and per vertex the turning angle and the lengths of
    the chords before (``a``) and after (``b``) it (ends: the seam's chords)."""

    c0: int
    unit: np.ndarray
    chord: np.ndarray
    turn: np.ndarray
    a: np.ndarray
    b: np.ndarray


@dataclass(frozen=True, eq=False)
class _Chords:
    """The reduced vertices (m ≥ 2) and what their ends need (the first and last chord, the seam
    of a closed path), from which any window's chords and turning angles are made the same way,
    row by row, as over the whole path."""

    reduced: np.ndarray
    closed: bool
    first_chord: float
    last_chord: float
    first_unit: np.ndarray
    last_unit: np.ndarray

    @property
    def m(self) -> int:
        return len(self.reduced)

    @staticmethod
    def of(reduced: np.ndarray, tol: float) -> _Chords:
        m = len(reduced)
        ends = np.diff(reduced[[0, 1, m - 2, m - 1]], axis=0)[[0, 2]]
        length = np.linalg.norm(ends, axis=1)
        unit = ends / length[:, None]
        closed = m > 3 and np.linalg.norm(reduced[-1] - reduced[0]) <= 2.0 * tol
        return _Chords(reduced, bool(closed), float(length[0]), float(length[1]), unit[0], unit[1])

    def window(self, lo: int, hi: int) -> _Window:
        m = self.m
        c0, c1 = max(lo - 1, 0), min(hi, m - 1)            # chords c0..c1-1 touch vertices lo..hi-1
        vec = np.diff(self.reduced[c0:c1 + 1], axis=0)
        chord = np.linalg.norm(vec, axis=1)
        unit = vec / chord[:, None]
        w = hi - lo
        turn = np.zeros(w)
        a = np.empty(w)
        b = np.empty(w)
        v0, v1 = max(lo, 1), min(hi, m - 1)                 # inner vertices: chords v-1 and v
        turn[v0 - lo:v1 - lo] = _angle(unit[v0 - 1 - c0:v1 - 1 - c0], unit[v0 - c0:v1 - c0])
        a[v0 - lo:] = chord[v0 - 1 - c0:hi - 1 - c0]
        b[:v1 - lo] = chord[lo - c0:v1 - c0]
        if lo == 0:
            a[0] = self.last_chord
        if hi == m:
            b[-1] = self.first_chord
        if self.closed and (lo == 0 or hi == m):
            seam = _angle(self.last_unit, self.first_unit)
            if lo == 0:
                turn[0] = seam
            if hi == m:
                turn[-1] = seam
        return _Window(c0, unit, chord, turn, a, b)

    def turn(self, lo: int, hi: int) -> np.ndarray:
        return self.window(lo, hi).turn


def _tangent_of(axis: np.ndarray, center: np.ndarray, point: np.ndarray, toward: np.ndarray) -> np.ndarray:
    """Unit tangents (row-wise) of fitted runs (line direction or circle normal ``axis``, circle
    ``center``, NaN for a line) at ``point``, oriented along ``toward``."""
    line = np.isnan(center[:, :1])
    t = np.where(line, axis, np.cross(axis, point - np.where(line, 0.0, center)))
    n = np.linalg.norm(t, axis=1)[:, None]
    t = np.where(n > 0, t / np.where(n > 0, n, 1.0), toward)
    return np.where(np.einsum("ij,ij->i", t, toward)[:, None] >= 0, t, -t)


def _run_candidates(pts: np.ndarray, tol: float) -> np.ndarray:
    """Cheap screen (vectorised): can the :data:`MIN_RUN` vertices from i lie on one circle or line
    within ``tol``? Their circumcurvatures (three consecutive points) must agree within what a
    displacement of ``tol`` can change (8·tol/c² for chords c), with a factor 4 of margin."""
    n = len(pts)
    out = np.zeros(n, dtype=bool)
    if n < MIN_RUN:
        return out
    d1 = pts[1:-1] - pts[:-2]
    d2 = pts[2:] - pts[1:-1]
    d3 = pts[2:] - pts[:-2]
    la, lb, lc = (np.linalg.norm(d, axis=1) for d in (d1, d2, d3))
    with np.errstate(divide="ignore", invalid="ignore"):
        k3 = 2.0 * np.linalg.norm(np.cross(d1, d2), axis=1) / (la * lb * lc)
        slack = 4.0 * 8.0 * tol / np.minimum(la, lb) ** 2
    k3 = np.nan_to_num(k3, nan=np.inf, posinf=np.inf)
    w = MIN_RUN - 2                      # circumcurvatures inside a window of MIN_RUN vertices
    size = k3.size - w + 1
    hi, lo, allowed = k3[:size].copy(), k3[:size].copy(), slack[:size].copy()
    for s in range(1, w):                # window max/min by shifted copies (exact, no strided reduce)
        np.maximum(hi, k3[s:s + size], out=hi)
        np.minimum(lo, k3[s:s + size], out=lo)
        np.minimum(allowed, slack[s:s + size], out=allowed)
    with np.errstate(invalid="ignore"):
        spread = hi - lo                 # inf - inf (a reversal): NaN, the full fit decides
    ok = (spread <= allowed) | ~np.isfinite(spread)      # inf - inf: let the full fit decide
    out[:ok.size] = ok
    return out


def _runs(pts: np.ndarray, turn: np.ndarray, tol: float, path_tol: float,
          compiled: bool | None = None) -> _Runs:
    """Maximal runs [i, j] (inclusive vertex indices, consecutive runs may share an end vertex)
    fitted by one line or circle: greedy from the start, galloping then bisecting on j, then
    neighbours merged where one fit covers both. From :data:`COMPILED_MIN_VERTICES` vertices on
    (``compiled`` forces a form) the same search runs as numba-compiled loops
    (:mod:`fuzzyfeed.geometry._polyline_jit`); below, in numpy (no numba import)."""
    maybe = _run_candidates(pts, tol)
    if compiled is None:
        compiled = len(pts) >= COMPILED_MIN_VERTICES
    if compiled:
        return _runs_compiled(pts, turn, maybe, tol, path_tol)
    return _runs_numpy(pts, turn, maybe, tol, path_tol)


@cache
def _runs_kernel():
    """The compiled run search (numba, cached on disk; see :func:`fuzzyfeed.geometry._kernels.compile_once`)."""
    import numba

    from fuzzyfeed.geometry._kernels import compile_once
    from fuzzyfeed.geometry._polyline_jit import find_runs

    f8, i8 = numba.float64, numba.int64
    sig = i8(f8[:, ::1], f8[::1], numba.boolean[::1], f8, f8, i8[:, ::1], i8[::1], f8[:, ::1], i8, i8, i8,
             i8[::1])
    return compile_once(find_runs, sig, "the polyline run search", 10)


def _runs_from(ij: np.ndarray, kind: np.ndarray, fit: np.ndarray) -> _Runs:
    center = np.where(kind[:, None] == 1, np.nan, fit[:, 1:4])
    return _Runs(ij[:, 0].astype(int), ij[:, 1].astype(int), fit[:, 0].copy(), center, fit[:, 4:7].copy())


def _runs_compiled(pts, turn, maybe, tol, path_tol) -> _Runs:
    n = len(pts)
    ij = np.zeros((n, 2), dtype=np.int64)
    kind = np.zeros(n, dtype=np.int64)
    fit = np.zeros((n, 7))
    stop = np.zeros(1, dtype=np.int64)
    count = _runs_kernel()(np.ascontiguousarray(pts, dtype=float), np.ascontiguousarray(turn, dtype=float),
                           np.ascontiguousarray(maybe, dtype=bool), float(tol), float(path_tol), ij, kind, fit,
                           0, 0, n, stop)
    return _runs_from(ij[:count], kind[:count], fit[:count])


def _runs_windowed(geo: _Chords, tol: float, path_tol: float, window: int) -> _Runs:
    """The compiled run search window after window: each window holds ``window`` vertices past the
    vertex the search resumes from (and the last run found, which the next may still merge into);
    the kernel stops before a trial reaching the window's last vertex, so every trial is the one the
    search over the whole sequence makes, and the runs are its runs, bit for bit (a window without
    progress, inside one long run, is doubled)."""
    m = geo.m
    kernel = _runs_kernel()
    done: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    pend = None                  # (ij, kind, fit) of the last run found, global vertex indices
    stop = np.zeros(1, dtype=np.int64)
    i, extra = 0, window
    while i + MIN_RUN - 1 < m:
        carry = pend is not None and int(pend[0][1]) == i
        lo = int(pend[0][0]) if carry else i
        hi = min(m, i + extra)
        pts = np.ascontiguousarray(geo.reduced[lo:hi])
        turn = geo.turn(lo, hi)
        size = (hi - lo) // (MIN_RUN - 1) + 2
        ij = np.zeros((size, 2), dtype=np.int64)
        kind = np.zeros(size, dtype=np.int64)
        fit = np.zeros((size, 7))
        if carry:
            ij[0], kind[0], fit[0] = pend[0] - lo, pend[1], pend[2]
        elif pend is not None:
            done.append((pend[0][None, :], np.array([pend[1]]), pend[2][None, :]))
            pend = None
        limit = hi - lo if hi == m else hi - lo - 1
        count = kernel(pts, turn, _run_candidates(pts, tol), float(tol), float(path_tol), ij, kind, fit,
                       i - lo, int(carry), limit, stop)
        resume = int(stop[0]) + lo
        if resume == i and hi < m:                  # no trial fitted in the window: widen it
            extra *= 2
            continue
        extra = window
        if count:
            done.append((ij[:count - 1] + lo, kind[:count - 1], fit[:count - 1]))
            pend = (ij[count - 1] + lo, int(kind[count - 1]), fit[count - 1].copy())
        i = resume
        if hi == m:
            break
    if pend is not None:
        done.append((pend[0][None, :], np.array([pend[1]]), pend[2][None, :]))
    if not done:
        return _runs_from(np.zeros((0, 2), np.int64), np.zeros(0, np.int64), np.zeros((0, 7)))
    return _runs_from(np.concatenate([d[0] for d in done]), np.concatenate([d[1] for d in done]),
                      np.concatenate([d[2] for d in done]))


def _runs_numpy(pts, turn, maybe, tol, path_tol) -> _Runs:
    n = len(pts)

    def fits(i: int, j: int) -> _Fit | None:
        if j - i + 1 < MIN_RUN or j >= n:
            return None
        if j - i >= 2 and turn[i + 1:j].max() >= np.pi / 2:
            return None
        return _fit_run(pts[i:j + 1], tol, path_tol)

    runs: list[tuple[int, int, _Fit]] = []
    i = 0
    while i + MIN_RUN - 1 < n:
        good_j = i + MIN_RUN - 1
        fit = fits(i, good_j) if maybe[i] else None
        if fit is None:
            i += 1
            continue
        step, bad_j = MIN_RUN, None
        while good_j < n - 1:
            j = min(good_j + step, n - 1)
            f = fits(i, j)
            if f is None:
                bad_j = j
                break
            good_j, fit = j, f
            step *= 2
        if bad_j is not None:
            lo, hi = good_j, bad_j
            while hi - lo > 1:
                mid = (lo + hi) // 2
                f = fits(i, mid)
                if f is None:
                    hi = mid
                else:
                    lo, fit = mid, f
            good_j = lo
        runs.append((i, good_j, fit))
        i = good_j
        if i >= n - 1:
            break
    merged: list[tuple[int, int, _Fit]] = []
    for run in runs:
        if merged and merged[-1][1] == run[0]:
            f = fits(merged[-1][0], run[1])
            if f is not None:
                merged[-1] = (merged[-1][0], run[1], f)
                continue
        merged.append(run)
    return _Runs(np.array([r[0] for r in merged], dtype=int), np.array([r[1] for r in merged], dtype=int),
                 np.array([r[2].kappa for r in merged], dtype=float),
                 np.array([np.full(3, np.nan) if r[2].center is None else r[2].center for r in merged],
                          dtype=float).reshape(-1, 3),
                 np.array([r[2].axis for r in merged], dtype=float).reshape(-1, 3))


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


def _angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle between unit vectors, row-wise (atan2 form, accurate near 0 and π)."""
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.einsum("...i,...i->...", u, v))


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
    pts3 = _pad3(raw)
    ids, reduced = _reduce(pts3, 0.1 * path_tol)
    m = len(reduced)
    if m == 1:   # the whole path lies within the merge distance: a point
        tangent = np.zeros((len(raw), 3))
        tangent[:, 0] = 1.0
        return PolylineCurvature(np.zeros(len(raw)), tangent, np.zeros(len(raw), bool), tol,
                                 path_tol, quantum)
    geo = _Chords.of(reduced, tol)
    if tolerance_mm is None and quantum is None:
        w = geo.window(0, m)
        kappa, corner = _exact_curvature(reduced, w.turn, geo.closed, path_tol, extent)
        return _result(kappa, corner, _tangents(geo, 0, m, w), ids, tol, path_tol, quantum)
    if m <= window:
        w = geo.window(0, m)
        runs = _runs(reduced, w.turn, FIT_SLACK * tol, path_tol)
    else:
        runs = _runs_windowed(geo, FIT_SLACK * tol, path_tol, window)
    kappa = np.empty(m)
    corner = np.empty(m, dtype=bool)
    tangent = np.empty((m, 3))
    whole = _RunContext.of(geo, runs, tol)
    carry = 0.0
    for lo in range(0, m, window):
        hi = min(lo + window, m)
        w = geo.window(lo, hi)
        s, carry = _arc_lengths(w, lo, hi, carry)
        kappa[lo:hi], corner[lo:hi] = _vertex_pass(geo, whole, lo, hi, w, s, tol, path_tol)
        tangent[lo:hi] = _tangents(geo, lo, hi, w)
    return _result(kappa, corner, tangent, ids, tol, path_tol, quantum)


def _reduce(pts3: np.ndarray, merge_mm: float) -> tuple[np.ndarray | None, np.ndarray]:
    """Cluster ids (None: every point its own vertex) and the vertices (cluster means; see
    :func:`_clusters`). Without a cluster the vertices are the points (+ 0.0, as the means' sums
    make -0.0)."""
    n = len(pts3)
    merges = any(bool((np.linalg.norm(np.diff(pts3[c:c + WINDOW_VERTICES + 1], axis=0), axis=1) < merge_mm).any())
                 for c in range(0, n - 1, WINDOW_VERTICES))
    if not merges:
        return None, pts3 + 0.0
    ids = _clusters(pts3, merge_mm)
    m = int(ids[-1]) + 1
    counts = np.bincount(ids, minlength=m).astype(float)
    reduced = np.column_stack([np.bincount(ids, weights=pts3[:, k], minlength=m) for k in range(3)])
    reduced /= counts[:, None]
    return ids, reduced


class _RunContext(NamedTuple):
    """What the per-vertex pass needs of the runs beyond its window: each meet's tangent break
    (angle between the fitted tangents, thresholded like any vertex's turn), the seam's, and the
    chains of smooth arc runs with their middles' arc length (s summed chord after chord from the
    path's start, as one cumulative sum)."""

    runs: _Runs
    meet_theta: np.ndarray          # (R-1,) at vertex last[r] == first[r+1] (else unused)
    seam_theta: float | None        # a closed path whose seam joins two runs
    chains: np.ndarray              # (C, 2) run ranges c0..c1-1 of the smooth chains (> 1 run)
    mids: np.ndarray                # (R,) s at each run's middle

    @staticmethod
    def of(geo: _Chords, runs: _Runs, tol: float) -> _RunContext:
        first, last, k = runs.first, runs.last, runs.kappa
        count = first.size
        meet_theta = np.zeros(max(count - 1, 0))
        seam = None
        if count:
            meet = np.flatnonzero(last[:-1] == first[1:])
            v = first[meet + 1]
            vec_in = geo.reduced[v] - geo.reduced[v - 1]
            vec_out = geo.reduced[v + 1] - geo.reduced[v]
            len_in, len_out = np.linalg.norm(vec_in, axis=1), np.linalg.norm(vec_out, axis=1)
            u_in, u_out = vec_in / len_in[:, None], vec_out / len_out[:, None]
            axis, center = runs.axis, runs.center
            t_in = _tangent_of(axis[meet], center[meet], geo.reduced[v], u_in)
            t_out = _tangent_of(axis[meet + 1], center[meet + 1], geo.reduced[v], u_out)
            theta = _angle(t_in, t_out)
            noise = tol * FIT_SLACK * (1.0 / len_in + 1.0 / len_out)
            meet_theta[meet] = np.where(theta > noise, theta, 0.0)
            m = geo.m
            if geo.closed and first[0] == 0 and last[-1] == m - 1:   # the seam joins two runs
                t_in = _tangent_of(axis[-1:], center[-1:], geo.reduced[-1:], geo.last_unit[None, :])
                t_out = _tangent_of(axis[:1], center[:1], geo.reduced[:1], geo.first_unit[None, :])
                seam = float(_angle(t_in, t_out)[0])
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
                s_first, s_last = _arc_length_at(geo, first), _arc_length_at(geo, last)
                mids = (s_first + s_last) / 2
        return _RunContext(runs, meet_theta, seam, chains, mids)


def _arc_lengths(w: _Window, lo: int, hi: int, carry: float) -> tuple[np.ndarray, float]:
    """s = Σ chords from vertex 0 at vertices lo..hi-1 of window ``w``, ``carry`` being s at lo - 1:
    one cumulative sum carried from window to window (each partial sum the same float as in one
    cumsum over the whole path); and s at hi - 1."""
    if lo == 0:
        s = np.cumsum(np.concatenate([[0.0], w.chord[:hi - 1]]))
    else:
        s = np.cumsum(np.concatenate([[carry], w.chord[:hi - lo]]))[1:]
    return s, float(s[-1])


def _arc_length_at(geo: _Chords, at: np.ndarray) -> np.ndarray:
    """s at the (sorted) vertices ``at`` (:func:`_arc_lengths` window after window)."""
    out = np.empty(at.size)
    carry = 0.0
    for lo in range(0, geo.m, WINDOW_VERTICES):
        hi = min(lo + WINDOW_VERTICES, geo.m)
        s, carry = _arc_lengths(geo.window(lo, hi), lo, hi, carry)
        sel = slice(np.searchsorted(at, lo), np.searchsorted(at, hi))
        out[sel] = s[at[sel] - lo]
    return out


def _vertex_pass(geo: _Chords, ctx: _RunContext, lo: int, hi: int, w: _Window, s: np.ndarray, tol: float,
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


def _tangents(geo: _Chords, lo: int, hi: int, w: _Window) -> np.ndarray:
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
