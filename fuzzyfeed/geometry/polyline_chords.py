"""The vertices of a point sequence and their chords, window by window (:mod:`fuzzyfeed.geometry.polyline`,
steps 2 and 4).

Consecutive points within the merge distance (P/10) of a cluster's first point are one vertex, the
cluster's mean (:func:`merge_tiny_moves`). :class:`Chords` holds the vertices and what their ends need
(the first and last chord, the seam of a closed path) and makes any window's chords, unit vectors,
turning angles θ = atan2(|u × v|, u·v) and neighbouring chord lengths row by row, as over the whole
path; :func:`arc_lengths` carries the arc length s = Σ chords from window to window as one cumulative
sum (each partial sum the same float).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

#: Vertices one window of the fit holds (the run search and the per-vertex pass): a longer point
#: sequence (a cut of 10⁶ G1 moves) is fitted window after window, with the whole sequence's result
#: (:func:`~fuzzyfeed.geometry.polyline_runs.line_arc_runs_windowed`, the per-vertex pass of
#: :func:`~fuzzyfeed.geometry.polyline.polyline_curvature`), its memory bounded by the window.
WINDOW_VERTICES = 1 << 16


def pad3(a: np.ndarray) -> np.ndarray:
    """Points (N, 2) or (N, 3) as (N, 3), z = 0 for planar ones."""
    return a if a.shape[1] == 3 else np.hstack([a, np.zeros((a.shape[0], 3 - a.shape[1]))])


def _clusters(pts: np.ndarray, merge_mm: float) -> np.ndarray:
    """Cluster id per point: a point joins the current cluster while it lies within ``merge_mm``
    of the cluster's first point."""
    step = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if np.all(step >= merge_mm):
        return np.arange(len(pts))
    return cluster_ids(pts, merge_mm)[0]


#: A step this much (relative) over the merge distance surely starts a cluster after a point that
#: started its own (the loop's distance, a 1-D norm, differs from the rows' norm by a few ulps).
_SURE = 1e-6


def cluster_ids(pts: np.ndarray, merge_mm: float, current: int = 0,
                first: np.ndarray | None = None) -> tuple[np.ndarray, int, np.ndarray]:
    """The clusters of :func:`_clusters` from a carried state (``current`` cluster and its ``first``
    point; None: ``pts`` starts the path): each point's id, and the state after the last point.
    The loop ``|p − first| ≥ merge_mm`` runs at the points after a step under (1 + 1e-6)·merge_mm
    or after a point that joined a cluster; every other point starts its own cluster (the same
    ids as the loop over every point)."""
    n = len(pts)
    ids = np.empty(n, dtype=np.int64)
    near = np.flatnonzero(np.linalg.norm(np.diff(pts, axis=0), axis=1) < merge_mm * (1 + _SURE)) + 1
    i, started = 0, False
    if first is None and n:
        ids[0], first, i, started = current, pts[0], 1, True
    while i < n:
        if started:
            k = int(np.searchsorted(near, i))
            j = int(near[k]) if k < near.size else n
            if j > i:            # points i..j-1: each starts a cluster
                ids[i:j] = current + 1 + np.arange(j - i)
                current += j - i
                first, i = pts[j - 1], j
                continue
        started = bool(np.linalg.norm(pts[i] - first) >= merge_mm)
        if started:
            current += 1
            first = pts[i]
        ids[i] = current
        i += 1
    return ids, current, first


def merge_tiny_moves(pts3: np.ndarray, merge_mm: float) -> tuple[np.ndarray | None, np.ndarray]:
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


class Window(NamedTuple):
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
class Chords:
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
    def of(reduced: np.ndarray, tol: float) -> Chords:
        m = len(reduced)
        ends = np.diff(reduced[[0, 1, m - 2, m - 1]], axis=0)[[0, 2]]
        length = np.linalg.norm(ends, axis=1)
        unit = ends / length[:, None]
        closed = m > 3 and np.linalg.norm(reduced[-1] - reduced[0]) <= 2.0 * tol
        return Chords(reduced, bool(closed), float(length[0]), float(length[1]), unit[0], unit[1])

    def vertices(self, a: int, b: int) -> np.ndarray:
        """Reduced vertices a..b-1."""
        return self.reduced[a:b]

    def at(self, idx: np.ndarray) -> np.ndarray:
        """Reduced vertices at the indices ``idx``."""
        return self.reduced[idx]

    def s_at(self, idx: np.ndarray) -> np.ndarray:
        """s at the (sorted) vertices ``idx`` (:func:`arc_length_at`)."""
        return arc_length_at(self, idx)

    def window(self, lo: int, hi: int) -> Window:
        return chord_window(self, lo, hi)

    def turn(self, lo: int, hi: int) -> np.ndarray:
        return self.window(lo, hi).turn


def chord_window(geo, lo: int, hi: int) -> Window:
    """The :class:`Window` of vertices lo..hi-1 of ``geo`` (a :class:`Chords`, or any object with
    its ends, ``m``, ``closed`` and ``vertices(a, b)``), row by row as over the whole path."""
    m = geo.m
    c0, c1 = max(lo - 1, 0), min(hi, m - 1)            # chords c0..c1-1 touch vertices lo..hi-1
    vec = np.diff(geo.vertices(c0, c1 + 1), axis=0)
    chord = np.linalg.norm(vec, axis=1)
    unit = vec / chord[:, None]
    w = hi - lo
    turn = np.zeros(w)
    a = np.empty(w)
    b = np.empty(w)
    v0, v1 = max(lo, 1), min(hi, m - 1)                 # inner vertices: chords v-1 and v
    turn[v0 - lo:v1 - lo] = angle_between(unit[v0 - 1 - c0:v1 - 1 - c0], unit[v0 - c0:v1 - c0])
    a[v0 - lo:] = chord[v0 - 1 - c0:hi - 1 - c0]
    b[:v1 - lo] = chord[lo - c0:v1 - c0]
    if lo == 0:
        a[0] = geo.last_chord
    if hi == m:
        b[-1] = geo.first_chord
    if geo.closed and (lo == 0 or hi == m):
        seam = angle_between(geo.last_unit, geo.first_unit)
        if lo == 0:
            turn[0] = seam
        if hi == m:
            turn[-1] = seam
    return Window(c0, unit, chord, turn, a, b)


def angle_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle between unit vectors, row-wise (atan2 form, accurate near 0 and π)."""
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.einsum("...i,...i->...", u, v))


def arc_lengths(w: Window, lo: int, hi: int, carry: float) -> tuple[np.ndarray, float]:
    """s = Σ chords from vertex 0 at vertices lo..hi-1 of window ``w``, ``carry`` being s at lo - 1:
    one cumulative sum carried from window to window (each partial sum the same float as in one
    cumsum over the whole path); and s at hi - 1."""
    if lo == 0:
        s = np.cumsum(np.concatenate([[0.0], w.chord[:hi - 1]]))
    else:
        s = np.cumsum(np.concatenate([[carry], w.chord[:hi - lo]]))[1:]
    return s, float(s[-1])


def arc_length_at(geo: Chords, at: np.ndarray) -> np.ndarray:
    """s at the (sorted) vertices ``at`` (:func:`arc_lengths` window after window)."""
    out = np.empty(at.size)
    carry = 0.0
    for lo in range(0, geo.m, WINDOW_VERTICES):
        hi = min(lo + WINDOW_VERTICES, geo.m)
        s, carry = arc_lengths(geo.window(lo, hi), lo, hi, carry)
        sel = slice(np.searchsorted(at, lo), np.searchsorted(at, hi))
        out[sel] = s[at[sel] - lo]
    return out
