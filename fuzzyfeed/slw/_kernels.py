"""Compiled loops of the SLW package (numba, cached on disk).

Every kernel is a module-level ``njit(cache=True)`` function that calls only other module-level
kernels: numba then keys the on-disk cache by this file and the function's name, so a second
process loads the compiled code instead of compiling it again (a kernel built inside a factory
and closing over another dispatcher gets a new cache entry in every process). This module
imports numba at import time; import it lazily (inside the functions that need it).
"""

from __future__ import annotations

import math

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


@numba.njit(cache=True, nogil=True)
def _branch_time(x0, acc, width):
    """∫₀^width dσ/√(x0 + 2·acc·σ) = 2·width/(√x1 + √x0), x1 = x0 + 2·acc·width (acc ≥ 0; stable
    as acc → 0; inf from rest with acc = 0)."""
    if width <= 0.0:
        return 0.0
    m = math.sqrt(x0 + 2.0 * acc * width) + math.sqrt(x0)
    return 2.0 * width / m if m > 0.0 else np.inf


@numba.njit(cache=True, nogil=True)
def interval_times(ds, x, x_cap, tangent, kn, axis_acc, out):
    """Per grid interval, the time of the phase-plane envelope inside it, into ``out``:
    ∫ dσ/√E(σ), E(σ) = min(x_i + 2·a_f·σ, x_i+1 + 2·a_b·(ds − σ), c) with a_f the hardest
    acceleration at point i and a_b the hardest braking at point i+1 (both from
    :func:`acc_range` at the points' own x, as the passes use them; negatives taken as 0) and c
    the larger of the two points' pointwise limits (``x_cap``). Forward branch up to the crossing
    σ* of the two lines, backward after it, each cruising at c where it reaches it. E ≥ the line
    x_i → x_i+1 that :func:`travel_time` integrates (the passes keep x_i+1 ≤ x_i + 2·a_f·ds and
    x_i ≤ x_i+1 + 2·a_b·ds), so each interval's time is at most its 2·ds/(v_i + v_i+1): the
    same where the line is the envelope (acceleration-limited from end to end), shorter where an
    end is held by a limit (leaving a corner or a rest, reaching a feed or a cap)."""
    n = x.size
    for i in range(n - 1):
        h = ds[i]
        if h <= 0.0:
            out[i] = 0.0
            continue
        x0, x1 = max(x[i], 0.0), max(x[i + 1], 0.0)
        c = max(x_cap[i], x_cap[i + 1], x0, x1)
        if c <= 0.0:  # a stationary stretch: never passed
            out[i] = np.inf
            continue
        lo0, hi0 = acc_range(x0, tangent[i], kn[i], axis_acc)
        lo1, hi1 = acc_range(x1, tangent[i + 1], kn[i + 1], axis_acc)
        af, ab = max(hi0, 0.0), max(-lo1, 0.0)
        if not (af < np.inf):
            af = 1e300
        if not (ab < np.inf):
            ab = 1e300
        # the crossing of x0 + 2·af·σ and x1 + 2·ab·(h − σ), clipped to [0, h]
        den = 2.0 * (af + ab)
        if den > 0.0:
            sig = min(max((x1 + 2.0 * ab * h - x0) / den, 0.0), h)
        else:
            sig = h if x0 <= x1 else 0.0
        # forward part [0, sig]: rises from x0 at af until c
        rise = (c - x0) / (2.0 * af) if af > 0.0 else np.inf
        up = min(rise, sig)
        t = _branch_time(x0, af, up)
        if sig > up:
            t += (sig - up) / math.sqrt(c)
        # backward part [sig, h]: falls to x1 at ab, measured from the end
        w = h - sig
        fall = (c - x1) / (2.0 * ab) if ab > 0.0 else np.inf
        down = min(fall, w)
        t += _branch_time(x1, ab, down)
        if w > down:
            t += (w - down) / math.sqrt(c)
        out[i] = t


# ---------------------------------------------------------------------- transitions (profile.py)
# The same arithmetic as fuzzyfeed.slw.profile.transition_time / _bisect, compiled: the look-ahead
# calls the bisections ~10⁴ times on a long program, each ~40 distances (2·10⁶ Python calls).
@numba.njit(cache=True, nogil=True)
def transition_time(v_s, v_e, acc, jerk, seven):
    """Seven-phase ramp (``seven``) or seed 000's cosine, eq. (20): shortest T of v_s → v_e."""
    dv = abs(v_e - v_s)
    if dv < 1e-200:
        return 0.0
    if seven:
        if dv * jerk >= acc * acc:
            return dv / acc + acc / jerk
        return 2.0 * math.sqrt(dv / jerk)
    return max(math.pi * dv / (2.0 * acc), math.pi * math.sqrt(dv / (2.0 * jerk)))


