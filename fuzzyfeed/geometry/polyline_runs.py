"""The run search of the polyline curvature (:mod:`fuzzyfeed.geometry.polyline`, step 3): maximal runs
of ≥ :data:`MIN_RUN` vertices that one straight line or one circle passes within the tolerance of.

A line is the points' principal axis; a circle is Kåsa's algebraic fit refined by Gauss–Newton
steps on the geometric distances, in the points' plane (planar within the tolerance for 3-D
points). A run may not turn by 90° or more at a vertex, and every chord's sagitta on its circle
r − √(r² − c²/4) must be ≤ P.

The search is greedy: from a start vertex (screened by the spread of its circumcurvatures,
:func:`_run_candidates`) the run's end is found by galloping then bisecting on the vertex count,
and neighbouring runs are merged where one fit covers both. Each candidate run costs one
line/circle fit; from :data:`COMPILED_MIN_VERTICES` vertices on these fits run as numba-compiled
scalar loops (:mod:`fuzzyfeed.geometry._polyline_jit`, cached on disk like the other kernels,
:mod:`fuzzyfeed.geometry._kernels`), below in numpy without importing numba. Both forms run the
same search; their sums run in another order, so on a near-straight stretch whose fit residual
equals the tolerance to the last bits they can cut the runs differently (both within the
tolerance of the points).

A sequence longer than a window is searched window after window (:func:`line_arc_runs_windowed`):
the compiled search stops before any trial that would reach a window's last vertex and resumes in
the next window from where it stopped, the last run found carried (the next may merge into it), so
each of its trials is one the whole search makes and the runs are the whole search's, bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from typing import NamedTuple

import numpy as np
from numpy.linalg import _umath_linalg

from fuzzyfeed.geometry.polyline_chords import Chords

#: Fewest vertices a line/circle run must have to be taken as one (three points fit any circle).
MIN_RUN = 5
#: A run's fit may miss a point by this factor times the rounding tolerance (least squares is not
#: the minimax fit).
FIT_SLACK = 1.5
#: Vertices (after merging tiny moves) from which the run search runs numba-compiled (~0.1 s per
#: 10⁵ vertices): importing numba and LAPACK and loading the cached kernel costs ~1 s of CPU once
#: per process, what the numpy form (~0.3 ms per vertex on short runs) spends on ~4000 vertices.
COMPILED_MIN_VERTICES = 4096


def _lapack_error(message: str):
    def raise_it(err, flag):
        raise np.linalg.LinAlgError(message)
    return raise_it


_sum = np.add.reduce      # ``a.sum(axis)``, ``a.mean(axis)·n`` and ``norm(a, axis)²`` are this reduce
_LAPACK_STATE = dict(invalid="call", over="ignore", divide="ignore", under="ignore")   # np.linalg's


def _lapack_errstate(message: str):
    """``np.errstate(call=<raise LinAlgError(message)>, **_LAPACK_STATE)`` as np.linalg enters it around
    its LAPACK gufuncs (the gufunc flags 'invalid' on a singular matrix or no convergence), made once:
    ``(set, reset)`` of numpy's error-state context variable with that state, which is what entering
    the errstate does (~4 µs a time on a loaded machine, ~0.3 µs so); np.errstate where numpy lacks them."""
    try:
        from numpy._core._ufunc_config import _extobj_contextvar, _make_extobj
    except ImportError:                                                   # pragma: no cover
        def enter():
            state = np.errstate(call=_lapack_error(message), **_LAPACK_STATE)
            state.__enter__()
            return state
        return enter, lambda state: state.__exit__(None, None, None)
    state = _make_extobj(call=_lapack_error(message), **_LAPACK_STATE)
    return (lambda: _extobj_contextvar.set(state)), _extobj_contextvar.reset


_SINGULAR = _lapack_errstate("Singular matrix")
_NOT_CONVERGED = _lapack_errstate("Eigenvalues did not converge")


def _solve3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.linalg.solve(a, b)`` for a 3×3 ``a`` and a 3-vector ``b``: the same LAPACK gufunc under the same
    error state (LinAlgError when singular), without the wrapper's checks and conversions."""
    enter, leave = _SINGULAR
    token = enter()
    try:
        return _umath_linalg.solve1(a, b, signature="dd->d")
    finally:
        leave(token)


