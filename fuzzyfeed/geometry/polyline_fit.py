"""The smooth path a controller follows along a polyline, within its path tolerance.

A CAM post writes a free-form cut as short G1 moves rounded to 3–4 decimals. Followed vertex by
vertex, every rounding-level kink is a tangent break that the scheduler must pass within one servo
period (:func:`fuzzyfeed.slw.preprocess.corners`): a 10⁵-move finishing pass is run at a crawl, and
the positions at Ts carry the rounding as acceleration noise. A controller blends instead
(LinuxCNC G64 P with its naive-CAM detector, Fanuc AI contour control, Siemens COMPCAD): it follows
a smooth path within the path tolerance P of the programmed points and stops only at true
corners. :func:`fit_polyline` builds that path (DESIGN §3, "Feeds in a program"):

1. **Corners.** The true corners are the vertices :func:`fuzzyfeed.geometry.polyline.polyline_curvature`
   flags (a blend within P is tighter there than the curve the chords sample, rounding seen
   through); the polyline is cut at them. The scheduler passes a corner as before, turning within
   one servo period (≈ a stop at 90°): *true corners stop, the rest is blended*.
2. **Pieces.** Each piece between corners with at least :data:`MIN_FIT_POINTS` vertices gets the
   weighted least-squares cubic B-spline of its vertices over their chord length, its ends fixed
   on the piece's end vertices. Knots every h = max(:data:`KNOT_CHORDS` median chords,
   √(:data:`NOISE_LENGTH_MM`·t)), t the coordinates' rounding tolerance, and at least two vertices
   between knots: the fit averages the rounding out (curvature noise ~ t/h²). A knot interval with
   a vertex or a chord midpoint farther than max(2t, P/10) from the fit is halved, up to
   :data:`REFINE_ROUNDS` times.
3. **Acceptance.** Every vertex and chord midpoint lies within max(P, 1.5·t) of the fit (distance
   to the fit's point at the same chord length: an upper bound on the distance to the curve), or
   the piece is kept as its polyline (its vertices then are corners); so is a piece of fewer
   vertices. The measured worst distance is reported.
4. **Joining.** Pieces are joined at their corner vertices (C0 knots of one cubic NURBS whose
   parameter is the polyline's chord length); a kept polyline is its chords as straight cubic
   pieces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.geometry.nurbs import Nurbs

#: Fewest vertices a piece between corners needs to be fitted (a cubic has 4 coefficients).
MIN_FIT_POINTS = 6
#: Knot spacing in median chords (vertices per knot interval the fit averages over).
KNOT_CHORDS = 8
#: Knot spacing at least √(NOISE_LENGTH_MM · t) mm: curvature noise of the fit ≲ t/h² ≈ 10⁻³/mm.
NOISE_LENGTH_MM = 1000.0
#: Halvings of the knot intervals where the fit is farther than the target from the points.
REFINE_ROUNDS = 10
#: Weight of a piece's end vertices in the least-squares fit (the ends are then set exactly).
END_WEIGHT = 1.0e6


@dataclass(frozen=True, eq=False)
class PolylineFit:
    """The followed path of a polyline: ``curve`` (cubic, C0 at ``corners`` true corners), the
    ``source`` polyline, the tolerances used (mm) and the measured worst distance (mm) of a vertex
    or chord midpoint from the path; ``fitted``/``kept`` pieces between corners."""

    curve: Nurbs
    source: Nurbs
    path_tolerance_mm: float
    rounding_tolerance_mm: float
    max_deviation_mm: float
    corners: int
    fitted: int
    kept: int
    quantum_mm: float | None = None

    def describe(self) -> str:
        """One line for a summary."""
        coords = ("full-precision coordinates" if self.quantum_mm is None
                  else f"coordinates rounded to {self.quantum_mm:g} mm")
        return (f"polyline of {self.source.n_control_points} points ({coords}) followed within "
                f"{1000 * self.max_deviation_mm:.2f} um (path tolerance P {self.path_tolerance_mm:g} mm): "
                f"{self.fitted} smooth "
                f"piece(s), {self.kept} kept as lines, {self.corners} true corner(s) passed within one "
                "servo period")


def fit_polyline(curve: Nurbs, path_tolerance_mm: float | None = None,
                 tolerance_mm: float | None = None) -> PolylineFit:
    """The path a blending controller follows along the degree-1 ``curve`` (module docstring).

    ``path_tolerance_mm`` is P (default: the one of :func:`fuzzyfeed.geometry.polyline.polyline_curvature`,
    LinuxCNC's G64 P0.01 unless the CLI set it); ``tolerance_mm`` the coordinates' rounding (read
    from the values when None).
    """
    from fuzzyfeed.geometry.polyline import polyline_curvature

    if not isinstance(curve, Nurbs) or curve.degree != 1:
        raise InputError(f"curve: {type(curve).__name__} of degree {getattr(curve, 'degree', '?')}; "
                         "a polyline fit needs a degree-1 NURBS")
    raw = np.asarray(curve.control_points, dtype=float)
    keep = np.concatenate([[True], np.any(np.diff(raw, axis=0) != 0.0, axis=1)])
    pts = raw[keep]
    if len(pts) < 2:
        raise InputError("curve: all control points coincide; a path to follow needs a positive length")
    info = polyline_curvature(pts, tolerance_mm, path_tolerance_mm)
    p_tol, r_tol = float(info.path_tolerance_mm), float(info.tolerance_mm)
    target = max(2.0 * r_tol, 0.1 * p_tol)
    accept = max(p_tol, 1.5 * r_tol)
    chord = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    x = np.concatenate([[0.0], np.cumsum(chord)])
    h0 = max(KNOT_CHORDS * float(np.median(chord)), float(np.sqrt(NOISE_LENGTH_MM * r_tol)))
    is_corner = info.corner.copy()
    is_corner[0] = is_corner[-1] = True
    cuts = np.flatnonzero(is_corner)
    knots: list[np.ndarray] = [np.zeros(4)]
    ctrl: list[np.ndarray] = [pts[:1]]
    worst = 0.0
    fitted = kept = 0
    for a, b in zip(cuts[:-1], cuts[1:]):
        piece = _fit_piece(x[a:b + 1], pts[a:b + 1], h0, target, accept) if b - a + 1 >= MIN_FIT_POINTS else None
        if piece is None:
            t, c, dev = _chords(x[a:b + 1], pts[a:b + 1])
            kept += 1
        else:
            t, c, dev = piece
            fitted += 1
        worst = max(worst, dev)
        knots.append(t[4:-4])
        knots.append(np.full(3, x[b]))
        ctrl.append(c[1:])
    knots[-1] = np.full(4, x[-1])
    out = Nurbs(3, np.concatenate(knots), np.concatenate(ctrl))
    return PolylineFit(out, curve, p_tol, r_tol, worst, int(np.count_nonzero(is_corner[1:-1])), fitted, kept,
                       info.quantum_mm)


def _chords(x: np.ndarray, p: np.ndarray):
    """The polyline itself as straight cubic pieces (C0 knots at every vertex): knots of a clamped
    piece on [x0, xn], control points, deviation 0."""
    d = np.diff(p, axis=0)
    inner = np.stack([p[:-1] + d / 3.0, p[:-1] + 2.0 * d / 3.0, p[1:]], axis=1).reshape(-1, p.shape[1])
    t = np.concatenate([np.full(4, x[0]), np.repeat(x[1:-1], 3), np.full(4, x[-1])])
    return t, np.vstack([p[:1], inner]), 0.0


def _initial_knots(x: np.ndarray, h: float) -> np.ndarray:
    """Interior knots about every h with at least two vertices strictly inside every interval."""
    length = x[-1] - x[0]
    n = int(length // h)
    if n < 1:
        return np.empty(0)
    cand = x[0] + length * np.arange(1, n + 1) / (n + 1)
    out = []
    last = x[0]
    for k in cand:
        inside = np.searchsorted(x, k, side="left") - np.searchsorted(x, last, side="right")
        if inside >= 2:
            out.append(k)
            last = k
    while out:  # the last interval needs its two vertices too
        inside = np.searchsorted(x, x[-1], side="left") - np.searchsorted(x, out[-1], side="right")
        if inside >= 2:
            break
        out.pop()
    return np.asarray(out, dtype=float)


def _deviation(spline, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distances of the vertices and of the chord midpoints from the fit's points at the same
    chord length, and the chord lengths of those check points."""
    xm = 0.5 * (x[:-1] + x[1:])
    xs = np.concatenate([x, xm])
    ps = np.concatenate([p, 0.5 * (p[:-1] + p[1:])])
    return np.linalg.norm(spline(xs) - ps, axis=1), xs, ps


def _fit_piece(x: np.ndarray, p: np.ndarray, h: float, target: float, accept: float):
    """Least-squares cubic of one piece (module docstring, steps 2-3): (knots, control points,
    worst distance), or None when it cannot be fitted within ``accept``."""
    from scipy.interpolate import BSpline, make_lsq_spline

    interior = _initial_knots(x, h)
    w = np.ones(x.size)
    w[0] = w[-1] = END_WEIGHT
    best = None
    for _ in range(REFINE_ROUNDS + 1):
        t = np.concatenate([np.full(4, x[0]), interior, np.full(4, x[-1])])
        try:
            spl = make_lsq_spline(x, p, t, k=3, w=w)
        except (ValueError, np.linalg.LinAlgError):
            break
        c = np.array(spl.c, dtype=float)
        c[0], c[-1] = p[0], p[-1]
        spl = BSpline(t, c, 3)
        dev, xs, _ = _deviation(spl, x, p)
        worst = float(dev.max())
        if best is None or worst < best[2]:
            best = (t, c, worst)
        if worst <= target:
            break
        bad = np.unique(np.searchsorted(interior, xs[dev > target], side="right"))
        edges = np.concatenate([[x[0]], interior, [x[-1]]])
        new = []
        for i in bad:
            lo, hi = edges[i], edges[i + 1]
            mid = 0.5 * (lo + hi)
            left = np.searchsorted(x, mid, side="left") - np.searchsorted(x, lo, side="right")
            right = np.searchsorted(x, hi, side="left") - np.searchsorted(x, mid, side="right")
            if left >= 2 and right >= 2:
                new.append(mid)
        if not new:
            break
        interior = np.sort(np.concatenate([interior, new]))
    if best is None or best[2] > accept:
        return None
    return best
