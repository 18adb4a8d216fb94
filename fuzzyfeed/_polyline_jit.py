"""The run search of :mod:`fuzzyfeed.polyline` compiled by numba (imported only for large inputs).

The same algorithm as ``polyline._runs`` / ``_fit_run`` / ``_circle_fit_2d`` (greedy runs,
galloping then bisecting on the run's end, neighbours merged; a line by principal axes, else a
circle by Kåsa's fit refined by two Gauss–Newton steps, checked within ``tol`` and the sagitta
≤ P), written as scalar loops: each candidate run costs its points' arithmetic only, where the numpy
form pays some 60 array calls. Sums run in index order (numpy sums pairwise), so a decision can
differ from the numpy form only where a residual equals the tolerance to the last bits.
Module-level, with no closure, so numba's on-disk cache serves every later process
(see :mod:`fuzzyfeed._kernels`).
"""

from __future__ import annotations

import numba
import numpy as np

MIN_RUN = 5          # polyline.MIN_RUN (checked equal by the tests)
_HALF_PI = np.pi / 2


@numba.njit(cache=True, nogil=True)
def _solve3(a, b, out):
    """Gaussian elimination with partial pivoting (LAPACK dgesv's pivoting); False if singular."""
    m = a.copy()
    r = b.copy()
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
def _circle_fit_2d(xs, ys):
    """polyline._circle_fit_2d: (ok, cx, cy, radius)."""
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
    x = (xs - mx) / scale
    y = (ys - my) / scale
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
    a = np.empty((3, 3))
    b = np.empty(3)
    sol = np.empty(3)
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
def _fit_run(pts, i, j, tol, path_tol, fit):
    """polyline._fit_run on pts[i..j]: 0 none, 1 line, 2 circle; ``fit`` gets
    (κ, centre xyz, axis xyz) — the line direction, or the circle plane's normal."""
    n = j - i + 1
    c0 = np.zeros(3)
    for k in range(i, j + 1):
        for d in range(3):
            c0[d] += pts[k, d]
    c0 /= n
    q = pts[i:j + 1] - c0
    cov = q.T @ q
    _, vecs = np.linalg.eigh(cov)
    axis = vecs[:, 2].copy()
    second = vecs[:, 1].copy()
    normal = vecs[:, 0].copy()
    along = np.empty(n)
    across = np.empty(n)
    off_max = 0.0
    out_max = 0.0
    for k in range(n):
        a = q[k, 0] * axis[0] + q[k, 1] * axis[1] + q[k, 2] * axis[2]
        along[k] = a
        across[k] = q[k, 0] * second[0] + q[k, 1] * second[1] + q[k, 2] * second[2]
        r0 = q[k, 0] - a * axis[0]
        r1 = q[k, 1] - a * axis[1]
        r2 = q[k, 2] - a * axis[2]
        off_max = max(off_max, np.sqrt(r0 * r0 + r1 * r1 + r2 * r2))
        out_max = max(out_max, abs(q[k, 0] * normal[0] + q[k, 1] * normal[1] + q[k, 2] * normal[2]))
    if off_max <= tol:
        fit[0] = 0.0
        fit[4:7] = axis
        return 1
    if out_max > tol:
        return 0
    ok, cx, cy, radius = _circle_fit_2d(along, across)
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
    for d in range(3):
        fit[1 + d] = c0[d] + cx * axis[d] + cy * second[d]
    fit[4:7] = normal
    return 2


@numba.njit(cache=True, nogil=True)
def _fits(pts, next_sharp, i, j, tol, path_tol, fit):
    """polyline._runs.fits: the run i..j (no vertex strictly inside turning by ≥ 90°)."""
    if j - i + 1 < MIN_RUN or j >= pts.shape[0]:
        return 0
    if j - i >= 2 and next_sharp[i + 1] < j:
        return 0
    return _fit_run(pts, i, j, tol, path_tol, fit)


@numba.njit(cache=True, nogil=True)
def find_runs(pts, turn, maybe, tol, path_tol, out_ij, out_kind, out_fit):
    """polyline._runs: fills out_ij[r] = (i, j), out_kind[r] (1 line, 2 circle), out_fit[r]
    (κ, centre, axis) for the merged runs; returns their count."""
    n = pts.shape[0]
    next_sharp = np.full(n + 1, n)
    for k in range(n - 1, -1, -1):
        next_sharp[k] = k if turn[k] >= _HALF_PI else next_sharp[k + 1]
    fit = np.empty(7)
    trial = np.empty(7)
    count = 0
    i = 0
    while i + MIN_RUN - 1 < n:
        good_j = i + MIN_RUN - 1
        kind = _fits(pts, next_sharp, i, good_j, tol, path_tol, fit) if maybe[i] else 0
        if kind == 0:
            i += 1
            continue
        step = MIN_RUN
        bad_j = -1
        while good_j < n - 1:
            j = min(good_j + step, n - 1)
            k2 = _fits(pts, next_sharp, i, j, tol, path_tol, trial)
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
                k2 = _fits(pts, next_sharp, i, mid, tol, path_tol, trial)
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
            k2 = _fits(pts, next_sharp, out_ij[count - 1, 0], good_j, tol, path_tol, trial)
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