@numba.njit(cache=True, nogil=True)
def transition_distance(v_s, v_e, acc, jerk, seven):
    """(v_s + v_e)·T/2 (eq. (21))."""
    return 0.5 * (v_s + v_e) * transition_time(v_s, v_e, acc, jerk, seven)


@numba.njit(cache=True, nogil=True)
def bisect_end(v_s, length, good, bad, acc, jerk, seven, steps):
    """The speed nearest ``bad`` with transition_distance(v_s, v) ≤ length, by bisection from
    ``good`` (holds) towards ``bad`` (fails), as profile._bisect."""
    for _ in range(steps):
        mid = 0.5 * (good + bad)
        if transition_distance(v_s, mid, acc, jerk, seven) <= length:
            good = mid
        else:
            bad = mid
        if abs(bad - good) <= 1e-11 * max(good, bad, 1.0):
            break
    return good


@numba.njit(cache=True, nogil=True)
def bisect_peak(v_s, v_e, length, good, bad, acc, jerk, seven, steps, acc_down):
    """The peak v nearest ``bad`` with D(v_s, v) + D(v, v_e) ≤ length (Table 1, approach 2), by
    bisection as profile._bisect; the rise under ``acc``, the fall under ``acc_down``."""
    for _ in range(steps):
        mid = 0.5 * (good + bad)
        if (transition_distance(v_s, mid, acc, jerk, seven)
                + transition_distance(mid, v_e, acc_down, jerk, seven)) <= length:
            good = mid
        else:
            bad = mid
        if abs(bad - good) <= 1e-11 * max(good, bad, 1.0):
            break
    return good


@numba.njit(cache=True, nogil=True)
def sample_segments(v0, v1, dur, jerk, start, half_ts):
    """A block's profile at ≥ 8 (≤ 20 000) even steps per segment of at most ``half_ts`` (each
    segment's ends included): s (from ``start``), v, a and the segment's index per sample — the
    cosine of seed 000 (eq. (17)-(18)) where jerk[k] is NaN, else the seven-phase ramp under that
    jerk (profile._seven_phase_state); a cruise where v0 = v1 or the duration is 0."""
    m = v0.size
    counts = np.empty(m, np.int64)
    total = 0
    for k in range(m):
        n = int(min(max(math.ceil(dur[k] / half_ts), 8), 20000))
        counts[k] = n + 1
        total += n + 1
    s = np.empty(total)
    v = np.empty(total)
    a = np.empty(total)
    seg = np.empty(total, np.int64)
    at = 0
    offset = start
    for k in range(m):
        n = counts[k] - 1
        T = dur[k]
        dv = v1[k] - v0[k]
        step = T / n
        seven = not math.isnan(jerk[k])
        if seven and dv != 0.0 and T != 0.0:
            sign = 1.0 if dv > 0 else -1.0
            mag = abs(dv)
            t_j = 0.5 * (T - math.sqrt(max(T * T - 4.0 * mag / jerk[k], 0.0)))
            a_p = mag / (T - t_j)
            jr = a_p / t_j
            whole = 0.5 * (v0[k] + v1[k]) * T
            v_j = v0[k] + sign * 0.5 * a_p * t_j
            s_j = v0[k] * t_j + sign * jr * t_j ** 3 / 6.0
        for i in range(n + 1):
            tau = T if i == n else i * step
            if dv == 0.0 or T == 0.0:
                p, vel, acc = v0[k] * tau, v0[k], 0.0
            elif seven:
                tau = min(max(tau, 0.0), T)
                r = T - tau
                if tau < t_j:
                    p = v0[k] * tau + sign * jr * tau ** 3 / 6.0
                    vel = v0[k] + sign * 0.5 * jr * tau * tau
                    acc = sign * jr * tau
                elif r < t_j:
                    p = whole - (v1[k] * r - sign * jr * r ** 3 / 6.0)
                    vel = v1[k] - sign * 0.5 * jr * r * r
                    acc = sign * jr * r
                else:
                    mm = tau - t_j
                    p = s_j + v_j * mm + sign * 0.5 * a_p * mm * mm
                    vel = v_j + sign * a_p * mm
                    acc = sign * a_p
            else:
                w = math.pi / T
                c = math.cos(w * tau)
                sn = math.sin(w * tau)
                vel = v0[k] + 0.5 * dv * (1.0 - c)
                p = v0[k] * tau + 0.5 * dv * (tau - sn / w)
                acc = 0.5 * dv * w * sn
            s[at] = p + offset
            v[at] = vel
            a[at] = acc
            seg[at] = k
            at += 1
        offset += 0.5 * (v0[k] + v1[k]) * T
    return s, v, a, seg


