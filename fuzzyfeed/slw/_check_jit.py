"""The tick check's ratios (slw/check.py, :func:`~fuzzyfeed.slw.check.tick_ratios` then
:func:`~fuzzyfeed.slw.check.worst`) in one compiled pass: no array per ratio over the ticks.

The same floating-point operations in the same order as the numpy lines (the chord's squares added in
order, as np.linalg.norm adds three; a difference then a division by Ts, then by the limit), and the
same choice of tick: the first of the largest (np.nanargmax), NaN (a corner's path jerk) skipped.
Checked bit for bit in tests/test_slw_check_jit.py. Module-level, no closure: numba's disk cache
serves every process.
"""

from __future__ import annotations

import math

import numba

#: The ratios: 0 feed, 1-3 velocity x y z, 4-6 acceleration x y z, 7 jerk, 8 path jerk.
N_RATIOS = 9


@numba.njit(cache=True, nogil=True, inline="always")
def _keep(r, best, where, k):
    """(ratio, tick) of the larger of ``r`` at tick ``k`` and the worst so far (``best`` at
    ``where``): NaN never wins (a comparison with NaN is false), the first of equal values stays.
    Scalars in and out: the worst values stay in registers through the loop."""
    if r > best:
        return r, k
    return best, where


@numba.njit(cache=True, nogil=True)
def worst_ticks(xyz, jerk, ts, feed, axis_vel, axis_acc, jerk_limit, path_scale, skip, best, where):
    """For each ratio of tick_ratios: the largest value into ``best`` and its first tick into
    ``where`` (−1 when every value is NaN). ``skip`` (K flags, one a path jerk) marks the path jerks that are
    NaN (a corner's); the path jerk is compared divided by ``path_scale`` (1 + PATH_JERK_RTOL) as
    breach judges it: ``best[8]`` is the value so divided, ``best[9]`` the ratio itself."""
    n = xyz.shape[0]            # K + 1 ticks, K chords
    # the worst of each ratio so far (−1: none yet) and its first tick
    b0 = b1 = b2 = b3 = b4 = b5 = b6 = b7 = -1.0
    w0 = w1 = w2 = w3 = w4 = w5 = w6 = w7 = -1
    b8 = -1.0                   # the path jerk: judged (divided by path_scale), and raw
    raw8 = -1.0
    w8 = -1
    vx0 = 0.0                   # the velocities of the chord before (rest before the first)
    vy0 = 0.0
    vz0 = 0.0
    f_prev = 0.0                # the feed of the chord before (rest before the first)
    acc_prev = 0.0              # the tangential acceleration at the tick before
    for k in range(n):
        if k < n - 1:
            dx = xyz[k + 1, 0] - xyz[k, 0]
            dy = xyz[k + 1, 1] - xyz[k, 1]
            dz = xyz[k + 1, 2] - xyz[k, 2]
            vx = dx / ts
            vy = dy / ts
            vz = dz / ts
            f = math.sqrt((dx * dx + dy * dy) + dz * dz) / ts
            b0, w0 = _keep(f / feed, b0, w0, k)
            b1, w1 = _keep(abs(vx) / axis_vel[0], b1, w1, k)
            b2, w2 = _keep(abs(vy) / axis_vel[1], b2, w2, k)
            b3, w3 = _keep(abs(vz) / axis_vel[2], b3, w3, k)
            b7, w7 = _keep(abs(jerk[k]) / jerk_limit, b7, w7, k)
        else:                   # to rest after the last tick
            vx = 0.0
            vy = 0.0
            vz = 0.0
            f = 0.0
            b7, w7 = _keep(abs(jerk[k]) / jerk_limit, b7, w7, k)
        # the axis accelerations at tick k: (v_k − v_k−1) / Ts
        b4, w4 = _keep(abs((vx - vx0) / ts) / axis_acc[0], b4, w4, k)
        b5, w5 = _keep(abs((vy - vy0) / ts) / axis_acc[1], b5, w5, k)
        b6, w6 = _keep(abs((vz - vz0) / ts) / axis_acc[2], b6, w6, k)
        # the tangential acceleration at tick k, the path jerk between ticks k − 1 and k
        acc = (f - f_prev) / ts
        if k >= 1 and not skip[k - 1]:
            raw = abs(acc - acc_prev) / ts / jerk_limit
            r = raw / path_scale
            if r > b8:   # NaN never wins; the first of equal values stays
                b8, w8, raw8 = r, k - 1, raw
        vx0 = vx
        vy0 = vy
        vz0 = vz
        f_prev = f
        acc_prev = acc
    for i, (b, w) in enumerate(((b0, w0), (b1, w1), (b2, w2), (b3, w3), (b4, w4), (b5, w5), (b6, w6), (b7, w7),
                                (b8, w8))):
        best[i] = b
        where[i] = w
    best[9] = raw8