def _eigh_vectors(a: np.ndarray) -> np.ndarray:
    """The eigenvectors of ``np.linalg.eigh(a)`` (columns, ascending eigenvalues) for a real symmetric
    ``a``: the same LAPACK gufunc under the same error state, without the wrapper."""
    enter, leave = _NOT_CONVERGED
    token = enter()
    try:
        return _umath_linalg.eigh_lo(a, signature="d->dd")[1]
    finally:
        leave(token)


def _circle_fit_2d(xy: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Least-squares circle: Kåsa's algebraic fit refined by two Gauss–Newton steps on the
    geometric distances (3×3 normal equations); None if the points are (numerically) collinear.

    Costs ~100 small numpy calls per candidate run, the run search's time: rows x, y (and z = x² + y²,
    then the Jacobian and residuals) share one array so their sums are one reduce, scalars are Python
    floats; every float is the one of the plain form (``a.dot(b)`` is ``a @ b``'s BLAS call, reduces
    run over the same rows in the same order, the same LAPACK calls), pinned by
    ``tests/test_polyline_runs_fit.py``."""
    n = len(xy)
    c0 = _sum(xy, axis=0) / n
    p = xy - c0
    scale = np.abs(p).max()
    if scale == 0:
        return None
    rows = np.empty((3, n))                       # x, y, z
    np.divide(p.T, scale, out=rows[:2])
    sq = rows[:2] * rows[:2]
    np.add(sq[0], sq[1], out=rows[2])
    x, y, z = rows
    sx, sy, sz = _sum(rows, axis=1).tolist()
    xy_ = x.dot(y)
    a = np.array([[x.dot(x), xy_, sx], [xy_, y.dot(y), sy], [sx, sy, float(n)]])
    try:
        sol = _solve3(a, -np.array([x.dot(z), y.dot(z), sz]))
    except np.linalg.LinAlgError:
        return None
    s0, s1, s2 = sol.tolist()
    cx, cy = -0.5 * s0, -0.5 * s1
    r2 = cx * cx + cy * cy - s2
    if not math.isfinite(r2) or r2 <= 0 or r2 > 1e12:
        return None
    radius = math.sqrt(r2)
    jac = np.empty((3, n))                        # ∂dist/∂cx, ∂dist/∂cy, residual dist − r
    jx, jy, res = jac
    for _ in range(2):
        d = rows[:2] - np.array([[cx], [cy]])
        dd = d * d
        dist = np.sqrt(dd[0] + dd[1])
        if dist.min() == 0:                   # any(dist == 0): dist ≥ 0
            return None
        np.divide(np.negative(d), dist, out=jac[:2])
        np.subtract(dist, radius, out=res)
        sjx, sjy, sres = _sum(jac, axis=1).tolist()
        jxy = jx.dot(jy)
        jtj = np.array([[jx.dot(jx), jxy, -sjx], [jxy, jy.dot(jy), -sjy], [-sjx, -sjy, float(n)]])
        try:
            step = _solve3(jtj, -np.array([jx.dot(res), jy.dot(res), -sres]))
        except np.linalg.LinAlgError:
            break
        t0, t1, t2 = step.tolist()
        cx, cy, radius = cx + t0, cy + t1, radius + t2
    if not math.isfinite(radius) or radius <= 0:
        return None
    return np.array([cx, cy]) * scale + c0, float(radius * scale)


@dataclass(frozen=True)
class _Fit:
    kappa: float
    center: np.ndarray | None      # 3-D centre of the circle (None for a line)
    axis: np.ndarray               # line direction, or the circle plane's normal


def _fit_run(pts: np.ndarray, tol: float, path_tol: float) -> _Fit | None:
    """A line or a circle through every point of ``pts`` within ``tol``, or None. Rounded √, ·², and
    r − √(r² − c²/4) are monotone, so the largest distance off the line, farthest |dist − r| and
    largest sagitta are those of the largest (or smallest) square: one √ each, the same floats."""
    n = len(pts)
    c0 = _sum(pts, axis=0) / n
    q = pts - c0
    vecs = _eigh_vectors(q.T.dot(q))               # principal axes, ascending variance
    axis, second, normal = vecs[:, 2], vecs[:, 1], vecs[:, 0]
    along = q.dot(axis)
    off = q - along[:, None] * axis
    if math.sqrt(_sum(off * off, axis=1).max()) <= tol:
        return _Fit(0.0, None, axis)
    if np.abs(q.dot(normal)).max() > tol:
        return None
    xy = np.empty((n, 2))
    xy[:, 0] = along
    xy[:, 1] = q.dot(second)
    fit = _circle_fit_2d(xy)
    if fit is None:
        return None
    center, radius = fit
    d = xy - center
    dist2 = _sum(d * d, axis=1)
    if max(math.sqrt(dist2.max()) - radius, radius - math.sqrt(dist2.min())) > tol:
        return None
    e = xy[1:] - xy[:-1]
    chord = math.sqrt(_sum(e * e, axis=1).max())
    if chord >= 2 * radius:
        return None
    if radius - math.sqrt(radius * radius - 0.25 * chord * chord) > path_tol:
        return None
    return _Fit(1.0 / radius, c0 + center[0] * axis + center[1] * second, normal)


class Runs(NamedTuple):
    """Runs in order (arrays, one entry per run): vertices first..last (inclusive; interiors
    disjoint, a run may start where the previous one ends), κ, circle centre (NaN for a line),
    axis (a line's direction, a circle plane's normal)."""

    first: np.ndarray
    last: np.ndarray
    kappa: np.ndarray
    center: np.ndarray
    axis: np.ndarray


def tangent_of(axis: np.ndarray, center: np.ndarray, point: np.ndarray, toward: np.ndarray) -> np.ndarray:
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


def line_arc_runs(pts: np.ndarray, turn: np.ndarray, tol: float, path_tol: float,
          compiled: bool | None = None) -> Runs:
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
def run_search_kernel():
    """The compiled run search (numba, cached on disk; see :func:`fuzzyfeed.geometry._kernels.compile_once`)."""
    import numba

    from fuzzyfeed.geometry._kernels import compile_once
    from fuzzyfeed.geometry._polyline_jit import find_runs

    f8, i8 = numba.float64, numba.int64
    sig = i8(f8[:, ::1], f8[::1], numba.boolean[::1], f8, f8, i8[:, ::1], i8[::1], f8[:, ::1], i8, i8, i8,
             i8[::1])
    return compile_once(find_runs, sig, "the polyline run search", 10)


def _runs_from(ij: np.ndarray, kind: np.ndarray, fit: np.ndarray) -> Runs:
    center = np.where(kind[:, None] == 1, np.nan, fit[:, 1:4])
    return Runs(ij[:, 0].astype(int), ij[:, 1].astype(int), fit[:, 0].copy(), center, fit[:, 4:7].copy())


def _runs_compiled(pts, turn, maybe, tol, path_tol) -> Runs:
    n = len(pts)
    ij = np.zeros((n, 2), dtype=np.int64)
    kind = np.zeros(n, dtype=np.int64)
    fit = np.zeros((n, 7))
    stop = np.zeros(1, dtype=np.int64)
    count = run_search_kernel()(np.ascontiguousarray(pts, dtype=float), np.ascontiguousarray(turn, dtype=float),
                           np.ascontiguousarray(maybe, dtype=bool), float(tol), float(path_tol), ij, kind, fit,
                           0, 0, n, stop)
    return _runs_from(ij[:count], kind[:count], fit[:count])


def line_arc_runs_windowed(geo: Chords, tol: float, path_tol: float, window: int) -> Runs:
    """The compiled run search window after window: each window holds ``window`` vertices past the
    vertex the search resumes from (and the last run found, which the next may still merge into);
    the kernel stops before a trial reaching the window's last vertex, so every trial is the one the
    search over the whole sequence makes, and the runs are its runs, bit for bit (a window without
    progress, inside one long run, is doubled)."""
    done = [(ij, kind, fit) for ij, kind, fit, _ in windowed_run_blocks(geo, tol, path_tol, window)]
    return _runs_from(np.concatenate([d[0] for d in done]), np.concatenate([d[1] for d in done]),
                      np.concatenate([d[2] for d in done]))


def runs_of_block(ij: np.ndarray, kind: np.ndarray, fit: np.ndarray) -> Runs:
    """A block of :func:`windowed_run_blocks` as :class:`Runs`."""
    return _runs_from(ij, kind, fit)


def windowed_run_blocks(geo, tol: float, path_tol: float, window: int):
    """:func:`line_arc_runs_windowed` as it goes: yields ``(ij, kind, fit, low)`` per window — the
    runs found final there (global vertex indices; the last run is held back while the next may
    merge into it) and the lowest vertex the search may still read (``geo.vertices(a, b)`` is asked
    for a ≥ low only, b rising window after window). The last block holds the last run."""
    m = geo.m
    kernel = run_search_kernel()
    pend = None                  # (ij, kind, fit) of the last run found, global vertex indices
    stop = np.zeros(1, dtype=np.int64)
    empty = (np.zeros((0, 2), np.int64), np.zeros(0, np.int64), np.zeros((0, 7)))
    i, extra = 0, window
    while i + MIN_RUN - 1 < m:
        out = []
        carry = pend is not None and int(pend[0][1]) == i
        lo = int(pend[0][0]) if carry else i
        hi = min(m, i + extra)
        pts = np.ascontiguousarray(geo.vertices(lo, hi))
        turn = geo.turn(lo, hi)
        size = (hi - lo) // (MIN_RUN - 1) + 2
        ij = np.zeros((size, 2), dtype=np.int64)
        kind = np.zeros(size, dtype=np.int64)
        fit = np.zeros((size, 7))
        if carry:
            ij[0], kind[0], fit[0] = pend[0] - lo, pend[1], pend[2]
        elif pend is not None:
            out.append((pend[0][None, :], np.array([pend[1]]), pend[2][None, :]))
            pend = None
        limit = hi - lo if hi == m else hi - lo - 1
        count = kernel(pts, turn, _run_candidates(pts, tol), float(tol), float(path_tol), ij, kind, fit,
                       i - lo, int(carry), limit, stop)
        resume = int(stop[0]) + lo
        if resume == i and hi < m:                  # no trial fitted in the window: widen it
            extra *= 2
            if out:
                yield (*out[0], lo)
            continue
        extra = window
        if count:
            out.append((ij[:count - 1] + lo, kind[:count - 1], fit[:count - 1]))
            pend = (ij[count - 1] + lo, int(kind[count - 1]), fit[count - 1].copy())
        i = resume
        low = min(int(pend[0][0]), i) if pend is not None else i
        block = tuple(np.concatenate([o[k] for o in out]) for k in range(3)) if out else empty
        yield (*block, low)
        if hi == m:
            break
    if pend is not None:
        yield pend[0][None, :], np.array([pend[1]]), pend[2][None, :], m
    else:
        yield (*empty, m)


def _runs_numpy(pts, turn, maybe, tol, path_tol) -> Runs:
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
    return Runs(np.array([r[0] for r in merged], dtype=int), np.array([r[1] for r in merged], dtype=int),
                 np.array([r[2].kappa for r in merged], dtype=float),
                 np.array([np.full(3, np.nan) if r[2].center is None else r[2].center for r in merged],
                          dtype=float).reshape(-1, 3),
                 np.array([r[2].axis for r in merged], dtype=float).reshape(-1, 3))
