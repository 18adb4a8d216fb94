"""The path's feed limit, unit tangent and κN at given parameters, in one compiled pass.

The same floating-point operations, in the same order, as preprocess._evaluate does through
samples_at, curvature_vectors, feed_limit_components (eq. (8)-(12)) and FeedCap — value for value
(tests/test_slw_exact.py): the look-ahead reads the path exactly at ~10⁷ near-limit samples of a
long program, and those ~30 numpy calls per read were a third of its scheduling. numba at import
time: import lazily.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fuzzyfeed.geometry._nurbs_jit import evaluate_power_basis


@numba.njit(cache=True, nogil=True)
def derivatives(spans, coeffs, u, out, speed):
    """C, C′, C″ at ``u`` into out[0..2] (the NURBS kernel, as Nurbs.evaluate) and |C′| into
    ``speed`` (np.linalg.norm: the squares added in order)."""
    evaluate_power_basis(spans, coeffs, u, 2, out)
    dim = out.shape[2]
    for i in range(u.size):
        acc = out[1, i, 0] * out[1, i, 0]
        for j in range(1, dim):
            acc += out[1, i, j] * out[1, i, j]
        speed[i] = math.sqrt(acc)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _cap_at(x, xp, fp, left):
    """slw.feed_cap._interp at one x: linear between the cap's points, a repeated point's value
    taken from the ``left`` (last interval ending there) or right side."""
    n = xp.size
    if left:
        j = np.searchsorted(xp, x, side="left")
    else:
        j = np.searchsorted(xp, x, side="right")
    j = min(max(j, 1), n - 1)
    x0, x1, f0, f1 = xp[j - 1], xp[j], fp[j - 1], fp[j]
    width = x1 - x0
    if width > 0.0:
        w = (x - x0) / width
    else:
        w = 1.0 if left else 0.0
    if not math.isnan(w):
        w = min(max(w, 0.0), 1.0)
    return f0 + w * (f1 - f0)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def exact_limits(d1, d2, speed, speed3, s, cap_s, cap_v, vel, acc, feed, delta, two_over_ts, maxf,
                 vlim, tangent, kn):
    """From C′, C″ (n, dim), |C′| and |C′|**3 (numpy's power, passed in): the feed limit, the unit
    tangent and κN (n, 3) of preprocess._evaluate, into ``vlim``, ``tangent``, ``kn``. False (and
    nothing to use) when a derivative is not finite: curvature_vectors then takes another branch."""
    n, dim = d1.shape
    for i in range(n):
        for j in range(dim):
            if not (math.isfinite(d1[i, j])):
                return False
    has_cap = cap_s.size > 0
    t = np.zeros(3)
    a1 = np.zeros(3)
    a2 = np.zeros(3)
    k = np.zeros(3)
    for i in range(n):
        sp = speed[i]
        for j in range(3):
            if j < dim:
                a1[j] = d1[i, j]
                a2[j] = d2[i, j]
                t[j] = d1[i, j] / sp
            else:
                a1[j] = 0.0
                a2[j] = 0.0
                t[j] = 0.0
        # curvature_from_derivatives (unpadded): |C′ × C″| / |C′|³, inf where |C′| = 0
        if dim == 2:
            cross = abs(a1[0] * a2[1] - a1[1] * a2[0])
        else:
            c0 = a1[1] * a2[2] - a1[2] * a2[1]
            c1 = a1[2] * a2[0] - a1[0] * a2[2]
            c2 = a1[0] * a2[1] - a1[1] * a2[0]
            cross = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        kappa = cross / speed3[i] if sp > 0.0 else np.inf
        # curvature_vectors: κN = (C″ − (C″·T)T)/|C′|², a row with a non-finite part all inf
        # np.einsum("ij,ij->i") over three columns adds as (x0 + x2) + x1 (its SIMD lanes)
        sp2 = (a1[0] * a1[0] + a1[2] * a1[2]) + a1[1] * a1[1]
        dot = (a2[0] * t[0] + a2[2] * t[2]) + a2[1] * t[1]
        bad = False
        for j in range(3):
            k[j] = (a2[j] - dot * t[j]) / sp2
            if not math.isfinite(k[j]):
                bad = True
        if bad:
            for j in range(3):
                k[j] = np.inf
        # feed_limit_components: command, axial velocity, chord, centripetal
        axial = np.inf
        finite_t = True
        for j in range(3):
            ta = abs(t[j])
            if not math.isfinite(t[j]):
                finite_t = False
            x = vel[j] / ta if ta > 0 else np.inf
            axial = min(axial, x)
        if not finite_t:
            axial = 0.0
        rho = 1.0 / kappa if kappa > 0 else np.inf
        if math.isinf(rho) or 2.0 * rho <= delta:
            chord = np.inf
        else:
            chord = two_over_ts * math.sqrt(max(2.0 * rho * delta - delta * delta, 0.0))
        if math.isnan(kappa):
            chord = 0.0
        cen = np.inf
        for j in range(3):
            ka = abs(k[j])
            x = math.sqrt(acc[j] / ka) if ka > 0 else np.inf
            cen = min(cen, x)
        best = feed
        for x in (min(axial, feed), min(chord, feed), min(cen, feed)):
            if math.isnan(x):
                x = 0.0
            elif x == np.inf:
                x = feed
            best = min(best, x)
        if has_cap:
            c = min(_cap_at(s[i], cap_s, cap_v, True), _cap_at(s[i], cap_s, cap_v, False))
            best = min(best, c)
        vlim[i] = best
        # np.nan_to_num: the tangent's NaN → 0, κN's inf → the largest float
        for j in range(3):
            x = t[j]
            if math.isnan(x):
                x = 0.0
            elif x == np.inf:
                x = maxf
            elif x == -np.inf:
                x = -maxf
            tangent[i, j] = x
            y = k[j]
            kn[i, j] = maxf if y == np.inf else (-maxf if y == -np.inf else y)
    return True


@numba.njit(cache=True, nogil=True, inline="always")
def _np_min(a, b):
    """np.minimum of two floats (a NaN either side wins)."""
    if math.isnan(a) or math.isnan(b):
        return math.nan
    return a if a <= b else b


@numba.njit(cache=True, nogil=True, error_model="numpy")
def window_feed_limit(s, vlim, tan, kn, acc, vel, feed, delta, two_over_ts, cap_s, cap_v, out):
    """window_check.BlockCheck._feed_limit point by point into ``out`` (the same operations in the
    same order as its numpy form, value for value): ``vlim`` where the centripetal part
    √(A_j/|κN_j|) does not bind, else lifted to min(axial velocity, chord, command, cap)."""
    n, d = tan.shape
    has_cap = cap_s.size > 0
    for i in range(n):
        cen = np.inf
        other = np.inf
        ksum = 0.0
        finite = True
        for j in range(d):
            k = abs(kn[i, j])
            t = abs(tan[i, j])
            if not math.isfinite(k):
                finite = False
            x = math.sqrt(acc[j] / k) if k > 0.0 else np.inf
            cen = x if x < cen else cen      # np.min: no NaN here (k > 0, A_j > 0)
            y = vel[j] / t if t > 0.0 else np.inf
            other = y if y < other else other
            ksum = ksum + k * k if j > 0 else k * k
        kappa = math.sqrt(ksum)
        rho = 1.0 / kappa if kappa > 0.0 else np.inf
        if math.isinf(rho) or 2.0 * rho <= delta:
            chord = np.inf
        else:
            c = 2.0 * rho * delta - delta * delta
            chord = two_over_ts * math.sqrt(c if (c >= 0.0 or math.isnan(c)) else 0.0)
        other = _np_min(_np_min(other, chord), feed)
        if has_cap:
            other = _np_min(other, _np_min(_cap_at(s[i], cap_s, cap_v, True), _cap_at(s[i], cap_s, cap_v, False)))
        v = vlim[i]
        if finite and cen > 0.0 and cen < other and abs(v - cen) <= 1e-9 * cen:
            out[i] = math.nan if (math.isnan(v) or math.isnan(other)) else (v if v >= other else other)
        else:
            out[i] = v
