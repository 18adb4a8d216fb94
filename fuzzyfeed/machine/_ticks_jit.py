"""The servo-tick loop compiled by numba (see :mod:`fuzzyfeed.machine.stream`): one pass over the
ticks of a planned motion, nothing kept per tick. It does, tick by tick, what
:meth:`~fuzzyfeed.machine.planner.Plan.sample`, :func:`~fuzzyfeed.machine.servo.following_errors`
and :func:`~fuzzyfeed.machine.contour.windowed_distance` do on whole arrays in
:func:`~fuzzyfeed.machine.trace.trace_motion` (the reference the tests hold it to)."""

from __future__ import annotations

import math

import numba
import numpy as np

#: Histogram of the contour error (µm): linear bins of HIST_STEP_UM below HIST_LINEAR_UM, then
#: logarithmic bins of relative width HIST_LOG_STEP (≤ 0.05 µm at 500 µm); the last bin is open.
HIST_STEP_UM = 0.05
HIST_LINEAR_UM = 500.0
HIST_LOG_STEP = 1e-4
HIST_BINS = 10_000 + 80_000

# indices into the float state vector
S_MAX, S_MAX_T, S_MAX_X, S_AIR, S_AIR_T, S_AIR_X, S_N_PART, S_N_AIR, S_N_SKIP, S_SKIP_MAX, S_LAST, S_N_LEAP = \
    0, 1, 2, 5, 6, 7, 10, 11, 12, 13, 14, 15
FSTATE_SIZE = 16
# indices into the int state vector
I_MAX_SEG, I_AIR_SEG, I_AIR_NEAR, I_EV_N, I_K0, I_K1, I_K2, I_K3, I_K4, I_SEG, I_NEAR, I_RIGHT, I_LEFT, \
    I_LEAP = range(14)
ISTATE_SIZE = 14
#: A window of at most this many blocks is scanned segment by segment (the boxes cost more there).
SCAN_BLOCKS = 3
#: Segments of the fast path's bound: the last tick's nearest and the next ones of the window.
BOUND_SEGMENTS = 4
#: The fast path tries a tick's bound only when the last measured tick's error (searched or
#: bounded) was at most this many times the threshold (the error moves little from tick to tick;
#: this only saves the bound's cost where it would fail, the answers do not depend on it).
TRY_FACTOR = 4.0
#: The fewest ticks a leap (:func:`leap_histogram`) is taken over.
LEAP_MIN_TICKS = 8


@numba.njit(cache=True, nogil=True)
def hist_bin(v_um):
    if v_um < HIST_LINEAR_UM:
        return int(v_um / HIST_STEP_UM)
    b = 10_000 + int(math.log(v_um / HIST_LINEAR_UM) / math.log1p(HIST_LOG_STEP))
    return min(b, HIST_BINS - 1)


@numba.njit(cache=True, nogil=True)
def count_on_part(fstate, hist, seg_max, seg, dist_mm):
    """One tick of the tool on the part with contour error ``dist_mm`` (searched, or the fast path's
    bound): counted, binned in µm (:func:`hist_bin`), and kept as its segment's largest if it is."""
    fstate[S_N_PART] += 1.0
    hist[hist_bin(dist_mm * 1e3)] += 1
    if dist_mm > seg_max[seg]:
        seg_max[seg] = dist_mm


@numba.njit(cache=True, nogil=True)
def _search_right(a, x):
    lo, hi = 0, a.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if x < a[mid]:
            hi = mid
        else:
            lo = mid + 1
    return lo


