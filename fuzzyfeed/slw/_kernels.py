"""Compiled loops of the SLW package (numba, compiled lazily, cached on disk)."""

from __future__ import annotations

from functools import cache


@cache
def phase_plane_kernel():
    """Compiled ``passes(ds, x_lim, tangent, kn, axis_acc) -> x`` (x = v², forward then backward)."""
    import numba
    import numpy as np

    @numba.njit(cache=True, nogil=True)
    def acc_range(x, t, k, axis_acc):
        # tangential accelerations a with |a·T_j + x·κN_j| ≤ A_j on every axis
        lo, hi = -np.inf, np.inf
        for j in range(t.size):
            tj = t[j]
            c = x * k[j]
            if abs(tj) > 1e-12:
                b1 = (axis_acc[j] - c) / tj
                b2 = (-axis_acc[j] - c) / tj
                if b1 > b2:
                    b1, b2 = b2, b1
                lo = max(lo, b1)
                hi = min(hi, b2)
        return lo, hi

    @numba.njit(cache=True, nogil=True)
    def passes(ds, x_lim, tangent, kn, axis_acc):
        n = x_lim.size
        x = x_lim.copy()
        x[0] = min(x[0], 0.0)
        x[n - 1] = min(x[n - 1], 0.0)
        for i in range(n - 1):  # forward: fastest acceleration
            lo, hi = acc_range(x[i], tangent[i], kn[i], axis_acc)
            nxt = x[i] + 2.0 * max(hi, 0.0) * ds[i]
            if nxt < x[i + 1]:
                x[i + 1] = nxt
        for i in range(n - 1, 0, -1):  # backward: hardest braking
            lo, hi = acc_range(x[i], tangent[i], kn[i], axis_acc)
            prv = x[i] - 2.0 * min(lo, 0.0) * ds[i - 1]
            if prv < x[i - 1]:
                x[i - 1] = prv
        return x

    return passes