# ---------------------------------------------------------------------- the block check (window_check.py)
# The per-block profile check ran ~10 numpy calls per block (interpolations, the axis ratio) on
# ~10⁵ blocks of a long program: the same arithmetic here, in one call, element for element as
# numpy computes it (the schedules stay byte-identical).
@numba.njit(cache=True, nogil=True)
def _interp_at(x, x0, x1, y0, y1, j, n):
    """np.interp at one x between (x0, y0) = (xp[j], fp[j]) and (x1, y1) = (xp[j+1], fp[j+1]),
    j the last index with xp[j] <= x (-1 if none; then y0 = fp[0]; j ≥ n − 1: y0 = fp[n − 1]),
    with numpy's own arithmetic: slope·(x − xp[j]) + fp[j], from the right end if that is NaN."""
    if math.isnan(x):
        return x
    if j < 0 or j >= n - 1 or x0 == x:
        return y0
    slope = (y1 - y0) / (x1 - x0)
    y = slope * (x - x0) + y0
    if math.isnan(y):
        y = slope * (x - x1) + y1
        if math.isnan(y) and y0 == y1:
            y = y0
    return y


@numba.njit(cache=True, nogil=True)
def interp_reference(s, ref_s, ref_vlim, ref_tan, ref_kn):
    """The path's feed limit, unit tangent and κN at arc lengths ``s``, each linear in s between
    the reference points: np.interp per column, value for value."""
    n = s.size
    m = ref_s.size
    d = ref_tan.shape[1]
    vlim = np.empty(n)
    tan = np.empty((n, d))
    kn = np.empty((n, d))
    idx = np.searchsorted(ref_s, s, side="right") - 1
    for i in range(n):
        j = idx[i]
        x = s[i]
        lo = 0 if j < 0 else min(j, m - 1)
        hi = min(lo + 1, m - 1)
        x0, x1 = ref_s[lo], ref_s[hi]
        vlim[i] = _interp_at(x, x0, x1, ref_vlim[lo], ref_vlim[hi], j, m)
        for c in range(d):
            tan[i, c] = _interp_at(x, x0, x1, ref_tan[lo, c], ref_tan[hi, c], j, m)
            kn[i, c] = _interp_at(x, x0, x1, ref_kn[lo, c], ref_kn[hi, c], j, m)
    return vlim, tan, kn


@numba.njit(cache=True, nogil=True)
def axis_ratio(v, a, tan, kn, axis_acc):
    """Worst |a·T_j + v²·κN_j|/A_j per sample, its axis (the first NaN's, as np.argmax), and the
    centripetal parts v²·κN."""
    n, d = tan.shape
    r = np.empty(n)
    worst = np.empty(n, np.int64)
    cen = np.empty((n, d))
    for i in range(n):
        vv = v[i] * v[i]
        best = -np.inf
        at = 0
        for j in range(d):
            c = vv * kn[i, j]
            cen[i, j] = c
            x = abs(a[i] * tan[i, j] + c) / axis_acc[j]
            if math.isnan(x):
                if not math.isnan(best):
                    best, at = x, j
            elif x > best and not math.isnan(best):
                best, at = x, j
        r[i] = best
        worst[i] = at
    return r, worst, cen


@numba.njit(cache=True, nogil=True)
def near_limits(v, vlim, r, feed, near):
    """Indices of the samples within ``near`` of a limit: r > near, or v > near·vlim where the
    feed limit is below the command feed."""
    n = v.size
    out = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        if r[i] > near or (v[i] > near * vlim[i] and vlim[i] < feed):
            out[m] = i
            m += 1
    return out[:m]


