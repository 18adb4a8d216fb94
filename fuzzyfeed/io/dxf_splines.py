"""DXF SPLINE entities as NURBS: control points as stored, fit points through ezdxf's construction
tool, unclamped (closed/periodic) knot vectors clamped, piecewise-Bézier knots joined or cut."""

from __future__ import annotations

import numpy as np

from fuzzyfeed.errors import NurbsError, PathFormatError
from fuzzyfeed.geometry.nurbs import MIN_EXTENT_MM, Nurbs, insert_knot


def _clamp_start(p: int, knots: np.ndarray, pw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = float(knots[p])
    while np.count_nonzero(knots == a) < p:
        knots, pw = insert_knot(p, knots, pw, a)
    j = int(np.argmax(knots == a))                   # first knot equal to a
    if j == 0:                                        # already p + 1 equal knots at the start
        return knots, pw
    m = int(np.count_nonzero(knots == a))
    start_cp = j + m - p - 1                          # C(a) = this control point
    return np.concatenate([[a] * (p + 1), knots[j + m:]]), pw[start_cp:]


def clamp_knots(p: int, knots: np.ndarray, points: np.ndarray, weights: np.ndarray):
    """The same curve on [u_p, u_n] with a clamped knot vector: insert u_p (and u_n) until each
    has multiplicity p, then drop the knots and control points outside the range (The NURBS Book
    §5.3, knot insertion; the curve is unchanged)."""
    pw = np.column_stack([points * weights[:, None], weights])
    knots, pw = _clamp_start(p, np.asarray(knots, dtype=float), pw)
    rk, rpw = _clamp_start(p, -knots[::-1], pw[::-1])
    knots, pw = -rk[::-1], rpw[::-1]
    return knots, pw[:, :-1] / pw[:, -1:], pw[:, -1]


def split_bezier_joints(p: int, knots: np.ndarray, points: np.ndarray, weights: np.ndarray,
                        tol: float) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """A clamped spline whose interior knots repeat p + 1 times (piecewise Bézier, as some CAD
    programs write them): where the two control points at such a knot coincide (within ``tol``)
    one copy of the knot and of the point is dropped (the same curve, C0 there); elsewhere the
    spline is cut into separate clamped pieces. More than p + 1 repeats always cut."""
    pieces = []
    k, pts, w = np.asarray(knots, float), np.asarray(points, float), np.asarray(weights, float)
    while True:
        interior = k[p + 1:k.size - p - 1]
        values, first, counts = np.unique(interior, return_index=True, return_counts=True)
        over = np.flatnonzero(counts > p)
        if over.size == 0:
            pieces.append((k, pts, w))
            return pieces
        j = p + 1 + int(first[over[0]])               # first index of the repeated knot
        m = int(counts[over[0]])
        left_end, right_start = j - 1, j + m - p - 1  # control points C(u-) and C(u+)
        if m == p + 1 and np.linalg.norm(pts[left_end] - pts[right_start]) <= tol:
            k = np.delete(k, j)
            pts, w = np.delete(pts, right_start, axis=0), np.delete(w, right_start)
            continue
        u = k[j]
        pieces.append((np.concatenate([k[:j], [u] * (p + 1)]), pts[:left_end + 1], w[:left_end + 1]))
        k = np.concatenate([[u] * (p + 1), k[j + m:]])
        pts, w = pts[right_start:], w[right_start:]


def split_at_corners(curve: Nurbs) -> list[Nurbs]:
    """``curve`` cut at every interior knot where its tangent turns (a corner: knot multiplicity
    = degree with the control polygon bending there): each knot raised to multiplicity p + 1 by
    knot insertion (the curve unchanged), then cut, so every piece is smooth inside."""
    from fuzzyfeed.geometry.sampling import tangent_breaks

    corners, _ = tangent_breaks(curve)
    if corners.size == 0:
        return [curve]
    p = curve.degree
    k = np.asarray(curve.knots, dtype=float)
    w = np.asarray(curve.weights, dtype=float)
    pw = np.column_stack([curve.control_points * w[:, None], w])
    for u in corners:
        while np.count_nonzero(k == u) < p + 1:
            k, pw = insert_knot(p, k, pw, float(u))
    pieces = []
    for u in corners:
        j = int(np.argmax(k == u))
        pieces.append((np.concatenate([k[:j], [u] * (p + 1)]), pw[:j]))
        k, pw = np.concatenate([[u] * (p + 1), k[j + p + 1:]]), pw[j:]
    pieces.append((k, pw))
    out = []
    for kk, q in pieces:
        pts = q[:, :-1] / q[:, -1:]
        if float(np.ptp(pts, axis=0).max()) >= MIN_EXTENT_MM:      # a piece of no length is no path
            out.append(Nurbs(p, kk, pts, q[:, -1]))
    return out


def spline_curves(entity, scale: float, where: str) -> tuple[list, str]:

    if len(entity.control_points) > 0:
        degree = int(entity.dxf.degree)
        knots = np.asarray(list(entity.knots), dtype=float)
        points = np.asarray([tuple(p) for p in entity.control_points], dtype=float)
        weights = np.asarray(list(entity.weights), dtype=float) if len(entity.weights) else None
        how = "control points"
    elif len(entity.fit_points) > 0:
        try:
            tool = entity.construction_tool()
        except Exception as exc:  # noqa: BLE001 — ezdxf raises several types for degenerate fit data
            raise PathFormatError(f"{where}: fit points could not be interpolated by ezdxf "
                                  f"({type(exc).__name__}: {' '.join(str(exc).split())})") from None
        degree = int(tool.degree)
        knots = np.asarray(tool.knots(), dtype=float)
        points = np.asarray([tuple(p) for p in tool.control_points], dtype=float)
        weights = np.asarray(tool.weights(), dtype=float) if tool.is_rational else None
        how = f"{len(entity.fit_points)} fit points (ezdxf construction tool)"
    else:
        raise PathFormatError(f"{where}: SPLINE has neither control points nor fit points")
    if not np.isfinite(points).all():
        i = int(np.argwhere(~np.isfinite(points))[0, 0])
        raise PathFormatError(f"{where}: control point {i} = {points[i].tolist()}; must be finite")
    points = points * scale
    weights = np.ones(len(points)) if weights is None or weights.size == 0 else weights
    implied = knots.size - len(points) - 1
    if knots.size != len(points) + degree + 1 and 1 <= implied < degree and \
            np.ptp(knots[:implied + 1]) == 0 and np.ptp(knots[-implied - 1:]) == 0:
        # a writer that states the wrong degree: the knots and control points make a clamped
        # curve of degree `implied` (arcs written as rational quadratics flagged degree 3)
        import warnings

        from fuzzyfeed.errors import FuzzyfeedNotice

        warnings.warn(f"{where}: degree {degree} stated, but its {knots.size} knots and {len(points)} "
                      f"control points make a clamped curve of degree {implied}: read as degree "
                      f"{implied}", FuzzyfeedNotice, stacklevel=2)
        how += f", degree {implied} (the file says {degree})"
        degree = implied
    valid = (degree >= 1 and knots.size == len(points) + degree + 1 and np.all(np.diff(knots) >= 0)
             and np.isfinite(knots).all() and np.all(weights > 0))
    if valid and (np.ptp(knots[:degree + 1]) > 0 or np.ptp(knots[-degree - 1:]) > 0):
        knots, points, weights = clamp_knots(degree, knots, points, weights)
        how += ", unclamped knots clamped to [u_p, u_n]"
    parts = [(knots, points, weights)]
    if valid:
        parts = split_bezier_joints(degree, knots, points, weights, 1e-9 * max(1.0, np.ptp(points)))
        if len(parts) > 1:
            how += f", cut into {len(parts)} pieces at discontinuous Bézier joints"
    curves = []
    for k, pts, w in parts:
        if float(np.ptp(pts, axis=0).max()) < MIN_EXTENT_MM:       # a piece of no length is no path
            continue
        try:
            curves.extend(split_at_corners(Nurbs(degree, k, pts, w)))
        except NurbsError as exc:
            raise PathFormatError(f"{where}: {exc}") from None
    if len(curves) > len(parts):
        how += f", cut into {len(curves)} smooth pieces at {len(curves) - len(parts)} corner knot(s)"
    return curves, how
