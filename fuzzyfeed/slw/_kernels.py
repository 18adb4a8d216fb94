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
def bisect_peak(v_s, v_e, length, good, bad, acc, jerk, seven, steps):
    """The peak v nearest ``bad`` with D(v_s, v) + D(v, v_e) ≤ length (Table 1, approach 2), by
    bisection as profile._bisect."""
    for _ in range(steps):
        mid = 0.5 * (good + bad)
        if (transition_distance(v_s, mid, acc, jerk, seven)
                + transition_distance(mid, v_e, acc, jerk, seven)) <= length:
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
