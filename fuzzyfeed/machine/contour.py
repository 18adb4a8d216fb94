"""Contour error against a polyline path: the distance of the actual tool from the stretch of path
the controller recently commanded (DESIGN §3: contour error = distance of the actual position from
the programmed path).

A tool that lags behind its command is an average of the positions commanded over the last few
time constants of its servo, so its nearest point on the path is sought in that stretch (from
where the command was ``lookback`` ticks ago to where it is now, plus a margin either side), not
on the whole path: a pocket's neighbouring pass 0.5 mm away must not hide a 0.3 mm error. Exact
point-to-segment distances: numpy in bounded chunks for small runs, a numba loop for large ones
(the same operations in the same order).
"""

from __future__ import annotations

from functools import cache

import numpy as np

from fuzzyfeed.geometry._kernels import compile_once, use_compiled

#: Point-segment pairs per chunk (memory: ~200 bytes per pair).
PAIRS_PER_CHUNK = 2_000_000


def windowed_distance(points: np.ndarray, s_vertex: np.ndarray, query: np.ndarray, s_lo: np.ndarray,
                      s_hi: np.ndarray, compiled: bool | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance from each ``query`` point (K, 3) to the polyline ``points`` (n+1, 3) restricted to
    the segments that overlap the arc-length window [s_lo_k, s_hi_k] (``s_vertex`` the arc
    length at each vertex). Returns (distance (K,), index of the nearest segment (K,), the
    nearest point on the path (K, 3)). Segments must have a length. A run over many
    point-segment pairs uses the compiled loop (:mod:`fuzzyfeed.machine._contour_jit`), a small
    one numpy; both give the same floats."""
    pts = np.ascontiguousarray(points, dtype=float)
    q = np.ascontiguousarray(query, dtype=float)
    n = pts.shape[0] - 1
    i_lo = np.clip(np.searchsorted(s_vertex, s_lo, side="right") - 1, 0, n - 1).astype(np.int64)
    i_hi = np.clip(np.searchsorted(s_vertex, s_hi, side="left"), i_lo + 1, n).astype(np.int64)   # exclusive
    seg_a = np.ascontiguousarray(pts[:-1])
    seg_d = np.ascontiguousarray(np.diff(pts, axis=0))
    seg_l2 = (seg_d[:, 0] * seg_d[:, 0] + seg_d[:, 1] * seg_d[:, 1]) + seg_d[:, 2] * seg_d[:, 2]
    dist = np.empty(q.shape[0])
    best = np.empty(q.shape[0], dtype=np.int64)
    foot = np.empty((q.shape[0], 3))
    pairs = int(np.sum(i_hi - i_lo))
    if compiled is None:
        compiled = use_compiled(pairs, _kernel.cache_info().currsize > 0)
    if compiled:
        _kernel()(seg_a, seg_d, seg_l2, q, i_lo, i_hi, dist, best, foot)
    else:
        _windows_numpy(seg_a, seg_d, seg_l2, q, i_lo, i_hi, dist, best, foot)
    return dist, best, foot


@cache
def _kernel():
    import numba

    from fuzzyfeed.machine._contour_jit import nearest_in_windows

    f2 = numba.types.Array(numba.float64, 2, "C", readonly=True)
    f1 = numba.types.Array(numba.float64, 1, "C", readonly=True)
    i1 = numba.types.Array(numba.int64, 1, "C", readonly=True)
    sig = numba.void(f2, f2, f1, f2, i1, i1, numba.float64[::1], numba.int64[::1], numba.float64[:, ::1])
    return compile_once(nearest_in_windows, sig, "the contour-error kernel", 2)


def _windows_numpy(seg_a, seg_d, seg_l2, query, i_lo, i_hi, dist, best, foot) -> None:
    """The numpy form of :func:`fuzzyfeed.machine._contour_jit.nearest_in_windows`, in bounded
    chunks of point-segment pairs."""
    counts = (i_hi - i_lo).astype(np.int64)
    ends = np.cumsum(counts)
    k0 = 0
    while k0 < query.shape[0]:
        base = ends[k0 - 1] if k0 else 0
        k1 = max(int(np.searchsorted(ends, base + PAIRS_PER_CHUNK, side="right")), k0 + 1)
        c = counts[k0:k1]
        tick = np.repeat(np.arange(k0, k1), c)
        first = np.repeat(np.cumsum(c) - c, c)
        seg = i_lo[tick] + (np.arange(tick.size) - first)
        a, d = seg_a[seg], seg_d[seg]
        r = query[tick] - a
        t = ((r[:, 0] * d[:, 0] + r[:, 1] * d[:, 1]) + r[:, 2] * d[:, 2]) / seg_l2[seg]
        t = np.minimum(np.maximum(t, 0.0), 1.0)
        o = r - d * t[:, None]
        d2 = (o[:, 0] * o[:, 0] + o[:, 1] * o[:, 1]) + o[:, 2] * o[:, 2]
        starts = np.cumsum(c) - c
        dmin = np.minimum.reduceat(d2, starts)
        # the nearest segment: the first pair reaching the minimum of its tick
        pos = np.flatnonzero(d2 <= np.repeat(dmin, c))
        first_min = pos[np.searchsorted(pos, starts)]
        dist[k0:k1] = np.sqrt(dmin)
        best[k0:k1] = seg[first_min]
        foot[k0:k1] = seg_a[seg[first_min]] + seg_d[seg[first_min]] * t[first_min, None]
        k0 = k1
