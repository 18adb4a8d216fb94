"""Compiled loops of the SLW package (numba, cached on disk).

Every kernel is a module-level ``njit(cache=True)`` function that calls only other module-level
kernels: numba then keys the on-disk cache by this file and the function's name, so a second
process loads the compiled code instead of compiling it again (a kernel built inside a factory
and closing over another dispatcher gets a new cache entry in every process). This module
imports numba at import time; import it lazily (inside the functions that need it).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def acc_range(x, t, k, axis_acc):
    """Tangential accelerations a with |a·T_j + x·κN_j| ≤ A_j on every axis → (lo, hi).

    Empty (lo > hi) above the maximum-velocity curve; unbounded on an axis the path does not move
    along (|T_j| = 0), where only x·|κN_j| ≤ A_j is required (see :func:`mvc`).
    """
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
def mvc(tangent, kn, axis_acc, out):
    """Maximum-velocity curve x = v² of the axis accelerations alone, per sample, into ``out``.

    Per axis the feasible tangential accelerations form the interval c_j ± r_j with
    c_j = −x·κN_j/T_j and r_j = A_j/|T_j|; a set of intervals on a line meets iff every pair
    meets (Helly), so x ≤ (r_j + r_m)/|κN_j/T_j − κN_m/T_m| for every pair, and x·|κN_j| ≤ A_j
    on an axis with T_j = 0. Braking or accelerating may offset the centripetal part: this is
    the exact limit (no rule that the centripetal part alone fits the axis).
    """
    n = tangent.shape[0]
    d = tangent.shape[1]
    for i in range(n):
        best = np.inf
        for j in range(d):
            tj = tangent[i, j]
            kj = kn[i, j]
            if abs(tj) <= 1e-12:
                if abs(kj) > 0.0:
                    best = min(best, axis_acc[j] / abs(kj))
                continue
            for m in range(j + 1, d):
                tm = tangent[i, m]
                if abs(tm) <= 1e-12:
                    continue
                diff = abs(kj / tj - kn[i, m] / tm)
                if diff > 0.0:
                    best = min(best, (axis_acc[j] / abs(tj) + axis_acc[m] / abs(tm)) / diff)
        out[i] = best


@numba.njit(cache=True, nogil=True)
def phase_plane_passes(ds, x_lim, tangent, kn, axis_acc):
    """Forward (hardest acceleration) then backward (hardest braking) pass on x = v².

    ``x_lim`` must already include the maximum-velocity curve (:func:`mvc`); both ends are put at
    rest. Segment i → i+1 uses the acceleration interval at its start (forward) or end
    (backward), the first-order discretisation toppra uses; it converges as the grid is refined.
    """
    n = x_lim.size
    x = x_lim.copy()
    x[0] = 0.0
    x[n - 1] = 0.0
    for i in range(n - 1):
        lo, hi = acc_range(x[i], tangent[i], kn[i], axis_acc)
        nxt = max(x[i] + 2.0 * hi * ds[i], 0.0)
        if nxt < x[i + 1]:
            x[i + 1] = nxt
    for i in range(n - 1, 0, -1):
        lo, hi = acc_range(x[i], tangent[i], kn[i], axis_acc)
        prv = max(x[i] - 2.0 * lo * ds[i - 1], 0.0)
        if prv < x[i - 1]:
            x[i - 1] = prv
    return x


@numba.njit(cache=True, nogil=True)
def travel_time(ds, v):
    """Σ 2·ds/(v_i + v_{i+1}): exact for a constant acceleration per segment (v² linear in s)."""
    t = 0.0
    for i in range(ds.size):
        m = v[i] + v[i + 1]
        if ds[i] > 0.0:
            t += 2.0 * ds[i] / m if m > 0.0 else np.inf
    return t
