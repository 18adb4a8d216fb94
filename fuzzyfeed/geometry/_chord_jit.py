"""The chord-exact interpolator's per-tick terms compiled by numba (geometry/interpolate.py,
_chord_exact): chords, curvature-explained deficits, corner flags, |C′|² and C′·C″ of one chunk of
ticks in one pass instead of ~20 numpy temporaries over it. The same floating-point operations in
the same order as the numpy lines they replace (np.linalg.norm adds the squares in order, np.cross
by its three formulas, np.einsum in two lanes: (x·x′ + z·z′) + y·y′); the powers ``** 3`` are
numpy's, passed in (its SIMD power may round otherwise than C's). Checked bit for bit in
tests/test_arc_jit.py. Module-level, no closure: numba's disk cache serves every process."""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True, nogil=True)
def speeds(d1, out):
    """np.linalg.norm(d1, axis=1) into ``out``."""
    n, dim = d1.shape
    for i in range(n):
        acc = d1[i, 0] * d1[i, 0]
        for d in range(1, dim):
            acc += d1[i, d] * d1[i, d]
        out[i] = math.sqrt(acc)


@numba.njit(cache=True, nogil=True, inline="always")
def _lanes(a, b, i):
    """np.einsum("ij,ij->i", a, b)[i]: even and odd components in two lanes, then the lanes."""
    dim = a.shape[1]
    even = a[i, 0] * b[i, 0]
    odd = a[i, 1] * b[i, 1]
    for d in range(2, dim):
        if d % 2 == 0:
            even += a[i, d] * b[i, d]
        else:
            odd += a[i, d] * b[i, d]
    return even + odd


@numba.njit(cache=True, nogil=True, inline="always")
def _kappa(d1, d2, d1n3, i):
    """|C′ × C″| / |C′|³ with the vectors padded to 3-D (np.cross, np.linalg.norm), NaN and +inf
    as 0 (np.nan_to_num)."""
    a0, a1, b0, b1 = d1[i, 0], d1[i, 1], d2[i, 0], d2[i, 1]
    if d1.shape[1] == 3:
        a2, b2 = d1[i, 2], d2[i, 2]
    else:
        a2, b2 = 0.0, 0.0
    cx = a1 * b2 - a2 * b1
    cy = a2 * b0 - a0 * b2
    cz = a0 * b1 - a1 * b0
    k = math.sqrt(cx * cx + cy * cy + cz * cz) / d1n3[i]
    if math.isnan(k) or k == math.inf:
        return 0.0
    return k


@numba.njit(cache=True, nogil=True, inline="always")
def _count(knots, x, right, start):
    """np.searchsorted(knots, x, side="right" if right else "left"), walking from ``start`` (the
    ticks' parameters move little from one to the next), by bisection after a few steps."""
    n = knots.size
    i = min(max(start, 0), n)
    # before(j): knots[j] < x (≤ x for the right side), true below the count and false from it
    if i < n and (knots[i] < x or (right and knots[i] == x)):
        for _ in range(8):
            i += 1
            if i == n or not (knots[i] < x or (right and knots[i] == x)):
                return i
    else:
        for _ in range(8):
            if i == 0 or knots[i - 1] < x or (right and knots[i - 1] == x):
                return i
            i -= 1
    lo, hi = 0, n
    while lo < hi:
        mid = (lo + hi) >> 1
        if knots[mid] < x or (right and knots[mid] == x):
            lo = mid + 1
        else:
            hi = mid
    return lo


@numba.njit(cache=True, nogil=True, error_model="numpy")
def chunk_terms(pts, d1, d2, d1n3, dl, dl3, hard, u, c0, chords, deficit, at_knot, sp2, d1d2):
    """Chords c0 … c0 + m − 1 (m = len(dl)) from the m + 1 points ``pts`` (C, C′, C″ at u[c0 …]):
    the chord, its deficit (the whole shortfall dl − chord ≥ 0, or across a corner knot of
    ``hard`` at most dl³·max(κ)²/12 + 1e-3 of it), the corner flag; |C′|² and C′·C″ at the points."""
    m = dl.size
    dim = pts.shape[1]
    k_prev = _kappa(d1, d2, d1n3, 0)
    left = _count(hard, u[c0], False, 0)
    for i in range(m):
        acc = (pts[i + 1, 0] - pts[i, 0]) * (pts[i + 1, 0] - pts[i, 0])
        for d in range(1, dim):
            acc += (pts[i + 1, d] - pts[i, d]) * (pts[i + 1, d] - pts[i, d])
        ch = math.sqrt(acc)
        chords[c0 + i] = ch
        k_next = _kappa(d1, d2, d1n3, i + 1)
        short = dl[i] - ch
        # np.maximum / np.minimum: a NaN on either side wins; of two equal values, the second
        part = short if (short > 0.0 or short != short) else 0.0
        kmax = k_prev if k_prev > k_next else k_next
        cap = dl3[i] * (kmax * kmax) / 12.0 + 1e-3 * part
        if part != part or (part < cap and cap == cap):
            capped = part
        else:
            capped = cap
        right = _count(hard, u[c0 + i + 1], True, left)
        corner = right > left
        left = _count(hard, u[c0 + i + 1], False, right)
        at_knot[c0 + i] = corner
        deficit[c0 + i] = capped if corner else part
        k_prev = k_next
    for j in range(m + 1):
        sp2[c0 + j] = _lanes(d1, d1, j)
        d1d2[c0 + j] = _lanes(d1, d2, j)
