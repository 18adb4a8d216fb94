"""Contour error against a polyline path: the distance of the actual tool from the stretch of path
the controller recently commanded (DESIGN §3: contour error = distance of the actual position from
the programmed path).

A tool that lags behind its command is an average of the positions commanded over the last few
time constants of its servo, so its nearest point on the path is sought in that stretch (from
where the command was ``lookback`` ticks ago to where it is now, plus a margin either side), not
on the whole path: a pocket's neighbouring pass 0.5 mm away must not hide a 0.3 mm error. Exact
point-to-segment distances, in bounded chunks (numpy).
"""

from __future__ import annotations

import numpy as np

#: Point-segment pairs per chunk (memory: ~200 bytes per pair).
PAIRS_PER_CHUNK = 2_000_000


def windowed_distance(points: np.ndarray, s_vertex: np.ndarray, query: np.ndarray, s_lo: np.ndarray,
                      s_hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance from each ``query`` point (K, 3) to the polyline ``points`` (n+1, 3) restricted to
    the segments that overlap the arc-length window [s_lo_k, s_hi_k] (``s_vertex`` the arc
    length at each vertex). Returns (distance (K,), index of the nearest segment (K,), the
    nearest point on the path (K, 3))."""
    pts = np.asarray(points, dtype=float)
    n = pts.shape[0] - 1
    i_lo = np.clip(np.searchsorted(s_vertex, s_lo, side="right") - 1, 0, n - 1)
    i_hi = np.clip(np.searchsorted(s_vertex, s_hi, side="left"), i_lo + 1, n)   # exclusive
    counts = (i_hi - i_lo).astype(np.int64)
    seg_a = pts[:-1]
    seg_d = np.diff(pts, axis=0)
    seg_l2 = np.einsum("ij,ij->i", seg_d, seg_d)
    dist = np.empty(query.shape[0])
    best = np.empty(query.shape[0], dtype=np.int64)
    foot = np.empty((query.shape[0], 3))
    ends = np.cumsum(counts)
    k0 = 0
    while k0 < query.shape[0]:
        base = ends[k0 - 1] if k0 else 0
        k1 = int(np.searchsorted(ends, base + PAIRS_PER_CHUNK, side="right"))
        k1 = max(k1, k0 + 1)
        c = counts[k0:k1]
        tick = np.repeat(np.arange(k0, k1), c)
        first = np.repeat(np.cumsum(c) - c, c)
        seg = i_lo[tick] + (np.arange(tick.size) - first)
        rel = query[tick] - seg_a[seg]
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.clip(np.einsum("ij,ij->i", rel, seg_d[seg]) / seg_l2[seg], 0.0, 1.0)
        off = rel - seg_d[seg] * t[:, None]
        d2 = np.einsum("ij,ij->i", off, off)
        starts = np.cumsum(c) - c
        dmin = np.minimum.reduceat(d2, starts)
        # the nearest segment: the first pair reaching the minimum of its tick
        is_min = d2 <= np.repeat(dmin, c)
        pos = np.flatnonzero(is_min)
        first_min = pos[np.searchsorted(pos, starts)]
        dist[k0:k1] = np.sqrt(dmin)
        best[k0:k1] = seg[first_min]
        foot[k0:k1] = seg_a[seg[first_min]] + seg_d[seg[first_min]] * t[first_min, None]
        k0 = k1
    return dist, best, foot
