"""The polyline curvature of a point sequence given in chunks (:func:`fit_chunks`), its memory bounded
by a window of vertices (and the longest run), not by the sequence: a cut of 10⁶ G1 moves read from
its file a window of lines at a time.

:func:`fuzzyfeed.geometry.polyline.polyline_curvature` takes four values over the whole sequence and
then already works window by window. Here the sequence is read three times from its source
(``chunks()``, called once per pass, the same points each time):

1. **Scan.** The checks (shape, finite), the rounding quantum's counts (integers per candidate,
   :func:`~fuzzyfeed.geometry.polyline.quantum_counts`: summed, the same share), the extent (each
   axis's min and max: ptp exactly) and whether any step is under the merge distance P/10 (each step
   the same row-wise norm, the step across a chunk boundary included).
2. **Vertices.** The tiny moves merged as :func:`~fuzzyfeed.geometry.polyline_chords.merge_tiny_moves`
   merges them (the same per-point loop, its cluster and first point carried; a cluster's sum starts
   from the sum carried over the boundary, so its additions run in the same order): the vertex count
   m and the first and last two vertices (the path's ends and whether it is closed).
3. **Fit.** The vertices again, into a buffer that holds what the run search
   (:func:`~fuzzyfeed.geometry.polyline_runs.windowed_run_blocks`, resumable) and the per-vertex pass
   still read, with s summed as one cumulative sum. Each window of vertices lo..hi-1 waits for the
   first final run starting at or after hi, and runs its per-vertex pass with the runs touching it
   and one more on each side: a meet's tangent break is the pair's own, and a smooth chain's κ at a
   vertex of run r is interpolated between the middles of runs r-1, r, r+1 (its s lies between
   them), so the chain cut at those runs gives the same κ; a chain's ends beyond them lie outside
   the window. Each window's κ, tangents and corners go out per point.

So the result is :func:`~fuzzyfeed.geometry.polyline.polyline_curvature`'s bit for bit (the tests
hold it to that). Where the window would not bound the memory the sequence is fitted whole, as
before (``bounded`` False): m within one window, one vertex, full-precision points (no quantum, no
tolerance given: :func:`~fuzzyfeed.geometry.polyline._exact_curvature` groups equal circles over
the whole path), a closed path (the seam joins the first and the last run).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.geometry.polyline import (DEFAULT_PATH_TOLERANCE_MM, QUANTUM_CANDIDATES, TOLERANCES, _RunContext,
                                         _tangents, _vertex_pass, polyline_curvature, quantum_counts,
                                         quantum_of_counts)
from fuzzyfeed.geometry.polyline_chords import (WINDOW_VERTICES, Chords, arc_lengths, chord_window, cluster_ids,
                                                pad3)
from fuzzyfeed.geometry.polyline_runs import FIT_SLACK, Runs, runs_of_block, windowed_run_blocks

Chunks = Callable[[], Iterable[np.ndarray]]
#: Runs beyond those touching a window that its per-vertex pass sees on each side (module docstring).
NEAR_RUNS = 1


@dataclass(frozen=True, eq=False)
class StreamedFit:
    """The fit of a point sequence given in chunks: its figures (``n`` points, ``m`` vertices, the
    tolerances used, mm) and :meth:`pieces`, the per-point κ, tangent and corner flag in order;
    ``bounded`` False where it is made whole (module docstring)."""

    n: int
    m: int
    tolerance_mm: float
    path_tolerance_mm: float
    quantum_mm: float | None
    bounded: bool
    _chunks: Chunks
    _window: int
    _given: tuple
    _merges: bool
    _ends: np.ndarray

    def pieces(self, chunks: Chunks | None = None) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """(κ, tangent (k, 3), corner) of consecutive points, in order, all n of them; ``chunks``: the
        same points from another source (a read that serves the caller too)."""
        chunks = self._chunks if chunks is None else chunks
        if not self.bounded:
            pts = np.concatenate([np.asarray(c, dtype=float) for c in chunks() if len(c)])
            fit = polyline_curvature(pts, *self._given, window=self._window)
            yield fit.curvature, fit.tangent, fit.corner
            return
        yield from _fit_pieces(self, chunks)


def fit_chunks(chunks: Chunks, tolerance_mm: float | None = None, path_tolerance_mm: float | None = None,
               window: int = WINDOW_VERTICES) -> StreamedFit:
    """:func:`~fuzzyfeed.geometry.polyline.polyline_curvature` of the points that ``chunks()`` yields
    (arrays (k, 2) or (k, 3); called once per pass, the same points each time): passes 1 and 2 of
    the module docstring here, pass 3 as :meth:`StreamedFit.pieces` is consumed."""
    given_tol, given_path = TOLERANCES.get()
    tolerance_mm = given_tol if tolerance_mm is None else tolerance_mm
    path_tolerance_mm = given_path if path_tolerance_mm is None else path_tolerance_mm
    path_tol = DEFAULT_PATH_TOLERANCE_MM if path_tolerance_mm is None else float(path_tolerance_mm)
    n, dim, bad, lo, hi, size, count, big, merges = _scan(chunks, tolerance_mm is None, 0.1 * path_tol)
    if n < 2 or dim not in (2, 3):
        raise InputError(f"points: shape ({n}, {dim}); need at least 2 points of 2 or 3 coordinates")
    if bad is not None:
        raise InputError(f"points[{bad[0]}] = {bad[1]}; coordinates must be finite")
    if not np.isfinite(path_tol) or path_tol <= 0:
        raise InputError(f"path_tolerance_mm = {path_tolerance_mm!r}; must be finite and > 0")
    extent = float((hi - lo).max())
    quantum = None
    if tolerance_mm is None:
        quantum = quantum_of_counts(size, count, big)
        tol = 0.5 * quantum * np.sqrt(dim) if quantum is not None else 0.0
    else:
        tol = float(tolerance_mm)
        if not np.isfinite(tol) or tol < 0:
            raise InputError(f"tolerance_mm = {tolerance_mm!r}; must be finite and >= 0")
    tol = max(tol, 1e-9 * max(1.0, extent))
    m, ends = _vertex_ends(chunks, merges, 0.1 * path_tol)
    bounded = (m > max(int(window), 4) and not (tolerance_mm is None and quantum is None)
               and not Chords.of(ends, tol).closed)
    return StreamedFit(n, m, tol, path_tol, quantum, bool(bounded), chunks, int(window),
                       (tolerance_mm, path_tolerance_mm), merges, ends)


def _scan(chunks: Chunks, want_quantum: bool, merge_mm: float):
    """Pass 1 (module docstring)."""
    k = len(QUANTUM_CANDIDATES)
    n, dim, bad, size = 0, None, None, 0
    count, big = np.zeros(k, dtype=np.int64), np.zeros(k, dtype=bool)
    lo = hi = None
    merges, last = False, None
    for chunk in chunks():
        raw = np.asarray(chunk, dtype=float)
        if raw.ndim != 2 or raw.shape[1] not in (2, 3) or (dim is not None and raw.shape[1] != dim):
            raise InputError(f"points: a chunk of shape {raw.shape} after {n} points of {dim} coordinates; "
                             "need points of 2 or 3 coordinates")
        if not len(raw):
            continue
        dim = raw.shape[1]
        finite = np.isfinite(raw).all(axis=1)
        if bad is None and not finite.all():
            i = int(np.argmin(finite))
            bad = (n + i, raw[i].tolist())
        if want_quantum:
            s, c, b = quantum_counts(raw)
            size, count, big = size + s, count + c, big | b
        lo = raw.min(axis=0) if lo is None else np.minimum(lo, raw.min(axis=0))
        hi = raw.max(axis=0) if hi is None else np.maximum(hi, raw.max(axis=0))
        if not merges and bad is None:
            pts = pad3(raw)
            both = pts if last is None else np.vstack([last, pts])
            merges = bool((np.linalg.norm(np.diff(both, axis=0), axis=1) < merge_mm).any())
            last = pts[-1:]
        n += len(raw)
    return n, dim, bad, lo, hi, size, count, big, merges


def _vertex_blocks(chunks: Chunks, merges: bool, merge_mm: float) -> Iterator[tuple[np.ndarray | None, np.ndarray]]:
    """The reduced vertices chunk after chunk: (each point's vertex, None when every point is one;
    the vertices completed by the chunk), as :func:`~fuzzyfeed.geometry.polyline_chords.merge_tiny_moves`
    makes them (module docstring, pass 2)."""
    if not merges:
        for chunk in chunks():
            if len(chunk):
                yield None, pad3(np.asarray(chunk, dtype=float)) + 0.0
        return
    current, first = 0, None
    psum, pcount = np.zeros(3), 0.0        # the open cluster's sums (from 0.0, as bincount starts)
    for chunk in chunks():
        if not len(chunk):
            continue
        pts = pad3(np.asarray(chunk, dtype=float))
        open_id = current
        ids, current, first = cluster_ids(pts, merge_mm, current, first)
        local = np.concatenate([[0], ids - open_id])
        counts = np.bincount(local, weights=np.concatenate([[pcount], np.ones(len(pts))]))
        sums = np.column_stack([np.bincount(local, weights=np.concatenate([[psum[c]], pts[:, c]]))
                                for c in range(3)])
        psum, pcount = sums[-1].copy(), float(counts[-1])
        yield ids, sums[:-1] / counts[:-1, None]
    yield np.zeros(0, dtype=np.int64), (psum / pcount)[None, :]


def _vertex_ends(chunks: Chunks, merges: bool, merge_mm: float) -> tuple[int, np.ndarray]:
    """Pass 2: the vertex count and the first two and last two vertices."""
    m, head, tail = 0, [], np.zeros((0, 3))
    for _, v in _vertex_blocks(chunks, merges, merge_mm):
        if len(head) < 2:
            head.extend(v[:2 - len(head)])
        tail = np.vstack([tail, v[-2:]])[-2:]
        m += len(v)
    if m < 2:
        return m, np.zeros((4, 3))
    return m, np.vstack([head[0], head[1], tail[0], tail[1]])


class _StreamChords:
    """The reduced vertices as :class:`~fuzzyfeed.geometry.polyline_chords.Chords` serves them, from
    a buffer filled forward from the vertex blocks and released from behind; s at every buffered
    vertex (one cumulative sum from vertex 0, as :func:`~fuzzyfeed.geometry.polyline_chords.arc_lengths`)."""

    def __init__(self, m: int, ends: np.ndarray, tol: float, blocks: Iterator[np.ndarray]):
        e = Chords.of(ends, tol)
        self.m, self.closed = m, e.closed
        self.first_chord, self.last_chord, self.first_unit, self.last_unit = \
            e.first_chord, e.last_chord, e.first_unit, e.last_unit
        self._blocks = blocks
        self._b0 = 0
        self._v = np.zeros((0, 3))
        self._s = np.zeros(0)
        self._last = None             # (vertex, s) of the last vertex read

    def _fill(self, b: int) -> None:
        vs, ss = [self._v], [self._s]
        have = self._b0 + len(self._v)
        while have < b:
            v = next(self._blocks)
            if not len(v):
                continue
            if self._last is None:
                ch = np.linalg.norm(np.diff(v, axis=0), axis=1)
                s = np.cumsum(np.concatenate([[0.0], ch]))
            else:
                ch = np.linalg.norm(np.diff(np.vstack([self._last[0], v]), axis=0), axis=1)
                s = np.cumsum(np.concatenate([[self._last[1]], ch]))[1:]
            self._last = (v[-1:], float(s[-1]))
            vs.append(v)
            ss.append(s)
            have += len(v)
        if len(vs) > 1:
            self._v, self._s = np.concatenate(vs), np.concatenate(ss)

    def release(self, a: int) -> None:
        """Vertices before ``a`` are not read again."""
        if a > self._b0:
            cut = min(a - self._b0, len(self._v))
            self._v, self._s = self._v[cut:].copy(), self._s[cut:].copy()
            self._b0 += cut

    def vertices(self, a: int, b: int) -> np.ndarray:
        self._fill(b)
        if a < self._b0:
            raise AssertionError(f"vertex {a} released (buffer from {self._b0})")
        return self._v[a - self._b0:b - self._b0]

    def at(self, idx: np.ndarray) -> np.ndarray:
        idx = np.asarray(idx)
        if idx.size:
            self.vertices(int(idx.min()), int(idx.max()) + 1)
        return self._v[idx - self._b0]

    def s_at(self, idx: np.ndarray) -> np.ndarray:
        self.at(idx)
        return self._s[np.asarray(idx) - self._b0]

    def window(self, lo: int, hi: int):
        return chord_window(self, lo, hi)

    def turn(self, lo: int, hi: int) -> np.ndarray:
        return self.window(lo, hi).turn


def _fit_pieces(fit: StreamedFit, chunks: Chunks) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Pass 3 (module docstring)."""
    merge_mm = 0.1 * fit.path_tolerance_mm
    point_ids: deque = deque()

    def vertices():
        for ids, v in _vertex_blocks(chunks, fit._merges, merge_mm):
            if ids is not None and ids.size:
                point_ids.append(ids)
            yield v

    m = fit.m
    geo = _StreamChords(m, fit._ends, fit.tolerance_mm, vertices())
    tol, path_tol, window = fit.tolerance_mm, fit.path_tolerance_mm, fit._window
    search = windowed_run_blocks(geo, FIT_SLACK * tol, path_tol, window)
    runs = runs_of_block(np.zeros((0, 2), np.int64), np.zeros(0, np.int64), np.zeros((0, 7)))
    searching, low = True, 0
    carry = 0.0
    for lo in range(0, m, window):
        hi = min(lo + window, m)
        while searching and not (runs.first.size and runs.first[-1] >= hi):
            try:
                ij, kind, fr, low = next(search)
            except StopIteration:
                searching = False
                break
            if ij.size:
                runs = Runs(*(np.concatenate([a, b]) for a, b in zip(runs, runs_of_block(ij, kind, fr))))
        r0 = int(np.searchsorted(runs.last, lo))
        r1 = int(np.searchsorted(runs.first, hi))
        near = Runs(*(a[max(r0 - NEAR_RUNS, 0):r1 + NEAR_RUNS] for a in runs))
        ctx = _RunContext.of(geo, near, tol)
        w = geo.window(lo, hi)
        s, carry = arc_lengths(w, lo, hi, carry)
        kappa, corner = _vertex_pass(geo, ctx, lo, hi, w, s, tol, path_tol)
        tangent = _tangents(geo, lo, hi, w)
        if not fit._merges:
            yield kappa, tangent, corner
        else:
            while point_ids and point_ids[0][0] < hi:
                ids = point_ids.popleft()
                k = int(np.searchsorted(ids, hi))
                if k < ids.size:
                    point_ids.appendleft(ids[k:])
                    ids = ids[:k]
                yield kappa[ids - lo], tangent[ids - lo], corner[ids - lo]
        keep = max(int(np.searchsorted(runs.last, hi)) - 1, 0)
        runs = Runs(*(a[keep:] for a in runs))
        need = min(low, hi - 1, int(runs.first[0]) if runs.first.size else hi - 1)
        geo.release(need)
