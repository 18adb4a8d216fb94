"""The exact Mamdani centroid in numpy: the small-call form of :mod:`fuzzyfeed.fuzzy._kernel`.

Same construction as the compiled loop (seed 002 eq. 11 with the sums replaced by integrals): on
each interval of the static cut of the output axis every fired term is one line clipped at its
level; the aggregated set A = max of those bends only at the candidate points (a line meets a clip
level or another line), so ∫A and ∫yA are summed in closed form between the sorted candidates.
Vectorised over the points instead of looping over them; the candidates are the same multiset and
are summed in the same order, so both forms give the same floats.
"""

from __future__ import annotations

import numpy as np


def centroid_numpy(h: np.ndarray, x_int: np.ndarray, act_ptr: np.ndarray, act_term: np.ndarray,
                   act_m0: np.ndarray, act_m1: np.ndarray, no_fire: float) -> np.ndarray:
    """Centroid of A(y) = max_o min(T_o(y), h_o) for each row of the clip levels ``h`` (N, n_out);
    ``no_fire`` where nothing fires."""
    n = h.shape[0]
    area = np.zeros(n)
    moment = np.zeros(n)
    for q in range(x_int.size - 1):
        lo, hi = int(act_ptr[q]), int(act_ptr[q + 1])
        if hi == lo:
            continue
        s0, s1 = act_m0[lo:hi], act_m1[lo:hi]
        sh = h[:, act_term[lo:hi]]          # (N, na) clip level of each term non-zero here
        on = sh > 0.0
        na = hi - lo
        cands = [np.zeros(n), np.ones(n)]
        for a in range(na):
            da = s1[a] - s0[a]
            for b in range(na):             # line a meets the clip level of b
                lv = sh[:, b]
                ok = on[:, a] & on[:, b] & (((s0[a] < lv) & (lv < s1[a])) | ((s1[a] < lv) & (lv < s0[a])))
                with np.errstate(divide="ignore", invalid="ignore"):
                    cands.append(np.where(ok, (lv - s0[a]) / da, np.nan))
            for b in range(a + 1, na):      # line a meets line b
                e0, e1 = s0[a] - s0[b], s1[a] - s1[b]
                if (e0 < 0.0 < e1) or (e1 < 0.0 < e0):
                    cands.append(np.where(on[:, a] & on[:, b], e0 / (e0 - e1), np.nan))
        cand = np.sort(np.column_stack(cands), axis=1)   # invalid (NaN) candidates sort last
        x0 = x_int[q]
        width = x_int[q + 1] - x0
        prev_t = prev_v = None
        for m in range(cand.shape[1]):
            tt = cand[:, m]
            v = np.zeros(n)
            for a in range(na):
                la = np.minimum(s0[a] + (s1[a] - s0[a]) * tt, sh[:, a])
                v = np.where(on[:, a], np.maximum(v, la), v)
            if prev_t is not None:
                dt = tt - prev_t
                ok = dt > 0.0
                xa = x0 + prev_t * width
                xb = x0 + tt * width
                dx = dt * width
                area = np.where(ok, area + 0.5 * dx * (prev_v + v), area)
                moment = np.where(ok, moment + dx * (prev_v * (2.0 * xa + xb) + v * (xa + 2.0 * xb)) / 6.0,
                                  moment)
            prev_t, prev_v = tt, v
    out = np.full(n, float(no_fire))
    np.divide(moment, area, out=out, where=area > 0.0)
    return out
