"""The sampling layer both planners consume: a path as a table of sampled points.

``sample_uniform_u`` samples uniformly in the parameter (seed 002 uses 2000 points, Δu = 0.0005);
``sample_by_arc_length`` samples uniformly in arc length through u(s). Both return one
:class:`PathSamples` value. ``samples_from_points`` builds the same value from a point sequence
(a G-code polyline, a CSV of points) with the curvature of :mod:`fuzzyfeed.polyline` (the path
within the coordinates' rounding, corners as the controller's blend); the three-point curvature of
seed 002, eq. 4–9 (:func:`three_point_curvature`) stays available as the paper's estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.nurbs import Nurbs, curvature_from_derivatives

#: Seed 002 samples its paths at 2000 points (Δu = 0.0005 on [0, 1]).
DEFAULT_POINTS = 2000


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
            arr = _readonly(getattr(self, name))
            if arr.shape[0] != n:
                raise InputError(f"samples.{name}: {arr.shape[0]} rows, expected {n}")
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


def _pad3(a: np.ndarray) -> np.ndarray:
    if a.shape[1] == 3:
        return a
    return np.hstack([a, np.zeros((a.shape[0], 3 - a.shape[1]))])


def samples_at(curve: Nurbs, u: np.ndarray, s: np.ndarray | None = None) -> PathSamples:
    """Sample ``curve`` at the given parameters (sorted, inside the domain)."""
    u = np.asarray(u, dtype=float)
    c, d1, d2 = curve.evaluate(u, order=2)
    speed = np.linalg.norm(d1, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        tangent = d1 / speed[:, None]
    s = curve.arc_length(u) if s is None else s
    return PathSamples(u=u, xyz=_pad3(c), s=s, tangent=_pad3(tangent),
                       curvature=curvature_from_derivatives(d1, d2), d1=_pad3(d1), d2=_pad3(d2),
                       dim=curve.dim, curve=curve)


def _check_count(n: object, name: str = "points") -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise InputError(f"{name}: {n!r}; the number of sample points must be an integer >= 2")
    return int(n)


def sample_uniform_u(curve: Nurbs, n: int = DEFAULT_POINTS) -> PathSamples:
    """n points uniform in the parameter, ends included (seed 002: n = 2000, Δu = 0.0005)."""
    n = _check_count(n)
    lo, hi = curve.domain
    return samples_at(curve, np.linspace(lo, hi, n))


def sample_by_arc_length(curve: Nurbs, step_mm: float | None = None, n: int | None = None) -> PathSamples:
    """Points uniform in arc length: every ``step_mm`` (last step shorter) or ``n`` points."""
    total = curve.length
    if (step_mm is None) == (n is None):
        raise InputError("sample_by_arc_length: give exactly one of step_mm or n")
    if step_mm is not None:
        if not np.isfinite(step_mm) or step_mm <= 0:
            raise InputError(f"step_mm: {step_mm!r}; the arc-length step must be finite and > 0")
        count = max(1, int(np.ceil(total / step_mm - 1e-9)))
        s = np.minimum(np.arange(count + 1) * float(step_mm), total)
        s[-1] = total
    else:
        s = np.linspace(0.0, total, _check_count(n))
    u = curve.param_at_length(s)
    return samples_at(curve, u, s=s)


def three_point_curvature(points: np.ndarray) -> np.ndarray:
    """Curvature of a point sequence from the chord-parametrised quadratic through three points.

    Seed 002, eq. 4–9: P(t) = a1 + a2 t + a3 t² through P_{i-1}, P_i, P_{i+1} at t = −t_a, 0, t_b
    with t_a, t_b the chord lengths; κ = 2|a2 × a3| / |a2|³ (eq. 9, generalised to 3-D). The two
    end points take their neighbour's value. Repeated points are an error (no chord length).
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[0] < 3 or pts.shape[1] not in (2, 3):
        raise InputError(f"points: shape {pts.shape}; need at least 3 points of 2 or 3 coordinates")
    if not np.isfinite(pts).all():
        i = int(np.argwhere(~np.isfinite(pts))[0, 0])
        raise InputError(f"points[{i}] = {pts[i].tolist()}; coordinates must be finite")
    pts = _pad3(pts)
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
    kappa_inner = 2.0 * np.linalg.norm(np.cross(a2, a3), axis=1) / np.linalg.norm(a2, axis=1) ** 3
    return np.concatenate([[kappa_inner[0]], kappa_inner, [kappa_inner[-1]]])


def samples_from_points(points: np.ndarray, curve: Nurbs | None = None, *,
                        tolerance_mm: float | None = None,
                        path_tolerance_mm: float | None = None) -> PathSamples:
    """A :class:`PathSamples` for a point sequence: chord-length s, and the curvature of the path
    the points describe within their rounding, corners blended as a controller blends them within
    the path tolerance P (:func:`fuzzyfeed.polyline.polyline_curvature`; ``tolerance_mm`` None
    reads the rounding from the coordinates, ``path_tolerance_mm`` None is LinuxCNC-style
    G64 P0.01). Consecutive repeated points are allowed (they get their neighbour's values).

    ``curve``, if given, is the degree-1 NURBS through the points with chord-length knots on
    [0, 1] (so u = s / L is its parameter at every point); planners and the simulator move along it.
    """
    from fuzzyfeed.polyline import polyline_curvature

    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[0] < 2 or pts.shape[1] not in (2, 3):
        raise InputError(f"points: shape {pts.shape}; need at least 2 points of 2 or 3 coordinates")
    result = polyline_curvature(pts, tolerance_mm, path_tolerance_mm)
    dim = pts.shape[1]
    xyz = _pad3(pts)
    chords = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(chords)])
    if s[-1] <= 0:
        raise InputError("points: all points coincide; a path needs length > 0")
    nan = np.full_like(xyz, np.nan)
    return PathSamples(u=s / s[-1], xyz=xyz, s=s, tangent=result.tangent,
                       curvature=result.curvature, d1=nan, d2=nan, dim=dim, curve=curve)
