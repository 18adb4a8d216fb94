"""The run search of :mod:`fuzzyfeed.geometry.polyline` compiled by numba (imported only for large inputs).

The same algorithm as ``polyline._runs`` / ``_fit_run`` / ``_circle_fit_2d`` (greedy runs,
galloping then bisecting on the run's end, neighbours merged; a line by principal axes, else a
circle by Kåsa's fit refined by two Gauss–Newton steps, checked within ``tol`` and the sagitta
≤ P), written as scalar loops: each candidate run costs its points' arithmetic only, where the numpy
form pays some 60 array calls. Sums run in index order (numpy sums pairwise), so a decision can
differ from the numpy form only where a residual equals the tolerance to the last bits.
Module-level, with no closure, so numba's on-disk cache serves every later process
(see :mod:`fuzzyfeed.geometry._kernels`).
"""

from __future__ import annotations

import numba
import numpy as np

MIN_RUN = 5          # polyline.MIN_RUN (checked equal by the tests)
_HALF_PI = np.pi / 2


@numba.njit(cache=True, nogil=True)
def _solve3(m, r, out):
    """Gaussian elimination with partial pivoting (LAPACK dgesv's pivoting), overwriting ``m`` and
    ``r``; False if singular."""
    for c in range(3):
        p = c
        for k in range(c + 1, 3):
            if abs(m[k, c]) > abs(m[p, c]):
                p = k
        if m[p, c] == 0.0:
            return False
        if p != c:
            for k in range(3):
                m[c, k], m[p, k] = m[p, k], m[c, k]
            r[c], r[p] = r[p], r[c]
        for k in range(c + 1, 3):
            f = m[k, c] / m[c, c]
            for q in range(c, 3):
                m[k, q] -= f * m[c, q]
            r[k] -= f * r[c]
    for c in range(2, -1, -1):
        s = r[c]
        for q in range(c + 1, 3):
            s -= m[c, q] * out[q]
        out[c] = s / m[c, c]
    return True


@numba.njit(cache=True, nogil=True)
def _circle_fit_2d(xs, ys, x, y, a, b, sol):
    """polyline._circle_fit_2d on xs[:n], ys[:n] (x, y, a, b, sol: work arrays): (ok, cx, cy, radius)."""
    n = xs.size
    mx = 0.0
    my = 0.0
    for k in range(n):
        mx += xs[k]
        my += ys[k]
    mx /= n
    my /= n
    scale = 0.0
    for k in range(n):
        scale = max(scale, abs(xs[k] - mx), abs(ys[k] - my))
    if scale == 0.0:
        return False, 0.0, 0.0, 0.0
    for k in range(n):
        x[k] = (xs[k] - mx) / scale
        y[k] = (ys[k] - my) / scale
    sxx = sxy = syy = sx = sy = sxz = syz = sz = 0.0
    for k in range(n):
        z = x[k] * x[k] + y[k] * y[k]
        sxx += x[k] * x[k]
        sxy += x[k] * y[k]
        syy += y[k] * y[k]
        sx += x[k]
        sy += y[k]
        sxz += x[k] * z
        syz += y[k] * z
        sz += z
    a[0, 0], a[0, 1], a[0, 2] = sxx, sxy, sx
    a[1, 0], a[1, 1], a[1, 2] = sxy, syy, sy
    a[2, 0], a[2, 1], a[2, 2] = sx, sy, float(n)
    b[0], b[1], b[2] = -sxz, -syz, -sz
    if not _solve3(a, b, sol):
        return False, 0.0, 0.0, 0.0
    cx = -0.5 * sol[0]
    cy = -0.5 * sol[1]
    r2 = cx * cx + cy * cy - sol[2]
    if not np.isfinite(r2) or r2 <= 0.0 or r2 > 1e12:
        return False, 0.0, 0.0, 0.0
    radius = np.sqrt(r2)
    for _ in range(2):
        jxx = jxy = jyy = jx = jy = jxr = jyr = rs = 0.0
        for k in range(n):
            dx = x[k] - cx
            dy = y[k] - cy
            dist = np.sqrt(dx * dx + dy * dy)
            if dist == 0.0:
                return False, 0.0, 0.0, 0.0
            ux = -dx / dist
            uy = -dy / dist
            res = dist - radius
            jxx += ux * ux
            jxy += ux * uy
            jyy += uy * uy
            jx += ux
            jy += uy
            jxr += ux * res
            jyr += uy * res
            rs += res
        a[0, 0], a[0, 1], a[0, 2] = jxx, jxy, -jx
        a[1, 0], a[1, 1], a[1, 2] = jxy, jyy, -jy
        a[2, 0], a[2, 1], a[2, 2] = -jx, -jy, float(n)
        b[0], b[1], b[2] = -jxr, -jyr, rs
        if not _solve3(a, b, sol):
            break
        cx += sol[0]
        cy += sol[1]
        radius += sol[2]
    if not np.isfinite(radius) or radius <= 0.0:
        return False, 0.0, 0.0, 0.0
    return True, cx * scale + mx, cy * scale + my, radius * scale


