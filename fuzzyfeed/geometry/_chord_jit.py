"""The chord-exact interpolator's passes compiled by numba (geometry/interpolate.py,
_chord_exact_compiled): each pass one loop over every tick, the curve evaluated tick by tick with the
span and the corner knot carried from the last tick (chords, deficits, corner flags, |C′|² and
C′·C″), then one loop for the pass's error and one for its retargeting and Taylor step, instead of
~30 numpy temporaries over chunks of ticks. The same floating-point operations in the same order
as the numpy lines they replace (the NURBS kernel's Horner and quotient rule, np.linalg.norm adding
the squares in order, np.einsum in two lanes: (x·x′ + z·z′) + y·y′, cumsum and the running maximum
in order, NaN winning as in np.maximum); the corner chords' cap, which takes numpy's ``** 3`` (its
SIMD power may round otherwise than C's), is left to numpy. Checked bit for bit in
tests/test_arc_jit.py. Module-level, no closure: numba's disk cache serves every process."""

from __future__ import annotations

import math

import numba
import numpy as np

from fuzzyfeed.geometry._nurbs_jit import find_span


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


@numba.njit(cache=True, nogil=True, inline="always")
def _point(spans, coeffs, x, k, out, a):
    """C, C′, C″ at ``x`` into out[0..2, :dim] in span ``k`` (found from the hint ``k``; ``a`` a
    (3, 4) scratch): the operations of _nurbs_jit.evaluate_power_basis at order 2, in its order.
    Returns the span."""
    m = coeffs.shape[0]
    p = coeffs.shape[1] - 1
    dh = coeffs.shape[2]
    dim = dh - 1
    k = find_span(spans, m, x, k)
    h = spans[k + 1] - spans[k]
    t = (x - spans[k]) / h
    for d in range(dh):
        a[0, d] = coeffs[k, p, d]
        a[1, d] = 0.0
        a[2, d] = 0.0
    for j in range(p - 1, -1, -1):
        for d in range(dh):
            a[2, d] = a[2, d] * t + 2.0 * a[1, d]
            a[1, d] = a[1, d] * t + a[0, d]
            a[0, d] = a[0, d] * t + coeffs[k, j, d]
    w = a[0, dim]
    for d in range(dim):
        out[0, d] = a[0, d] / w
    inv_h = 1.0 / h
    w1 = a[1, dim] * inv_h
    for d in range(dim):
        out[1, d] = (a[1, d] * inv_h - w1 * out[0, d]) / w
    inv_h2 = inv_h * inv_h
    w2 = a[2, dim] * inv_h2
    for d in range(dim):
        out[2, d] = (a[2, d] * inv_h2 - 2.0 * w1 * out[1, d] - w2 * out[0, d]) / w
    return k


@numba.njit(cache=True, nogil=True, inline="always")
def _lanes3(v, a, b, dim):
    """np.einsum("ij,ij->i", A, B) of one point's rows a, b: even and odd components in two lanes."""
    even = v[a, 0] * v[b, 0]
    odd = v[a, 1] * v[b, 1]
    for d in range(2, dim):
        if d % 2 == 0:
            even += v[a, d] * v[b, d]
        else:
            odd += v[a, d] * v[b, d]
    return even + odd


