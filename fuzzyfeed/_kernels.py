"""Compiled inner loops (numba), compiled lazily on first use so importing fuzzyfeed stays light.

Each kernel is the plain loop of one equation; the vectorised callers in the core validate input
and own the meaning. numba is a dependency because these loops are the hot path of every planner:
a Horner pass per point in compiled code is several times faster than scipy's BSpline on
homogeneous coordinates, and far faster than numpy gathers of the span coefficients.
"""

from __future__ import annotations

from functools import cache


@cache
def nurbs_kernel():
    """Compiled ``kernel(spans, coeffs, u, order, out)`` filling out[0..order, i, :dim]."""
    import numba
    import numpy as np

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
            # span search: sorted input usually stays in the same or the next span
            if not (spans[k] <= x < spans[k + 1]):
                lo, hi = 0, m
                while hi - lo > 1:
                    mid = (lo + hi) >> 1
                    if spans[mid] <= x:
                        lo = mid
                    else:
                        hi = mid
                k = lo
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

    return evaluate_power_basis
