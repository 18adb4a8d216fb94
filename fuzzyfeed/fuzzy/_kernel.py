"""Numba kernel of the exact Mamdani engine (imported lazily by :mod:`fuzzyfeed.fuzzy.engine` for
calls of at least :data:`fuzzyfeed.geometry._kernels.COMPILED_MIN_POINTS` points; smaller calls use the numpy
form in :mod:`fuzzyfeed.fuzzy._centroid`, which does the same operations in the same order).

Per point: memberships of the two (clipped) inputs, rule strengths w_r = min(μκ, μDκ) (AND = min),
per output term the clip level h_o = max of the strengths of its rules (min implication, max
aggregation), then the exact centroid of A(y) = max_o min(T_o(y), h_o) (seed 002 eq. 11 with the
sums replaced by integrals).

The output axis is cut once per table at every term vertex; inside such an interval each term is one
line L_o. The aggregated set can bend only where a line meets its own clip level, another line or
another term's clip level, so those points (plus the interval ends) split the interval into pieces
on which A is linear, and ∫A and ∫yA are summed in closed form. No output grid.
"""

from __future__ import annotations

from functools import cache

import numba
import numpy as np

from fuzzyfeed.geometry._kernels import compile_once


@numba.njit(cache=True, inline="always")
def _mu(x, a, b, c, d):
    if x < a or x > d:
        return 0.0
    if x < b:
        return (x - a) / (b - a)
    if x <= c:
        return 1.0
    return (d - x) / (d - c)


@numba.njit(cache=True)
def mamdani_centroid(kappa, dk, k_terms, d_terms, k_lo, k_hi, d_lo, d_hi, grid_o, n_out,
                     x_int, act_ptr, act_term, act_m0, act_m1, no_fire, out):
    """Exact centroid for every point; ``out[i]`` = no_fire where no rule fires.

    ``grid_o[i, j]`` is the output term of rule (κ term i, Dκ term j), or −1 for no rule.
    """
    nk = k_terms.shape[0]
    nd = d_terms.shape[0]
    n_int = x_int.shape[0] - 1
    mk = np.empty(nk)
    md = np.empty(nd)
    h = np.empty(n_out)
    max_act = 1
    for q in range(n_int):
        max_act = max(max_act, act_ptr[q + 1] - act_ptr[q])
    s0 = np.empty(max_act)
    s1 = np.empty(max_act)
    sh = np.empty(max_act)
    cand = np.empty(2 + max_act * max_act + max_act * (max_act - 1) // 2)
    for i in range(kappa.shape[0]):
        x = min(max(kappa[i], k_lo), k_hi)
        y = min(max(dk[i], d_lo), d_hi)
        for t in range(nk):
            mk[t] = _mu(x, k_terms[t, 0], k_terms[t, 1], k_terms[t, 2], k_terms[t, 3])
        for t in range(nd):
            md[t] = _mu(y, d_terms[t, 0], d_terms[t, 1], d_terms[t, 2], d_terms[t, 3])
        for o in range(n_out):
            h[o] = 0.0
        for a in range(nk):             # only the few rules whose both memberships are > 0
            if mk[a] <= 0.0:
                continue
            for b in range(nd):
                if md[b] <= 0.0:
                    continue
                o = grid_o[a, b]
                if o >= 0:
                    w = min(mk[a], md[b])
                    if w > h[o]:
                        h[o] = w
        area = 0.0
        moment = 0.0
        for q in range(n_int):
            # the fired terms that are non-zero in this interval, as lines on t in [0, 1]
            na = 0
            for p in range(act_ptr[q], act_ptr[q + 1]):
                hv = h[act_term[p]]
                if hv > 0.0:
                    s0[na] = act_m0[p]
                    s1[na] = act_m1[p]
                    sh[na] = hv
                    na += 1
            if na == 0:
                continue
            x0 = x_int[q]
            width = x_int[q + 1] - x0
            nc = 2
            cand[0] = 0.0
            cand[1] = 1.0
            for a in range(na):
                da = s1[a] - s0[a]
                for b in range(na):       # line a meets clip level of b (b = a: its own clip)
                    lv = sh[b]
                    if (s0[a] < lv < s1[a]) or (s1[a] < lv < s0[a]):
                        cand[nc] = (lv - s0[a]) / da
                        nc += 1
                for b in range(a + 1, na):  # line a meets line b
                    e0 = s0[a] - s0[b]
                    e1 = s1[a] - s1[b]
                    if (e0 < 0.0 < e1) or (e1 < 0.0 < e0):
                        cand[nc] = e0 / (e0 - e1)
                        nc += 1
            # insertion sort of the few candidates
            for m in range(1, nc):
                v = cand[m]
                j = m - 1
                while j >= 0 and cand[j] > v:
                    cand[j + 1] = cand[j]
                    j -= 1
                cand[j + 1] = v
            prev_t = 0.0
            prev_v = 0.0
            for m in range(nc):
                tt = cand[m]
                v = 0.0
                for a in range(na):
                    la = s0[a] + (s1[a] - s0[a]) * tt
                    if la > sh[a]:
                        la = sh[a]
                    if la > v:
                        v = la
                if m > 0:
                    dt = tt - prev_t
                    if dt > 0.0:
                        xa = x0 + prev_t * width
                        xb = x0 + tt * width
                        dx = dt * width
                        area += 0.5 * dx * (prev_v + v)
                        moment += dx * (prev_v * (2.0 * xa + xb) + v * (xa + 2.0 * xb)) / 6.0
                prev_t = tt
                prev_v = v
        out[i] = moment / area if area > 0.0 else no_fire
    return out


@cache
def centroid_kernel():
    """``mamdani_centroid`` compiled once for its one signature (read-only inputs accept writable
    arrays, so read-only samples and writable test arrays share one compiled copy)."""
    f1, f2, i1, i2 = (numba.types.Array(dt, nd, "C", readonly=True)
                      for dt, nd in ((numba.float64, 1), (numba.float64, 2), (numba.int64, 1),
                                     (numba.int64, 2)))
    f = numba.float64
    sig = numba.float64[::1](f1, f1, f2, f2, f, f, f, f, i2, numba.int64, f1, i1, i1, f1, f1, f,
                             numba.float64[::1])
    return compile_once(mamdani_centroid, sig, "the fuzzy engine", 3)