@numba.njit(cache=True, nogil=True, error_model="numpy")
def pass_terms(spans, coeffs, lo, hi, u, target, hard, chords, deficit, at_knot, sp2, d1d2):
    """One pass of the chord-exact interpolator over every tick, the curve evaluated point by point
    (the NURBS kernel's operations, the span carried from the last point): the chords, their whole
    shortfall max(dl − chord, 0) as ``deficit`` (the corner chords' cap is applied by the caller,
    with numpy's powers), the corner flags, |C′|² and C′·C″ at the points. Returns the first
    point outside [lo, hi] or not finite (−1 when none is): the caller raises the curve's error."""
    n = u.size
    dim = coeffs.shape[2] - 1
    for i in range(n):
        x = u[i]
        if not (x >= lo and x <= hi):
            return i
    if n == 0:
        return -1
    cur = np.empty((3, 3))
    prev = np.empty((3, 3))
    work = np.empty((3, 4))
    k = _point(spans, coeffs, u[0], 0, prev, work)
    left = _count(hard, u[0], False, 0)
    sp2[0] = _lanes3(prev, 1, 1, dim)
    d1d2[0] = _lanes3(prev, 1, 2, dim)
    for i in range(n - 1):
        k = _point(spans, coeffs, u[i + 1], k, cur, work)
        acc = (cur[0, 0] - prev[0, 0]) * (cur[0, 0] - prev[0, 0])
        for d in range(1, dim):
            acc += (cur[0, d] - prev[0, d]) * (cur[0, d] - prev[0, d])
        ch = math.sqrt(acc)
        chords[i] = ch
        short = (target[i + 1] - target[i]) - ch
        # np.maximum(dl - ch, 0.0): a NaN wins
        deficit[i] = short if (short > 0.0 or short != short) else 0.0
        right = _count(hard, u[i + 1], True, left)
        at_knot[i] = right > left
        left = _count(hard, u[i + 1], False, right)
        sp2[i + 1] = _lanes3(cur, 1, 1, dim)
        d1d2[i + 1] = _lanes3(cur, 1, 2, dim)
        prev, cur = cur, prev
    return -1


@numba.njit(cache=True, nogil=True, inline="always")
def _max_nan(a, b):
    """np.maximum: a NaN on either side wins."""
    if a != a or b != b:
        return a + b
    return a if a >= b else b


@numba.njit(cache=True, nogil=True, inline="always")
def _min_nan(a, b):
    """np.minimum: a NaN on either side wins."""
    if a != a or b != b:
        return a + b
    return a if a <= b else b


@numba.njit(cache=True, nogil=True, error_model="numpy")
def pass_error(chords, steps, at_knot, mu):
    """max(err, initial=0) of err = where(at_knot, 0, |chords − μ·steps|) (NaN if any is)."""
    worst = 0.0
    for i in range(chords.size):
        e = 0.0 if at_knot[i] else abs(chords[i] - mu * steps[i])
        worst = _max_nan(worst, e)
    return worst


@numba.njit(cache=True, nogil=True, error_model="numpy")
def retarget(steps, deficit, mu, total, target, u, sp2, d1d2, chords, at_knot, lo, hi, taylor, redo):
    """The next targets s′ = min(max.accumulate([0, cumsum(μ·steps + deficit)] with s′_K = L), L)
    into ``target``; with ``taylor``, each u moved by the second-order Taylor step of its target's
    shift (clipped to [lo, hi]) and ``redo`` flagging the points of the chords still off by more
    than 1e-9 of their step (and the point after each): the lines of interpolate._chord_exact, in
    their order. Returns the number of chords so off."""
    n = target.size
    c = 0.0
    m = 0.0
    count = 0
    if taylor:
        for i in range(n):
            redo[i] = False
    for i in range(n):
        if i == 0:
            new = 0.0
        elif i == n - 1:
            new = total
        else:
            x = mu * steps[i - 1] + deficit[i - 1]
            c = x if i == 1 else c + x
            new = c
        m = new if i == 0 else _max_nan(m, new)
        out = _min_nan(m, total)
        shift = out - target[i]
        target[i] = out
        if taylor:
            s2 = sp2[i]
            if s2 > 0:
                du = shift / math.sqrt(s2) - shift * shift * d1d2[i] / (2.0 * s2 * s2)
            else:
                du = 0.0
            x = u[i] + du
            u[i] = x if x != x else min(max(x, lo), hi)
            if i < n - 1:
                e = 0.0 if at_knot[i] else abs(chords[i] - mu * steps[i])
                if e > 1e-9 * steps[i]:
                    redo[i] = True
                    redo[i + 1] = True
                    count += 1
    return count