@numba.njit(cache=True, nogil=True)
def _fit_run(pts, i, j, tol, path_tol, fit, work, cov, a, b, sol):
    """polyline._fit_run on pts[i..j]: 0 none, 1 line, 2 circle; ``fit`` gets
    (κ, centre xyz, axis xyz) — the line direction, or the circle plane's normal. ``work`` (4, N),
    ``cov`` (3, 3), ``a`` (3, 3), ``b`` and ``sol`` (3): work arrays."""
    n = j - i + 1
    m0 = m1 = m2 = 0.0
    for k in range(i, j + 1):
        m0 += pts[k, 0]
        m1 += pts[k, 1]
        m2 += pts[k, 2]
    m0 /= n
    m1 /= n
    m2 /= n
    c00 = c01 = c02 = c11 = c12 = c22 = 0.0
    for k in range(i, j + 1):
        q0 = pts[k, 0] - m0
        q1 = pts[k, 1] - m1
        q2 = pts[k, 2] - m2
        c00 += q0 * q0
        c01 += q0 * q1
        c02 += q0 * q2
        c11 += q1 * q1
        c12 += q1 * q2
        c22 += q2 * q2
    cov[0, 0], cov[0, 1], cov[0, 2] = c00, c01, c02
    cov[1, 0], cov[1, 1], cov[1, 2] = c01, c11, c12
    cov[2, 0], cov[2, 1], cov[2, 2] = c02, c12, c22
    _, vecs = np.linalg.eigh(cov)           # principal axes, ascending variance
    a0, a1, a2 = vecs[0, 2], vecs[1, 2], vecs[2, 2]
    s0, s1, s2 = vecs[0, 1], vecs[1, 1], vecs[2, 1]
    n0, n1, n2 = vecs[0, 0], vecs[1, 0], vecs[2, 0]
    along = work[0, :n]
    across = work[1, :n]
    off_max = 0.0
    out_max = 0.0
    for k in range(n):
        q0 = pts[i + k, 0] - m0
        q1 = pts[i + k, 1] - m1
        q2 = pts[i + k, 2] - m2
        t = q0 * a0 + q1 * a1 + q2 * a2
        along[k] = t
        across[k] = q0 * s0 + q1 * s1 + q2 * s2
        r0 = q0 - t * a0
        r1 = q1 - t * a1
        r2 = q2 - t * a2
        off_max = max(off_max, np.sqrt(r0 * r0 + r1 * r1 + r2 * r2))
        out_max = max(out_max, abs(q0 * n0 + q1 * n1 + q2 * n2))
    if off_max <= tol:
        fit[0] = 0.0
        fit[4], fit[5], fit[6] = a0, a1, a2
        return 1
    if out_max > tol:
        return 0
    ok, cx, cy, radius = _circle_fit_2d(along, across, work[2, :n], work[3, :n], a, b, sol)
    if not ok:
        return 0
    chord_max = 0.0
    for k in range(n):
        dx = along[k] - cx
        dy = across[k] - cy
        if abs(np.sqrt(dx * dx + dy * dy) - radius) > tol:
            return 0
        if k > 0:
            ex = along[k] - along[k - 1]
            ey = across[k] - across[k - 1]
            chord_max = max(chord_max, np.sqrt(ex * ex + ey * ey))
    if chord_max >= 2 * radius:
        return 0
    if radius - np.sqrt(radius * radius - 0.25 * chord_max * chord_max) > path_tol:
        return 0
    fit[0] = 1.0 / radius
    fit[1] = m0 + cx * a0 + cy * s0
    fit[2] = m1 + cx * a1 + cy * s1
    fit[3] = m2 + cx * a2 + cy * s2
    fit[4], fit[5], fit[6] = n0, n1, n2
    return 2


