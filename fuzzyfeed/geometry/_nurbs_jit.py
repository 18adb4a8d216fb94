"""The NURBS evaluation loop compiled by numba (imported only when a call is large enough).

Module-level, with no closure, so numba's on-disk cache key is the same in every process and a
compiled copy written once is loaded by every later run (see :mod:`fuzzyfeed.geometry._kernels`).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, inline="always")
def find_span(spans, m, x, k):
    """The span k of ``x`` among the ``m`` spans [spans[k], spans[k + 1]): the hint ``k`` when x
    lies in it, else bisection for the last k < m with spans[k] <= x (0 when none is), i.e.
    np.searchsorted(spans, x, side="right") - 1 clipped to [0, m - 1] (cf. The NURBS Book
    A2.1, FindSpan)."""
    if spans[k] <= x < spans[k + 1]:
        return k
    lo, hi = 0, m
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if spans[mid] <= x:
            lo = mid
        else:
            hi = mid
    return lo


@numba.njit(cache=True, nogil=True)
def evaluate_power_basis(spans, coeffs, u, order, out):
    # seed 004 step 3: Horner on the span's homogeneous power-basis polynomial and its
    # t-derivatives, then the rational quotient rule (The NURBS Book eq. 4.8).
    m = coeffs.shape[0]
    p = coeffs.shape[1] - 1
    dh = coeffs.shape[2]
    dim = dh - 1
    a0 = np.empty(dh)
    a1 = np.empty(dh)
    a2 = np.empty(dh)
    k = 0
    for i in range(u.size):
        x = u[i]
        # sorted input usually stays in the same or the next span
        k = find_span(spans, m, x, k)
        h = spans[k + 1] - spans[k]
        t = (x - spans[k]) / h
        for d in range(dh):
            a0[d] = coeffs[k, p, d]
            a1[d] = 0.0
            a2[d] = 0.0
        for j in range(p - 1, -1, -1):
            for d in range(dh):
                a2[d] = a2[d] * t + 2.0 * a1[d]
                a1[d] = a1[d] * t + a0[d]
                a0[d] = a0[d] * t + coeffs[k, j, d]
        w = a0[dim]
        for d in range(dim):
            out[0, i, d] = a0[d] / w
        if order >= 1:
            inv_h = 1.0 / h
            w1 = a1[dim] * inv_h
            for d in range(dim):
                out[1, i, d] = (a1[d] * inv_h - w1 * out[0, i, d]) / w
            if order >= 2:
                inv_h2 = inv_h * inv_h
                w2 = a2[dim] * inv_h2
                for d in range(dim):
                    out[2, i, d] = (a2[d] * inv_h2 - 2.0 * w1 * out[1, i, d]
                                    - w2 * out[0, i, d]) / w