@numba.njit(cache=True, nogil=True)
def _search_left(a, x):
    lo, hi = 0, a.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if a[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@numba.njit(cache=True, nogil=True)
def _walk_right(a, x, c):
    """_search_right(a, x) (the count of a ≤ x, a sorted) walked from the count ``c`` of a nearby
    x (-1: none, binary search): the window moves a few vertices per tick."""
    if c < 0:
        return _search_right(a, x)
    while c < a.shape[0] and a[c] <= x:
        c += 1
    while c > 0 and a[c - 1] > x:
        c -= 1
    return c


@numba.njit(cache=True, nogil=True)
def _walk_left(a, x, c):
    """_search_left(a, x) (the count of a < x, a sorted) walked from ``c`` as :func:`_walk_right`."""
    if c < 0:
        return _search_left(a, x)
    while c < a.shape[0] and a[c] < x:
        c += 1
    while c > 0 and a[c - 1] >= x:
        c -= 1
    return c


@numba.njit(cache=True, nogil=True)
def _seg_d2(points, q0, q1, q2, jj):
    """Squared distance from q to segment jj, and the foot's fraction t (the scan's operations)."""
    dx = points[jj + 1, 0] - points[jj, 0]
    dy = points[jj + 1, 1] - points[jj, 1]
    dz = points[jj + 1, 2] - points[jj, 2]
    l2 = (dx * dx + dy * dy) + dz * dz
    r0 = q0 - points[jj, 0]
    r1 = q1 - points[jj, 1]
    r2 = q2 - points[jj, 2]
    tt = ((r0 * dx + r1 * dy) + r2 * dz) / l2
    tt = min(max(tt, 0.0), 1.0)
    o0 = r0 - dx * tt
    o1 = r1 - dy * tt
    o2 = r2 - dz * tt
    return (o0 * o0 + o1 * o1) + o2 * o2, tt


@numba.njit(cache=True, nogil=True)
def nearest_scan(points, q0, q1, q2, i_lo, i_hi):
    """The nearest of segments i_lo … i_hi − 1 to q: (index, foot fraction, squared distance); the
    first one reaching the least squared distance (the reference scan, every segment)."""
    best_d2 = np.inf
    best_j = i_lo
    best_t = 0.0
    for jj in range(i_lo, i_hi):
        d2, tt = _seg_d2(points, q0, q1, q2, jj)
        if d2 < best_d2:
            best_d2 = d2
            best_j = jj
            best_t = tt
    return best_j, best_t, best_d2


@numba.njit(cache=True, nogil=True)
def nearest_pruned(points, q0, q1, q2, i_lo, i_hi, seed, box_lo, box_hi, block, slack):
    """:func:`nearest_scan`'s answer (same index, fraction and squared distance), skipping blocks.

    Bound: every point X of a segment of block b lies in the block's bounding box, so
    |q − X| ≥ dist(q, box_b). Start from the segment ``seed`` (the last tick's nearest, clipped to
    the window) with the distance d*; a block with dist(q, box_b) > d* + slack holds no segment at
    d* or nearer (slack covers the rounding of both sides: far above it, here 1e-9 mm per mm of
    coordinate), so only the other blocks are scanned, in order; ties go to the lower index, as
    in the scan (it keeps the first of equal distances)."""
    j0 = min(max(seed, i_lo), i_hi - 1)
    slack = slack + 1e-12 * ((abs(q0) + abs(q1)) + abs(q2))
    best_d2, best_t = _seg_d2(points, q0, q1, q2, j0)
    best_j = j0
    lim = math.sqrt(best_d2) + slack
    lim2 = lim * lim
    for b in range(i_lo // block, (i_hi - 1) // block + 1):
        g0 = max(box_lo[b, 0] - q0, q0 - box_hi[b, 0], 0.0)
        g1 = max(box_lo[b, 1] - q1, q1 - box_hi[b, 1], 0.0)
        g2 = max(box_lo[b, 2] - q2, q2 - box_hi[b, 2], 0.0)
        if (g0 * g0 + g1 * g1) + g2 * g2 > lim2:
            continue
        for jj in range(max(b * block, i_lo), min((b + 1) * block, i_hi)):
            d2, tt = _seg_d2(points, q0, q1, q2, jj)
            if d2 < best_d2 or (d2 == best_d2 and jj < best_j):
                if d2 < best_d2:
                    lim = math.sqrt(d2) + slack
                    lim2 = lim * lim
                best_d2 = d2
                best_j = jj
                best_t = tt
    return best_j, best_t, best_d2


@numba.njit(cache=True, nogil=True)
def nearest_bound(points, q0, q1, q2, i_lo, i_hi, seed, scale):
    """An upper bound on :func:`nearest_scan`'s distance over segments i_lo … i_hi − 1, times
    ``scale``: the least distance over the segment ``seed`` (clipped to the window) and the next
    ones of the window while it decreases (BOUND_SEGMENTS at most: the tool moves forward), with
    the segment reaching it. The scan takes the minimum of the same floats (:func:`_seg_d2`) over a
    set that holds these segments, so its answer is ≤ this one bit for bit (no rounding slack)."""
    j0 = min(max(seed, i_lo), i_hi - 1)
    best_d2, _ = _seg_d2(points, q0, q1, q2, j0)
    best_j = j0
    for jj in range(j0 + 1, min(j0 + BOUND_SEGMENTS, i_hi)):
        d2, _ = _seg_d2(points, q0, q1, q2, jj)
        if not d2 < best_d2:
            break
        best_d2 = d2
        best_j = jj
    return best_j, math.sqrt(best_d2) * scale


@numba.njit(cache=True, nogil=True)
def leap_histogram(hist, p_mm, decay, slack, n):
    """Count the bounds p·A^i + slack, i = 1 … n (decreasing), into ``hist`` bin by bin (not tick by
    tick): from the first uncounted i, every i' up to the last one with p·A^i' + slack at or above
    the bin's lower edge (log of the geometric term) goes to the bin of the i's value — each tick
    in the bin of a value at or above its own."""
    i = 1
    log_a = math.log(decay)
    while i <= n:
        v = p_mm * decay ** i + slack
        b = hist_bin(v * 1e3)
        lo_mm = (b * HIST_STEP_UM if b < 10_000 else
                 HIST_LINEAR_UM * math.exp((b - 10_000) * math.log1p(HIST_LOG_STEP))) * 1e-3
        if lo_mm <= slack or p_mm <= 0.0:
            last = n
        else:
            last = int(math.floor(math.log((lo_mm - slack) / p_mm) / log_a))
            last = min(max(last, i), n)
        hist[b] += last - i + 1
        i = last + 1


@numba.njit(cache=True, nogil=True)
def leap_end(t_start, total, ts, seg, k, k_end):
    """The last tick ≤ k_end commanded on segment ``seg`` (the tick loop's rule: tick j is on the
    segment before ``seg`` + 1 while min(j·Ts, T) < t_start[seg + 1]; the last segment keeps the
    rest), from tick k on it. ``t_start``: n + 1 entries, the last the end time."""
    n = t_start.shape[0] - 1
    if seg + 1 >= n:
        return k_end
    tn = t_start[seg + 1]
    j = max(min(int(tn / ts), k_end), k)
    while j > k and min(j * ts, total) >= tn:
        j -= 1
    while j < k_end and min((j + 1) * ts, total) < tn:
        j += 1
    return j


@numba.njit(cache=True, nogil=True)
def run_ticks(points, unit, length, s_vertex, t_start, v_entry, v_peak, acc, t_acc, t_cruise,
              measured, fb, fa, ts, total, k_from, k_measure, k_end, k_stop, lookback, margin, keep_mm,
              y_hist, x_hist, prev, s_ring, seg_ring, seg_max, hist, fstate, istate, ev_f, ev_i,
              box_lo, box_hi, block, slack, unmeasured_cum, skip_mm, bound_scale, leap_decay):
    """Ticks k_from … k_stop (inclusive; k_stop ≤ k_end, the last tick of the run: the leap's
    bound) of a plan; ticks before k_measure only run the servo. A run stopped at k_stop < k_end
    resumes at k_stop + 1 with the state left (on another stretch of the same plan, its segment
    indices moved: :mod:`fuzzyfeed.machine.chain_pass`).

    The nearest segment of the window is found as the plain scan would (the least squared distance,
    the first segment reaching it), skipping every block of ``block`` segments whose bounding box
    ``box_lo``/``box_hi`` is farther than the best distance found so far plus ``slack``
    (:func:`nearest_pruned`), a window of at most SCAN_BLOCKS blocks segment by segment, and the
    window's ends walked from the last tick's; ``block`` = 0 is the plain pass (binary searches for
    the window's ends, every segment of it scanned), the anchor the tests and benchmark hold it to.

    The servo state (y_hist: last two errors per axis, x_hist: last two tick velocities, prev: the
    last set-point) and the lookback ring buffers are read and left for the next call. Measured
    ticks update ``seg_max`` (per commanded segment, in the part), ``hist`` and ``fstate``/
    ``istate``; ticks over ``keep_mm`` in the part are events, run-length merged while their
    (segment, lookback, nearest, 0.1 mm bin, at-rest) key holds — the most demanding one
    (smallest speed/√error) kept. Returns the tick to resume at (k_stop + 1 when done; earlier
    when ``ev_f`` is full: drain it and call again).

    **Fast path** (``skip_mm`` > 0): a measured tick whose window holds no unmeasured segment
    (``unmeasured_cum``: their running count, n + 1 entries) and whose upper bound
    (:func:`nearest_bound`, times ``bound_scale``: 1, other values only in the tests) is at most
    ``skip_mm`` and ``keep_mm`` is not searched: its bound goes to the histogram and ``seg_max``
    (the scan's distance is ≤ it: the tick is in the part, in a bin at or below its bound's, no
    event) and is counted in fstate[S_N_SKIP], the largest in fstate[S_SKIP_MAX]; the largest
    error and where (fstate[S_MAX…]) come from searched ticks only (the caller re-runs when a
    bound reaches them).

    **Leap** (``leap_decay`` = A > 0: a first-order loop, the same on every axis,
    e_k+1 = A·e_k + B·v_k+1, B ≥ 0). After a bounded tick k commanded on segment j (unit u,
    length L, the set-point at d along it), every later tick on j has its velocity along u, so the
    error's part across u decays as A^i: e_k+i = λ_k+i·u + A^i·p_k, and λ stays ≥ 0 when λ_k ≥ 0;
    the tool's place along j, σ = d − λ, then never decreases (σ_k+1 − σ_k = Δd·(1 − B/Ts) +
    (1 − A)·λ_k, B ≤ Ts) nor passes d ≤ L. So with λ_k ≥ 0 and σ_k ≥ 0 the tool is over j at
    every tick k+1 … k' (the last on j) at distance |p_k|·A^i from it: j is in each window, so
    the searched error would be at most that (plus ``slack`` for rounding). When |p_k| + slack is
    within the threshold and no window up to k' holds an unmeasured segment, the ticks k+1 … k'
    are counted from that closed form (:func:`leap_histogram`) and only their set-points and servo
    are stepped (the same floats as the tick pass: the state after the leap is the tick pass's).
    Second-order loops and axes with different loops are not leapt (every tick is bounded)."""
    n = length.shape[0]
    ring = s_ring.shape[0]
    cap = ev_f.shape[0]
    seg = istate[I_SEG]
    for k in range(k_from, k_stop + 1):
        if istate[I_EV_N] >= cap:         # one free slot at each tick's start: resume here
            istate[I_SEG] = seg
            return k
        t = min(k * ts, total)
        while seg + 1 < n and t_start[seg + 1] <= t:
            seg += 1
        tau = t - t_start[seg]
        v0 = v_entry[seg]
        vp = v_peak[seg]
        a = acc[seg]
        ta = t_acc[seg]
        tc = t_cruise[seg]
        t1 = min(tau, ta)
        d = v0 * t1 + 0.5 * a * t1 * t1
        t2 = min(max(tau - ta, 0.0), tc)
        d += vp * t2
        t3 = max(tau - ta - tc, 0.0)
        d += vp * t3 - 0.5 * a * t3 * t3
        d = min(d, length[seg])
        c0 = points[seg, 0] + unit[seg, 0] * d
        c1 = points[seg, 1] + unit[seg, 1] * d
        c2 = points[seg, 2] + unit[seg, 2] * d
        s_cmd = s_vertex[seg] + math.sqrt(((c0 - points[seg, 0]) ** 2 + (c1 - points[seg, 1]) ** 2)
                                          + (c2 - points[seg, 2]) ** 2)
        # servo: e_k = (b1 v_k-1 + b2 v_k-2 − a1 e_k-1 − a2 e_k-2) / a0 (b0 = 0: strictly proper);
        # a fresh start (istate[I_K0] == -1) is at rest on its first set-point
        fresh = istate[I_K0] == -1
        cmd = (c0, c1, c2)
        e0 = e1 = e2 = 0.0
        for j in range(3):
            if fresh:
                x_hist[j, 0] = x_hist[j, 1] = y_hist[j, 0] = y_hist[j, 1] = 0.0
                ej = 0.0
            else:
                x_hist[j, 1] = x_hist[j, 0]
                x_hist[j, 0] = (cmd[j] - prev[j]) / ts
                ej = (fb[j, 1] * x_hist[j, 0] + fb[j, 2] * x_hist[j, 1]
                      - fa[j, 1] * y_hist[j, 0] - fa[j, 2] * y_hist[j, 1]) / fa[j, 0]
                y_hist[j, 1] = y_hist[j, 0]
                y_hist[j, 0] = ej
            prev[j] = cmd[j]
            if j == 0:
                e0 = ej
            elif j == 1:
                e1 = ej
            else:
                e2 = ej
        if fresh:
            istate[I_K0] = 0
            speed = 0.0
        else:
            speed = (s_cmd - s_ring[(k - 1) % ring]) / ts
        s_ring[k % ring] = s_cmd
        seg_ring[k % ring] = seg
        if k <= istate[I_LEAP]:       # counted by the leap that covers this tick
            continue
        if k < k_measure or not measured[seg]:
            continue
        kb = max(k - lookback, 0)
        s_back = s_ring[kb % ring]
        seg_back = seg_ring[kb % ring]
        q0, q1, q2 = c0 - e0, c1 - e1, c2 - e2
        s_lo = s_back - margin
        s_hi = s_cmd + margin
        if block > 0:   # the window's ends walked from the last tick's (the same counts)
            c_right = _walk_right(s_vertex, s_lo, istate[I_RIGHT])
            c_left = _walk_left(s_vertex, s_hi, istate[I_LEFT])
            istate[I_RIGHT] = c_right
            istate[I_LEFT] = c_left
        else:
            c_right = _search_right(s_vertex, s_lo)
            c_left = _search_left(s_vertex, s_hi)
        i_lo = min(max(c_right - 1, 0), n - 1)
        i_hi = min(max(c_left, i_lo + 1), n)
        seed = istate[I_NEAR]
        if (skip_mm > 0.0 and fstate[S_LAST] <= TRY_FACTOR * skip_mm
                and unmeasured_cum[i_hi] == unmeasured_cum[i_lo]):
            limit = min(skip_mm, keep_mm)
            bj, bound = nearest_bound(points, q0, q1, q2, i_lo, i_hi, seed, bound_scale)
            fstate[S_LAST] = bound
            if bound <= limit:
                istate[I_NEAR] = bj
                count_on_part(fstate, hist, seg_max, seg, bound)
                fstate[S_N_SKIP] += 1.0
                if bound > fstate[S_SKIP_MAX]:
                    fstate[S_SKIP_MAX] = bound
                if leap_decay > 0.0 and k < k_end:
                    k_last = leap_end(t_start, total, ts, seg, k, k_end)
                    if k_last - k >= LEAP_MIN_TICKS:
                        # the error across and along the segment, and the tool's place along it
                        lam = (e0 * unit[seg, 0] + e1 * unit[seg, 1]) + e2 * unit[seg, 2]
                        p0 = e0 - lam * unit[seg, 0]
                        p1 = e1 - lam * unit[seg, 1]
                        p2 = e2 - lam * unit[seg, 2]
                        p = math.sqrt((p0 * p0 + p1 * p1) + p2 * p2)
                        sl = slack * (1.0 + 1e-6 * (k_last - k))
                        if lam >= 0.0 and d - lam >= 0.0 and (p + sl) * bound_scale <= limit:
                            s_top = s_vertex[min(seg + 1, n)] + margin + sl
                            c_top = _search_left(s_vertex, s_top)
                            i_top = min(max(c_top, seg + 1), n)
                            if unmeasured_cum[i_top] == unmeasured_cum[i_lo]:
                                m_leap = k_last - k
                                leap_histogram(hist, p * bound_scale, leap_decay, sl * bound_scale, m_leap)
                                top = (p * leap_decay + sl) * bound_scale
                                if top > seg_max[seg]:
                                    seg_max[seg] = top
                                if top > fstate[S_SKIP_MAX]:
                                    fstate[S_SKIP_MAX] = top
                                fstate[S_N_PART] += m_leap
                                fstate[S_N_SKIP] += m_leap
                                fstate[S_N_LEAP] += m_leap
                                istate[I_LEAP] = k_last
                continue
            seed = bj
        if block > 0 and i_hi - i_lo > SCAN_BLOCKS * block:
            best_j, best_t, best_d2 = nearest_pruned(points, q0, q1, q2, i_lo, i_hi, seed,
                                                     box_lo, box_hi, block, slack)
        else:
            best_j, best_t, best_d2 = nearest_scan(points, q0, q1, q2, i_lo, i_hi)
        istate[I_NEAR] = best_j
        dist = math.sqrt(best_d2)
        fstate[S_LAST] = dist
        f0 = points[best_j, 0] + (points[best_j + 1, 0] - points[best_j, 0]) * best_t
        f1 = points[best_j, 1] + (points[best_j + 1, 1] - points[best_j, 1]) * best_t
        f2 = points[best_j, 2] + (points[best_j + 1, 2] - points[best_j, 2]) * best_t
        if not measured[best_j]:
            # the tool is nearest a segment not measured (a rapid it lags behind): in the air
            fstate[S_N_AIR] += 1.0
            if dist > fstate[S_AIR]:
                fstate[S_AIR] = dist
                fstate[S_AIR_T] = t
                fstate[S_AIR_X] = f0
                fstate[S_AIR_X + 1] = f1
                fstate[S_AIR_X + 2] = f2
                istate[I_AIR_SEG] = seg
                istate[I_AIR_NEAR] = best_j
            continue
        count_on_part(fstate, hist, seg_max, seg, dist)
        if dist > fstate[S_MAX]:
            fstate[S_MAX] = dist
            fstate[S_MAX_T] = t
            fstate[S_MAX_X] = f0
            fstate[S_MAX_X + 1] = f1
            fstate[S_MAX_X + 2] = f2
            istate[I_MAX_SEG] = seg
        if dist > keep_mm:
            sbin = int(math.floor((s_vertex[best_j] + best_t * length[best_j]) / 0.1))
            rest = 1 if speed <= 0.0 else 0
            m = istate[I_EV_N]
            same = (m > 0 and istate[I_K1] == seg_back and istate[I_K2] == best_j and istate[I_K3] == sbin
                    and istate[I_K4] == rest and ev_i[m - 1, 0] == seg)
            if same:
                if speed * math.sqrt(ev_f[m - 1, 1]) < ev_f[m - 1, 2] * math.sqrt(dist):
                    ev_f[m - 1, 0] = t
                    ev_f[m - 1, 1] = dist
                    ev_f[m - 1, 2] = speed
                    ev_f[m - 1, 3] = f0
                    ev_f[m - 1, 4] = f1
                    ev_f[m - 1, 5] = f2
            else:
                ev_f[m, 0] = t
                ev_f[m, 1] = dist
                ev_f[m, 2] = speed
                ev_f[m, 3] = f0
                ev_f[m, 4] = f1
                ev_f[m, 5] = f2
                ev_i[m, 0] = seg
                ev_i[m, 1] = best_j
                ev_i[m, 2] = seg_back
                istate[I_EV_N] = m + 1
                istate[I_K1] = seg_back
                istate[I_K2] = best_j
                istate[I_K3] = sbin
                istate[I_K4] = rest
    istate[I_SEG] = seg
    return k_stop + 1
