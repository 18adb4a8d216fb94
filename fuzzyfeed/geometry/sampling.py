"""The sampling layer both planners consume: a path as a table of sampled points.

``sample_uniform_u`` samples uniformly in the parameter (seed 002 uses 2000 points, Δu = 0.0005);
``sample_by_arc_length`` samples uniformly in arc length through u(s). Both return one
:class:`PathSamples` value. ``samples_from_points`` builds the same value from a point sequence
(a G-code polyline, a CSV of points) with the curvature of :mod:`fuzzyfeed.geometry.polyline` (the path
within the coordinates' rounding, corners as the controller's blend); the three-point curvature of
seed 002, eq. 4–9 (:func:`three_point_curvature`) stays available as the paper's estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.base.checks import expect, float_array
from fuzzyfeed.errors import InputError
from fuzzyfeed.geometry.nurbs import MAX_COORDINATE_MM, Nurbs, curvature_from_derivatives
from fuzzyfeed.geometry.polyline_chords import pad3

#: Seed 002 samples its paths at 2000 points (Δu = 0.0005 on [0, 1]).
DEFAULT_POINTS = 2000
#: Largest distance between samples along a program's cut (mm), and the spacing at which the
#: advisor's windows (WS, M points) become lengths on a point sequence, whose points are the file's.
POINT_STEP_MM = 0.25
#: Work budget: the most points any sampling (or arc flattening) may create (~0.3 GB of samples).
MAX_POINTS = 1_000_000


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr = np.ascontiguousarray(arr, dtype=float)
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True, eq=False)
class PathSamples:
    """Sampled path: one row per point, arrays of equal length N ≥ 1 (units: mm, 1/mm).

    ``u`` parameter (for point sequences: chord length normalised to [0, 1]); ``xyz`` (N, 3)
    positions (z = 0 for planar paths); ``s`` arc length from the start; ``tangent`` (N, 3) unit
    tangent; ``curvature`` κ; ``d1``/``d2`` (N, 3) the derivatives C′(u), C″(u) (NaN for point
    sequences, which have no parametrisation); ``dim`` the path's own dimension (2 or 3);
    ``curve`` the NURBS sampled, or None for a point sequence.
    """

    u: np.ndarray
    xyz: np.ndarray
    s: np.ndarray
    tangent: np.ndarray
    curvature: np.ndarray
    d1: np.ndarray
    d2: np.ndarray
    dim: int = 3
    curve: Nurbs | None = None

    def __post_init__(self) -> None:
        n = np.shape(self.u)[0] if np.ndim(self.u) == 1 else -1
        if n < 1:
            raise InputError("samples: no points; give at least one parameter")
        for name in ("u", "xyz", "s", "tangent", "curvature", "d1", "d2"):
            arr = _readonly(float_array(getattr(self, name), f"samples.{name}"))
            if arr.ndim == 0 or arr.shape[0] != n:
                raise InputError(f"samples.{name}: {arr.shape[0] if arr.ndim else 0} rows, expected {n}")
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return int(self.u.size)

    @property
    def length(self) -> float:
        """Arc length of the sampled path (mm)."""
        return float(self.s[-1])

    @property
    def x(self) -> np.ndarray:
        return self.xyz[:, 0]

    @property
    def y(self) -> np.ndarray:
        return self.xyz[:, 1]

    @property
    def z(self) -> np.ndarray:
        return self.xyz[:, 2]

    @property
    def speed(self) -> np.ndarray:
        """|C′(u)|: mm per unit parameter (NaN for point sequences)."""
        return np.linalg.norm(self.d1, axis=1)

    def columns(self) -> dict[str, np.ndarray]:
        """Named columns with units, the start of every CSV fuzzyfeed writes."""
        return {"u": self.u, "x_mm": self.x, "y_mm": self.y, "z_mm": self.z, "s_mm": self.s,
                "curvature_1_mm": self.curvature}


def samples_at(curve: Nurbs, u: np.ndarray, s: np.ndarray | None = None) -> PathSamples:
    """Sample ``curve`` at the given parameters (sorted, inside the domain)."""
    u = np.asarray(u, dtype=float)
    c, d1, d2 = curve.evaluate(u, order=2)
    speed = np.linalg.norm(d1, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        tangent = d1 / speed[:, None]
    s = curve.arc_length(u) if s is None else s
    return PathSamples(u=u, xyz=pad3(c), s=s, tangent=pad3(tangent),
                       curvature=curvature_from_derivatives(d1, d2), d1=pad3(d1), d2=pad3(d2),
                       dim=curve.dim, curve=curve)


def point_budget(count: float, what: str) -> int:
    """``count`` points as an int, or a one-line InputError if it exceeds :data:`MAX_POINTS`."""
    if not count <= MAX_POINTS:  # also NaN
        raise InputError(f"{what}: needs {count:.4g} points, more than the budget of {MAX_POINTS:,}")
    return int(count)


def _check_count(n: object, name: str = "points") -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise InputError(f"{name}: {n!r}; the number of sample points must be an integer >= 2")
    if n > MAX_POINTS:
        raise InputError(f"{name}: {n}; at most {MAX_POINTS:,} sample points")
    return int(n)


def sample_uniform_u(curve: Nurbs, n: int = DEFAULT_POINTS) -> PathSamples:
    """n points uniform in the parameter, ends included (seed 002: n = 2000, Δu = 0.0005)."""
    expect(curve, Nurbs, "curve", "a Nurbs")
    n = _check_count(n)
    lo, hi = curve.domain
    return samples_at(curve, np.linspace(lo, hi, n))


def sample_by_arc_length(curve: Nurbs, step_mm: float | None = None, n: int | None = None) -> PathSamples:
    """Points uniform in arc length: every ``step_mm`` (last step shorter) or ``n`` points."""
    expect(curve, Nurbs, "curve", "a Nurbs")
    if step_mm is not None:
        expect(step_mm, (int, float, np.integer, np.floating), "step_mm", "a number of mm")
    total = curve.length
    if (step_mm is None) == (n is None):
        raise InputError("sample_by_arc_length: give exactly one of step_mm or n")
    if step_mm is not None:
        if not np.isfinite(step_mm) or step_mm <= 0:
            raise InputError(f"step_mm: {step_mm!r}; the arc-length step must be finite and > 0")
        count = max(1, point_budget(np.ceil(total / step_mm - 1e-9),
                                    f"step_mm = {step_mm:g} on {total:.6g} mm"))
        s = np.minimum(np.arange(count + 1) * float(step_mm), total)
        s[-1] = total
    else:
        s = np.linspace(0.0, total, _check_count(n))
    u = curve.param_at_length(s)
    return samples_at(curve, u, s=s)


#: A unit tangent turning more than this across an interior knot is a corner (infinite curvature).
CORNER_ANGLE_DEG = 1.0


def tangent_breaks(curve: Nurbs, min_angle_deg: float = CORNER_ANGLE_DEG) -> tuple[np.ndarray, np.ndarray]:
    """Interior knots where the unit tangent jumps by more than ``min_angle_deg``: (u, angle in
    degrees). Uniform samples almost never land on such a knot, so a corner between two straight
    pieces would be sampled with curvature 0 on both sides; it must be found on the curve itself."""
    expect(curve, Nurbs, "curve", "a Nurbs")
    lo, hi = curve.domain
    knots = curve.span_breaks[1:-1]         # the distinct interior knots
    if knots.size == 0:
        return np.empty(0), np.empty(0)
    eps = 1e-9 * (hi - lo)
    d_left = curve.evaluate(knots - eps, order=1)[1]
    d_right = curve.evaluate(knots + eps, order=1)[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_left = d_left / np.linalg.norm(d_left, axis=1)[:, None]
        t_right = d_right / np.linalg.norm(d_right, axis=1)[:, None]
        cos = np.clip(np.einsum("ij,ij->i", t_left, t_right), -1.0, 1.0)
    angle = np.degrees(np.arccos(np.where(np.isfinite(cos), cos, -1.0)))
    corner = angle > min_angle_deg
    return knots[corner], angle[corner]


def three_point_curvature(points: np.ndarray) -> np.ndarray:
    """Curvature of a point sequence from the chord-parametrised quadratic through three points.

    Seed 002, eq. 4–9: P(t) = a1 + a2 t + a3 t² through P_{i-1}, P_i, P_{i+1} at t = −t_a, 0, t_b
    with t_a, t_b the chord lengths; κ = 2|a2 × a3| / |a2|³ (eq. 9, generalised to 3-D). The two
    end points take their neighbour's value. Repeated points are an error (no chord length).
    """
    pts = float_array(points, "points")
    if pts.ndim != 2 or pts.shape[0] < 3 or pts.shape[1] not in (2, 3):
        raise InputError(f"points: shape {pts.shape}; need at least 3 points of 2 or 3 coordinates")
    if not np.isfinite(pts).all():
        i = int(np.argwhere(~np.isfinite(pts))[0, 0])
        raise InputError(f"points[{i}] = {pts[i].tolist()}; coordinates must be finite")
    big = np.abs(pts) > MAX_COORDINATE_MM
    if big.any():
        i = int(np.argwhere(big)[0, 0])
        raise InputError(f"points[{i}] = {pts[i].tolist()}; coordinates must lie within "
                         f"±{MAX_COORDINATE_MM:g} mm (1 km)")
    pts = pad3(pts)
    d_a = pts[:-2] - pts[1:-1]   # P1 - P2
    d_b = pts[2:] - pts[1:-1]    # P3 - P2
    ta = np.linalg.norm(d_a, axis=1)
    tb = np.linalg.norm(d_b, axis=1)
    zero = (ta == 0) | (tb == 0)
    if zero.any():
        i = int(np.argmax(zero)) + (1 if ta[np.argmax(zero)] == 0 else 2)
        raise InputError(f"points[{i}] repeats points[{i - 1}]; consecutive points must differ")
    # eq. 7-8 solved in closed form: d_a/ta = -a2 + a3 ta, d_b/tb = a2 + a3 tb
    a3 = (d_a / ta[:, None] + d_b / tb[:, None]) / (ta + tb)[:, None]
    a2 = d_b / tb[:, None] - a3 * tb[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):  # a reversal (a2 = 0) gives NaN: a cusp
        kappa_inner = 2.0 * np.linalg.norm(np.cross(a2, a3), axis=1) / np.linalg.norm(a2, axis=1) ** 3
    return np.concatenate([[kappa_inner[0]], kappa_inner, [kappa_inner[-1]]])


def samples_from_points(points: np.ndarray, curve: Nurbs | None = None, *,
                        tolerance_mm: float | None = None,
                        path_tolerance_mm: float | None = None,
                        max_step_mm: float | None = None, where: str = "a path") -> PathSamples:
    """A :class:`PathSamples` for a point sequence: chord-length s, and the curvature of the path
    the points describe within their rounding, corners blended as a controller blends them within
    the path tolerance P (:func:`fuzzyfeed.geometry.polyline.polyline_curvature`; ``tolerance_mm`` None
    reads the rounding from the coordinates, ``path_tolerance_mm`` None is LinuxCNC-style
    G64 P0.01). Consecutive repeated points are allowed (they get their neighbour's values).

    ``max_step_mm``, if given, adds samples inside every segment longer than it (evenly, at most
    that far apart), as programs are sampled (:mod:`fuzzyfeed.program.cuts`): a feed given per sample and
    executed between samples then sees a long line between two corners, not only its slow ends.
    Inside a segment κ is the smaller of its two ends' that are not corners (a chord of a circle
    written as G1 moves keeps the circle's κ), 0 between two corners; the tangent is the chord's.

    A path so long that these samples would pass the budget (:data:`MAX_POINTS`) is sampled
    more coarsely inside its segments, with a notice naming ``where``.

    ``curve``, if given, is the degree-1 NURBS through the points with chord-length knots on
    [0, 1] (so u = s / L is its parameter at every point, the added ones too); planners and the
    simulator move along it.
    """
    from fuzzyfeed.geometry.polyline import polyline_curvature

    pts = float_array(points, "points")
    if pts.ndim != 2 or pts.shape[0] < 2 or pts.shape[1] not in (2, 3):
        raise InputError(f"points: shape {pts.shape}; need at least 2 points of 2 or 3 coordinates")
    if max_step_mm is not None and np.isfinite(max_step_mm) and max_step_mm > 0:
        point_budget(pts.shape[0], "points of the path")
        lengths = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        if float(segment_pieces(lengths, float(max_step_mm)).sum()) + 1 > MAX_POINTS:
            # a path this long is sampled inside its segments more coarsely: within the budget
            room = MAX_POINTS - lengths.size - 2         # ceil adds at most one piece a segment
            wider = float(lengths.sum()) / room if room > 0 else np.inf
            if not wider > max_step_mm:
                point_budget(np.inf, f"{pts.shape[0]} points sampled inside long segments")
            import warnings

            from fuzzyfeed.errors import FuzzyfeedNotice

            warnings.warn(f"{where}: {float(lengths.sum()):.6g} mm long, sampled every {wider:.3g} mm "
                          f"inside its segments (not {max_step_mm:g} mm: at most {MAX_POINTS:,} samples)",
                          FuzzyfeedNotice, stacklevel=2)
            max_step_mm = wider
    result = polyline_curvature(pts, tolerance_mm, path_tolerance_mm)
    dim = pts.shape[1]
    xyz = pad3(pts)
    chords = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
    if chords.sum() <= 0:
        raise InputError("points: all points coincide; a path needs length > 0")
    tangent, kappa = result.tangent, result.curvature
    if max_step_mm is not None:
        xyz, tangent, kappa, chords = _split_segments(xyz, tangent, kappa, result.corner, chords,
                                                      float(max_step_mm))
    s = np.concatenate([[0.0], np.cumsum(chords)])
    nan = np.full_like(xyz, np.nan)
    return PathSamples(u=s / s[-1], xyz=xyz, s=s, tangent=tangent,
                       curvature=kappa, d1=nan, d2=nan, dim=dim, curve=curve)


def segment_pieces(length_mm: np.ndarray, step_mm: float) -> np.ndarray:
    """How many equal pieces of at most ``step_mm`` each segment length is cut into (at least 1;
    a length a rounding over a whole number of steps is not cut once more)."""
    return np.maximum(1, np.ceil(np.asarray(length_mm, dtype=float) / step_mm - 1e-9)).astype(np.int64)


def _split_segments(xyz: np.ndarray, tangent: np.ndarray, kappa: np.ndarray, corner: np.ndarray,
                    chords: np.ndarray, max_step_mm: float):
    """Points added evenly inside every segment longer than ``max_step_mm`` (see
    :func:`samples_from_points`): positions, tangents, κ and the new chords."""
    if not np.isfinite(max_step_mm) or max_step_mm <= 0:
        raise InputError(f"max_step_mm = {max_step_mm!r}; must be a finite number > 0 (mm)")
    pieces = segment_pieces(chords, max_step_mm)
    if (pieces == 1).all():
        return xyz, tangent, kappa, chords
    seg = np.repeat(np.arange(chords.size), pieces)                  # segment of each new chord
    first = np.repeat(np.cumsum(pieces) - pieces, pieces)
    frac = (np.arange(seg.size) - first + 1) / pieces[seg]           # end of each new chord
    ends = xyz[seg] + (xyz[seg + 1] - xyz[seg]) * frac[:, None]
    at_vertex = frac == 1.0
    ends[at_vertex] = xyz[seg[at_vertex] + 1]
    out = np.vstack([xyz[:1], ends])
    own = np.where(corner, np.inf, kappa)
    inner = np.minimum(own[:-1], own[1:])
    inner = np.where(np.isfinite(inner), inner, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        direction = (xyz[1:] - xyz[:-1]) / chords[:, None]
    k_out = np.concatenate([kappa[:1], np.where(at_vertex, kappa[seg + 1], inner[seg])])
    t_inner = np.where(np.isfinite(direction), direction, tangent[1:])[seg]
    t_out = np.vstack([tangent[:1], np.where(at_vertex[:, None], tangent[seg + 1], t_inner)])
    return out, t_out, k_out, np.linalg.norm(np.diff(out, axis=0), axis=1)


def max_curvature(curve: Nurbs, per_span: int = 64, candidates: int = 8, rounds: int = 8) -> tuple[float, float]:
    """(u, κ) of the largest curvature κ = |C′ × C″| / |C′|³ on the curve, without a dense scan.

    ``per_span`` samples on every knot span (ends included) find the local maxima of the sampled κ;
    the ``candidates`` highest are refined by resampling their bracket (the neighbouring samples)
    at ``per_span`` points, ``rounds`` times, each round shrinking the bracket ~per_span/2-fold.
    A stationary point (C′ = 0) gives κ = inf.
    """
    spans = curve.span_breaks
    t = np.linspace(0.0, 1.0, per_span + 1)[:-1]
    u = np.append((spans[:-1, None] + np.diff(spans)[:, None] * t).ravel(), spans[-1])
    k = curve.curvature(u)
    if not np.isfinite(k).all():
        i = int(np.argmax(~np.isfinite(k)))
        return float(u[i]), float("inf")
    left = np.concatenate([[-np.inf], k[:-1]])
    right = np.concatenate([k[1:], [-np.inf]])
    peaks = np.flatnonzero((k >= left) & (k >= right))
    peaks = peaks[np.argsort(k[peaks])[::-1][:candidates]]
    best_u, best_k = float(u[peaks[0]]), float(k[peaks[0]])
    lo_u, hi_u = curve.domain
    for i in peaks:
        a, b = u[max(i - 1, 0)], u[min(i + 1, u.size - 1)]
        for _ in range(rounds):
            grid = np.linspace(a, b, per_span + 1)
            kg = curve.curvature(grid)
            j = int(np.argmax(kg))
            if not np.isfinite(kg[j]):
                return float(grid[j]), float("inf")
            if kg[j] > best_k:
                best_u, best_k = float(grid[j]), float(kg[j])
            a, b = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
    return min(max(best_u, lo_u), hi_u), best_k
