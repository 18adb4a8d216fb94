"""The contour-distance loop compiled by numba (imported only for large runs; see
:mod:`fuzzyfeed.machine.contour` for the numpy form doing the same operations in the same order)."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def nearest_in_windows(seg_a, seg_d, seg_l2, query, i_lo, i_hi, dist, best, foot):
    for k in range(query.shape[0]):
        q0, q1, q2 = query[k, 0], query[k, 1], query[k, 2]
        best_d2 = np.inf
        best_j = i_lo[k]
        best_t = 0.0
        for j in range(i_lo[k], i_hi[k]):
            r0 = q0 - seg_a[j, 0]
            r1 = q1 - seg_a[j, 1]
            r2 = q2 - seg_a[j, 2]
            t = ((r0 * seg_d[j, 0] + r1 * seg_d[j, 1]) + r2 * seg_d[j, 2]) / seg_l2[j]
            t = min(max(t, 0.0), 1.0)
            o0 = r0 - seg_d[j, 0] * t
            o1 = r1 - seg_d[j, 1] * t
            o2 = r2 - seg_d[j, 2] * t
            d2 = (o0 * o0 + o1 * o1) + o2 * o2
            if d2 < best_d2:
                best_d2 = d2
                best_j = j
                best_t = t
        dist[k] = np.sqrt(best_d2)
        best[k] = best_j
        foot[k, 0] = seg_a[best_j, 0] + seg_d[best_j, 0] * best_t
        foot[k, 1] = seg_a[best_j, 1] + seg_d[best_j, 1] * best_t
        foot[k, 2] = seg_a[best_j, 2] + seg_d[best_j, 2] * best_t
