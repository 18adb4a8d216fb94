"""u(s) compiled by numba: ArcLengthTable._param_block point by point, in one pass.

The same floating-point operations in the same order as the numpy form (Hermite first guess,
safeguarded Newton on s(u) with the GAUSS_ORDER Gauss–Legendre residual from the table interval's
start, the 3-point rule over a short step; seed 004 eq. 8–9), so the same parameters to the last
bit (tests/test_arc_jit.py). The numpy form spends ~2.6 µs per point in temporaries; the servo
ticks of a long program are ~10⁶ points, inverted three times by the chord-exact interpolator.
Module-level, no closure: numba's disk cache serves every process (geometry/_kernels.py).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fuzzyfeed.geometry._nurbs_jit import find_span


@numba.njit(cache=True, nogil=True, inline="always")
def _speed(spans, coeffs, x, hint):
    """|C′(x)| as the NURBS kernel computes C′ (_nurbs_jit.evaluate_power_basis, order ≥ 1), its
    squares added as np.einsum "ij,ij->i" adds them (two lanes, even and odd components, then the
    lanes: (x² + z²) + y² in 3-D, x² + y² in 2-D). Scalars, not scratch arrays: the evaluations
    of one quadrature overlap in the CPU."""
    m = coeffs.shape[0]
    p = coeffs.shape[1] - 1
    dim = coeffs.shape[2] - 1
    # the span search of the NURBS kernel; nearby points usually stay in the last span
    k = find_span(spans, m, x, hint[0])
    hint[0] = k
    h = spans[k + 1] - spans[k]
    t = (x - spans[k]) / h
    # homogeneous components 0, 1, (2), w: Horner on the value (a) and its t-derivative (b)
    a0 = coeffs[k, p, 0]
    a1 = coeffs[k, p, 1]
    a2 = coeffs[k, p, 2]
    a3 = coeffs[k, p, 3] if dim == 3 else 0.0
    b0 = 0.0
    b1 = 0.0
    b2 = 0.0
    b3 = 0.0
    for j in range(p - 1, -1, -1):
        b0 = b0 * t + a0
        b1 = b1 * t + a1
        b2 = b2 * t + a2
        a0 = a0 * t + coeffs[k, j, 0]
        a1 = a1 * t + coeffs[k, j, 1]
        a2 = a2 * t + coeffs[k, j, 2]
        if dim == 3:
            b3 = b3 * t + a3
            a3 = a3 * t + coeffs[k, j, 3]
    inv_h = 1.0 / h
    if dim == 3:
        w = a3
        w1 = b3 * inv_h
        cx = (b0 * inv_h - w1 * (a0 / w)) / w
        cy = (b1 * inv_h - w1 * (a1 / w)) / w
        cz = (b2 * inv_h - w1 * (a2 / w)) / w
        return math.sqrt((cx * cx + cz * cz) + cy * cy)
    w = a2
    w1 = b2 * inv_h
    cx = (b0 * inv_h - w1 * (a0 / w)) / w
    cy = (b1 * inv_h - w1 * (a1 / w)) / w
    return math.sqrt(cx * cx + cy * cy)


@numba.njit(cache=True, nogil=True, inline="always")
def _gl(spans, coeffs, lo, hi, nodes, weights, hint):
    """∫_lo^hi |C′| du by the Gauss–Legendre rule (nodes, weights), as nurbs._gl_lengths sums it."""
    half = 0.5 * (hi - lo)
    mid = 0.5 * (hi + lo)
    acc = _speed(spans, coeffs, mid + half * nodes[0], hint) * weights[0]
    for j in range(1, nodes.size):
        acc += _speed(spans, coeffs, mid + half * nodes[j], hint) * weights[j]
    return half * acc


@numba.njit(cache=True, nogil=True, error_model="numpy")
def param_at(spans, coeffs, breaks, cumulative, end_speeds, target, iterations, tol, short_step,
             eps_span, nodes, weights, nodes3, weights3, chain, out):
    """u(s) at each ``target`` (already clipped to [0, L]) into ``out``: ArcLengthTable._param_block.

    ``chain`` > 0 (non-decreasing targets, servo ticks): a point in the same table interval as the
    last converged one, its first guess at most ``chain`` of the interval away from it, takes its
    first residual from that point, s(u) = s(u_prev) + ∫_u_prev^u |C′| by the 3-point rule, not
    from the interval's start by the GAUSS_ORDER rule (3 curve derivatives instead of 8; the chain
    restarts at each interval's start, so the rule's error adds up over one interval's ticks at
    most: interpolate.CHAIN_S_BOUND). ``chain`` = 0: every residual from the interval's start."""
    nb = breaks.size
    nc = cumulative.size
    hint = np.zeros(1, dtype=np.int64)
    lo = 0
    held = False        # the last point converged with its residual known: s(u_held) = base + s_held
    k_held = -1
    u_held = 0.0
    s_held = 0.0        # from the table interval's start: its rounding does not grow with s
    for i in range(target.size):
        tg = target[i]
        # np.searchsorted(cumulative, target, side="right") - 1, clipped to the intervals: lo is
        # the count of entries <= tg, the one lo with cumulative[lo - 1] <= tg < cumulative[lo];
        # sorted targets (servo ticks) mostly keep the last point's or take the next one
        if not ((lo == 0 or cumulative[lo - 1] <= tg) and (lo == nc or tg < cumulative[lo])):
            if lo < nc and cumulative[lo] <= tg and (lo + 1 == nc or tg < cumulative[lo + 1]):
                lo += 1
            else:
                lo, hi = 0, nc
                while lo < hi:
                    mid = (lo + hi) >> 1
                    if cumulative[mid] <= tg:
                        lo = mid + 1
                    else:
                        hi = mid
        k = min(max(lo - 1, 0), nb - 2)
        a = breaks[k]
        b = breaks[k + 1]
        width = b - a
        base = cumulative[k]
        seg = cumulative[k + 1] - base
        frac = (tg - base) / seg if seg > 0 else 0.0
        m0 = seg / (end_speeds[k, 0] * width)
        m1 = seg / (end_speeds[k, 1] * width)
        monotone = math.isfinite(m0) and math.isfinite(m1) and (m0 * m0 + m1 * m1 <= 9.0)
        if monotone:
            f2 = frac * frac
            hermite = ((f2 * frac - 2.0 * f2 + frac) * m0 + (3.0 * f2 - 2.0 * f2 * frac)
                       + (f2 * frac - f2) * m1)
            g = min(max(hermite, 0.0), 1.0)
        else:
            g = frac
        u = a + width * g
        left = a
        short = False
        u_prev = 0.0
        f_prev = 0.0
        if held and k_held == k and abs(u - u_held) <= chain * width:
            short = True
            u_prev = u_held
            f_prev = s_held - (tg - base)
        held = False
        for _ in range(iterations):
            if short:
                f = f_prev + _gl(spans, coeffs, u_prev, u, nodes3, weights3, hint)
            else:
                f = base + _gl(spans, coeffs, left, u, nodes, weights, hint) - tg
            if abs(f) <= tol:
                held = chain > 0
                k_held = k
                u_held = u
                s_held = (tg - base) + f
                break
            if f > 0:
                b = u
            else:
                a = u
            step = u - f / _speed(spans, coeffs, u, hint)
            outside = not math.isfinite(step) or step < a or step > b
            if outside:
                step = 0.5 * (a + b)
            moved = abs(step - u)
            u_prev, f_prev = u, f
            short = (not outside) and moved <= short_step * width
            u = step
            if moved <= eps_span:
                break
        out[i] = u