@numba.njit(cache=True, nogil=True)
def _fits(pts, next_sharp, i, j, tol, path_tol, fit, work, cov, a, b, sol):
    """polyline._runs.fits: the run i..j (no vertex strictly inside turning by ≥ 90°)."""
    if j - i + 1 < MIN_RUN or j >= pts.shape[0]:
        return 0
    if j - i >= 2 and next_sharp[i + 1] < j:
        return 0
    return _fit_run(pts, i, j, tol, path_tol, fit, work, cov, a, b, sol)


@numba.njit(cache=True, nogil=True)
def find_runs(pts, turn, maybe, tol, path_tol, out_ij, out_kind, out_fit, i0, count0, limit, stop):
    """polyline._runs: fills out_ij[r] = (i, j), out_kind[r] (1 line, 2 circle), out_fit[r]
    (κ, centre, axis) for the merged runs; returns their count.

    Windowed use (:func:`fuzzyfeed.geometry.polyline._runs_windowed`): the search starts at vertex
    ``i0`` with ``count0`` runs already in the outputs (0, or 1: the previous window's last run,
    which the next run may still merge into), and stops before any trial fit reaching vertex
    ``limit`` or beyond (``limit`` ≥ n: never), leaving in stop[0] the vertex the search is to
    resume from (n when it ran to the end). A search whose trials all stay below n - 1 makes the
    same trials, and so finds the same runs, as on the points that continue past n."""
    n = pts.shape[0]
    next_sharp = np.full(n + 1, n)
    for k in range(n - 1, -1, -1):
        next_sharp[k] = k if turn[k] >= _HALF_PI else next_sharp[k + 1]
    fit = np.empty(7)
    trial = np.empty(7)
    work = np.empty((4, n))
    cov = np.empty((3, 3))
    a = np.empty((3, 3))
    b = np.empty(3)
    sol = np.empty(3)
    count = count0
    i = i0
    stop[0] = n
    while True:
        good_j = i + MIN_RUN - 1
        if good_j >= limit and limit < n:      # a trial would reach the window's last vertex
            stop[0] = i
            return count
        if good_j >= n:
            break
        kind = _fits(pts, next_sharp, i, good_j, tol, path_tol, fit, work, cov, a, b, sol) if maybe[i] else 0
        if kind == 0:
            i += 1
            continue
        step = MIN_RUN
        bad_j = -1
        while good_j < n - 1:
            j = min(good_j + step, n - 1)
            if j >= limit:
                stop[0] = i
                return count
            k2 = _fits(pts, next_sharp, i, j, tol, path_tol, trial, work, cov, a, b, sol)
            if k2 == 0:
                bad_j = j
                break
            good_j = j
            kind = k2
            fit[:] = trial
            step *= 2
        if bad_j >= 0:
            lo = good_j
            hi = bad_j
            while hi - lo > 1:
                mid = (lo + hi) // 2
                k2 = _fits(pts, next_sharp, i, mid, tol, path_tol, trial, work, cov, a, b, sol)
                if k2 == 0:
                    hi = mid
                else:
                    lo = mid
                    kind = k2
                    fit[:] = trial
            good_j = lo
        # merge with the previous run where one fit covers both (polyline._runs, second loop)
        merged = False
        if count > 0 and out_ij[count - 1, 1] == i:
            k2 = _fits(pts, next_sharp, out_ij[count - 1, 0], good_j, tol, path_tol, trial, work, cov, a, b, sol)
            if k2 != 0:
                out_ij[count - 1, 1] = good_j
                out_kind[count - 1] = k2
                out_fit[count - 1] = trial
                merged = True
        if not merged:
            out_ij[count, 0] = i
            out_ij[count, 1] = good_j
            out_kind[count] = kind
            out_fit[count] = fit
            count += 1
        i = good_j
        if i >= n - 1:
            break
    return count