# ---------------------------------------------------------------------- the window's junction feeds (lookahead.py)
# profile.max_rise, _bisect_speed and lowest_end_speed, and SlidingWindow._plan's two scans over the
# window, compiled with the same arithmetic in the same order (Python's min/max spelled out): the
# window re-plans ~10⁵ times on a long program, each a Python call per block.
@numba.njit(cache=True, nogil=True)
def depressed_cubic(p, c):
    """profile._depressed_cubic: the real root w ≥ 0 of w³ + p·w − c = 0."""
    if p * p * p <= 1e-12 * c * c:
        w = c ** (1.0 / 3.0)
    else:
        r = math.sqrt(p / 3.0)
        w = 2.0 * r * math.sinh(math.asinh(1.5 * c / (p * r)) / 3.0)
    for _ in range(2):
        f = w * w * w + p * w - c
        w -= f / (3.0 * w * w + p) if w > 0.0 else 0.0
    return w


@numba.njit(cache=True, nogil=True)
def _pos(x):
    """Python's max(x, 0.0)."""
    return 0.0 if 0.0 > x else x


@numba.njit(cache=True, nogil=True)
def max_rise(v, length, acc, jerk, seven):
    """profile.max_rise: the largest Δv ≥ 0 with transition_distance(v, v + Δv) ≤ length."""
    if length <= 0.0:
        return 0.0
    if seven:
        w = depressed_cubic(2.0 * v, length * math.sqrt(jerk))
        if w * w * jerk <= acc * acc:
            return _pos(w * w)
        b = 2.0 * v / acc + acc / jerk
        c0 = 2.0 * length - 2.0 * v * acc / jerk
        return _pos(2.0 * c0 / (b + math.sqrt(b * b + 4.0 * c0 / acc)))
    q = 4.0 * acc * length / math.pi
    d_a = q / (v + math.sqrt(v * v + q))
    w = depressed_cubic(2.0 * v, 2.0 * length * math.sqrt(2.0 * jerk) / math.pi)
    ww = w * w
    return _pos(ww if ww < d_a else d_a)


@numba.njit(cache=True, nogil=True)
def bisect_speed(fixed, length, cap, acc, jerk, seven, steps):
    """profile._bisect_speed: the largest v in [fixed, cap] with transition_distance(fixed, v) ≤
    length (max_end_speed, max_start_speed)."""
    if cap <= fixed:
        return cap
    rise = max_rise(fixed, length, acc, jerk, seven)
    if fixed + rise >= cap:
        return cap
    v = fixed
    for shrink in (0.0, 1e-9, 1e-6, 1e-3):
        v = fixed + rise * (1.0 - shrink)
        if transition_distance(fixed, v, acc, jerk, seven) <= length:
            return v
    return bisect_end(fixed, length, fixed, v, acc, jerk, seven, steps)


@numba.njit(cache=True, nogil=True)
def lowest_end_speed(v_s, length, floor, acc, jerk, seven, steps):
    """profile.lowest_end_speed: an end speed near ``floor`` (≤ v_s) reachable within ``length``."""
    if floor >= v_s or transition_distance(v_s, floor, acc, jerk, seven) <= length:
        return v_s if v_s < floor else floor
    if transition_distance(v_s, 0.0, acc, jerk, seven) <= length:
        return bisect_end(v_s, length, 0.0, floor, acc, jerk, seven, steps)
    return bisect_end(v_s, length, v_s, floor, acc, jerk, seven, steps)


@numba.njit(cache=True, nogil=True)
def plan_window(lengths, accs, caps, v_first, end_feed, jerk, seven, steps, accs_down):
    """SlidingWindow._plan: the junction feeds of a window of n blocks (n + 1 junctions with caps
    ``caps``): a backward scan from min(cap, end_feed) at the last junction (max_start_speed: a
    fall, under ``accs_down``), then a forward scan from the committed ``v_first`` (max_end_speed:
    a rise, under ``accs``; or the hardest braking the block allows, under ``accs_down``, where a
    later junction is lower than the committed one can reach)."""
    n = lengths.size
    v = np.empty(n + 1)
    v[n] = end_feed if end_feed < caps[n] else caps[n]
    for i in range(n - 1, -1, -1):
        v[i] = bisect_speed(v[i + 1], lengths[i], caps[i], accs_down[i], jerk, seven, steps)
    v[0] = v_first
    for i in range(n):
        if v[i + 1] < v[i] and transition_distance(v[i], v[i + 1], accs_down[i], jerk, seven) > lengths[i]:
            v[i + 1] = lowest_end_speed(v[i], lengths[i], v[i + 1], accs_down[i], jerk, seven, steps)
        else:
            v[i + 1] = bisect_speed(v[i], lengths[i], v[i + 1], accs[i], jerk, seven, steps)
    return v
