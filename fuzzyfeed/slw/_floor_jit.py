"""The corner chain's held gap times (slw/floor.py, :func:`~fuzzyfeed.slw.floor.gap_times` with held
end accelerations) in one compiled pass per gap: no (gaps × points) arrays per bisection step.

The same floating-point operations in the same order as the numpy lines of floor.py
(:func:`_capped_integral`, :func:`_reach`, :func:`max_distance_held`, :func:`_tent_sum`,
:func:`gap_times`), each ``np.where`` taken as the branch it selects and each ``np.clip`` as
numpy's max-then-min; the tent's 64 steps summed as numpy sums a row (its pairwise sum: eight
running sums, combined in pairs). Checked bit for bit in tests/test_slw_floor_jit.py.
Module-level, no closure: numba's disk cache serves every process.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, inline="always")
def _capped(width, start, end, acc):
    """∫ min(A, L) over ``width``, L linear from ``start`` to ``end`` (floor._capped_integral)."""
    if start <= acc and end <= acc:
        return 0.5 * (start + end) * width
    if start >= acc and end >= acc:
        return acc * width
    f = (acc - start) / (end - start)
    f = f if f > 0.0 else 0.0
    f = f if f < 1.0 else 1.0
    if start < acc:
        return (0.5 * (start + acc) * f + acc * (1.0 - f)) * width
    return (acc * f + 0.5 * (acc + end) * (1.0 - f)) * width


@numba.njit(cache=True, nogil=True, inline="always")
def _reach(alpha, t, a0, acc, jerk):
    """Largest v(t) − v(0) with a(t) = α, a(0) ≤ a₀ (floor._reach)."""
    sig = (alpha + jerk * t - a0) / (2.0 * jerk)
    sig = sig if sig > 0.0 else 0.0
    sig = sig if sig < t else t
    return _capped(sig, a0, a0 + jerk * sig, acc) + _capped(t - sig, alpha + jerk * (t - sig), alpha, acc)


@numba.njit(cache=True, nogil=True)
def _row_sum(a, n):
    """numpy's sum of a contiguous row of ``n`` doubles (pairwise_sum for 8 ≤ n ≤ 128: eight running
    sums, combined in pairs, then the rest in order; below 8 in order)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[i]
        return res
    r0, r1, r2, r3, r4, r5, r6, r7 = a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]
    i = 8
    while i < n - n % 8:
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[i]
        i += 1
    return res


@numba.njit(cache=True, nogil=True)
def _distance_held(T, c1, c2, a0, a1, feed, acc, jerk, frac, steps, w, tent):
    """floor.max_distance_held for one gap; ``w`` (points + 1) and ``tent`` (points) scratch."""
    points = frac.size - 1
    for k in range(points + 1):
        t = T * frac[k]
        r = T - t
        lo, hi = -acc, acc
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            if c1 + _reach(mid, t, a0, acc, jerk) >= c2 + _reach(-a1, r, -mid, acc, jerk):
                hi = mid
            else:
                lo = mid
        up = c1 + _reach(hi, t, a0, acc, jerk)
        down = c2 + _reach(-a1, r, -lo, acc, jerk)
        v = up if up <= down else down
        v = v if v <= feed else feed
        w[k] = v if v > 0.0 else 0.0
    h = T / points
    cap = acc * h
    for k in range(points):
        d = abs(w[k + 1] - w[k])
        d = d if d <= cap else cap
        x = h * 0.5 * (w[k] + w[k + 1]) + (acc * acc * h * h - d * d) / (4.0 * acc)
        y = h * feed
        tent[k] = x if x <= y else y
    return _row_sum(tent, points)


@numba.njit(cache=True, nogil=True)
def held_gap_times(gaps, c1, c2, a0, a1, acc, lo0, feed, jerk, frac, steps, time_steps, out):
    """floor.gap_times with held ends, gap by gap, into ``out``: from ``lo0`` (0.999 × the
    acceleration-only time), the bracket widened by doubling steps of A/J (at most 200), then
    ``time_steps`` halvings keeping max_distance_held(lo) < gap."""
    points = frac.size - 1
    w = np.empty(points + 1)
    tent = np.empty(points)
    for i in range(gaps.size):
        g, a = gaps[i], acc[i]
        lo = lo0[i]
        if not _distance_held(lo, c1[i], c2[i], a0[i], a1[i], feed, a, jerk, frac, steps, w, tent) < g:
            lo = g / feed * (1.0 - 1e-12)
        step = 1.0 * a / jerk
        hi = lo + step
        for _ in range(200):
            if not _distance_held(hi, c1[i], c2[i], a0[i], a1[i], feed, a, jerk, frac, steps, w, tent) < g:
                break
            step *= 2.0
            lo, hi = hi, hi + step
        for _ in range(time_steps):
            mid = 0.5 * (lo + hi)
            if _distance_held(mid, c1[i], c2[i], a0[i], a1[i], feed, a, jerk, frac, steps, w, tent) >= g:
                hi = mid
            else:
                lo = mid
        out[i] = lo
