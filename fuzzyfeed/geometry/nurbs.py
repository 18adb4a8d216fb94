"""NURBS curves: a validated immutable value, fast evaluation through the piecewise power basis.

The curve C(u) = Σ N_i,p(u) w_i P_i / Σ N_i,p(u) w_i (seed 002, eq. 1; The NURBS Book eq. 4.1) is
converted once, at construction, into one polynomial per non-empty knot span in homogeneous
coordinates (seed 004, "Conversion from B-spline to piecewise power basis functions", steps 1-3).
Evaluating C, C′ and C″ is then a Horner pass per span plus the quotient rule for the rational
derivatives (The NURBS Book eq. 4.8), vectorised over any number of parameters.

Arc length (:mod:`fuzzyfeed.geometry.arc_length`) uses Gauss–Legendre quadrature per span, refined
adaptively until two levels agree to a stated tolerance (seed 004, eq. 8–9); u(s) is found by a
safeguarded Newton iteration on s(u). Knot insertion and the split into Bézier pieces are here too.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from fuzzyfeed.geometry._kernels import evaluate_power_basis
from fuzzyfeed.geometry.arc_length import ArcLengthTable
from fuzzyfeed.errors import NurbsError
from fuzzyfeed.geometry.power_basis import power_basis as _power_basis

#: Scale guards (mm): coordinates beyond 1 km are not a machine's path; a control polygon smaller
#: than 1 nm has no length to feed along.
MAX_COORDINATE_MM = 1e6
MIN_EXTENT_MM = 1e-6
#: Largest ratio of the largest to the smallest weight: beyond it the rational quotient loses every
#: digit (a weight of 1e-300 next to 1 divides by zero) and arc length never converges.
MAX_WEIGHT_RATIO = 1e6
#: Smallest parameter range relative to max(1, |knot|): derivatives scale with 1/range.
MIN_KNOT_RANGE = 1e-9
#: Largest knot magnitude: a parameter is a relative measure along the curve, and beyond 10¹² the
#: sums of the quadrature (and of two knots) leave float64's exponent range.
MAX_KNOT = 1e12


def _fmt(value: float) -> str:
    return f"{value:.12g}"


@dataclass(frozen=True, eq=False)
class Nurbs:
    """A clamped NURBS curve of degree p ≥ 1 in 2-D or 3-D, validated at construction.

    Arguments are copied into read-only float arrays. ``knots`` has length n + p + 1 for n control
    points, is non-decreasing and clamped (first and last p + 1 knots equal); ``weights`` are finite
    and positive. Any other input raises :class:`NurbsError` naming the field, the index and the
    rule broken.
    """

    degree: int
    knots: np.ndarray
    control_points: np.ndarray
    weights: np.ndarray = None  # type: ignore[assignment]
    _spans: np.ndarray = field(init=False, repr=False)
    _coeffs: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        degree = _check_degree(self.degree)
        points = _check_points(self.control_points)
        n = points.shape[0]
        weights = _check_weights(self.weights, n)
        knots = _check_knots(self.knots, n, degree)
        for name, value in (("degree", degree), ("knots", knots),
                            ("control_points", points), ("weights", weights)):
            object.__setattr__(self, name, value)
        # the curve does not change when every weight is scaled: the largest weight becomes 1
        spans, coeffs = _power_basis(degree, knots, points, weights / weights.max())
        object.__setattr__(self, "_spans", spans)
        object.__setattr__(self, "_coeffs", coeffs)

    # ------------------------------------------------------------------ basic properties
    @property
    def dim(self) -> int:
        """Spatial dimension of the control points (2 or 3)."""
        return int(self.control_points.shape[1])

    @property
    def n_control_points(self) -> int:
        return int(self.control_points.shape[0])

    @property
    def domain(self) -> tuple[float, float]:
        """Parameter range [u_p, u_n] of the clamped curve."""
        return float(self.knots[0]), float(self.knots[-1])

    @property
    def span_breaks(self) -> np.ndarray:
        """Distinct knot values bounding the non-empty spans (length = spans + 1)."""
        return self._spans

    @property
    def is_rational(self) -> bool:
        return bool(np.ptp(self.weights) > 0.0)

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, u: np.ndarray | float, order: int = 2) -> np.ndarray:
        """C(u) and its derivatives up to ``order`` (0, 1 or 2) with respect to u.

        Returns an array of shape (order + 1, N, dim) for array input, (order + 1, dim) for a
        scalar. Parameters outside the domain are an error (a clamped curve is not extrapolated).
        """
        if order not in (0, 1, 2):
            raise NurbsError(f"order: {order!r} is not supported, use 0, 1 or 2")
        arr = np.asarray(u, dtype=float)
        scalar = arr.ndim == 0
        flat = np.atleast_1d(arr).ravel()
        lo, hi = self.domain
        bad = ~np.isfinite(flat) | (flat < lo) | (flat > hi)
        if bad.any():
            i = int(np.argmax(bad))
            raise NurbsError(f"u[{i}] = {_fmt(flat[i])} is outside the curve's domain "
                             f"[{_fmt(lo)}, {_fmt(hi)}]")
        out = np.empty((order + 1, flat.size, self.dim))
        evaluate_power_basis(self._spans, self._coeffs, flat, order, out)
        return out[:, 0] if scalar else out

    def __call__(self, u: np.ndarray | float) -> np.ndarray:
        """Points C(u)."""
        return self.evaluate(u, order=0)[0]

    def curvature(self, u: np.ndarray | float) -> np.ndarray:
        """κ(u) = |C′ × C″| / |C′|³ in 1/length (The NURBS Book / seed 002 eq. 9)."""
        _, d1, d2 = self.evaluate(u, order=2)
        return curvature_from_derivatives(d1, d2)

    # ------------------------------------------------------------------ arc length
    @cached_property
    def _arc_table(self) -> ArcLengthTable:
        return ArcLengthTable.build(self)

    @property
    def arc_table(self) -> ArcLengthTable:
        """The adaptive Gauss–Legendre partition of the domain and its cumulative arc length
        (built once per curve): where the speed |C′| is smooth enough for GL (seed 004 eq. 9)."""
        return self._arc_table

    @property
    def length(self) -> float:
        """Total arc length (adaptive Gauss–Legendre, seed 004 eq. 8–9)."""
        return float(self._arc_table.cumulative[-1])

    def arc_length(self, u: np.ndarray | float) -> np.ndarray:
        """s(u): arc length from the start of the curve to each parameter."""
        return self._arc_table.length_at(self, u)

    def param_at_length(self, s: np.ndarray | float, chain: float = 0.0) -> np.ndarray:
        """u(s): the parameter at each arc length, by safeguarded Newton iteration on s(u);
        ``chain`` > 0 for non-decreasing ``s``: see :meth:`ArcLengthTable.param_at`."""
        return self._arc_table.param_at(self, s, chain=chain)


# ---------------------------------------------------------------------- validation
def _check_degree(degree: object) -> int:
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)):
        if isinstance(degree, float) and degree.is_integer():
            degree = int(degree)
        else:
            raise NurbsError(f"degree: {degree!r} is not an integer; the degree must be an integer >= 1")
    if degree < 1:
        raise NurbsError(f"degree: {degree} is not allowed; the degree must be >= 1")
    return int(degree)


def non_number(value: object, depth: int = 0) -> object | None:
    """The first bool or string inside nested lists (numpy would read True as 1, "2" as 2)."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        return value
    if isinstance(value, (list, tuple)) and depth < 3:
        for item in value:
            bad = non_number(item, depth + 1)
            if bad is not None:
                return bad
    return None


def _as_float_array(value: object, field_name: str) -> np.ndarray:
    bad = non_number(value)
    if bad is not None:
        raise NurbsError(f"{field_name}: {bad!r} is not a number")
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise NurbsError(f"{field_name}: cannot be read as numbers ({exc})") from None
    return arr


def _check_points(points: object) -> np.ndarray:
    arr = _as_float_array(points, "control_points")
    if arr.ndim != 2 or arr.shape[1] not in (2, 3):
        raise NurbsError(f"control_points: shape {arr.shape} is not allowed; "
                         "expected a list of 2-D or 3-D points, shape (n, 2) or (n, 3)")
    bad = ~np.isfinite(arr)
    if bad.any():
        i, j = (int(v) for v in np.argwhere(bad)[0])
        raise NurbsError(f"control_points[{i}][{j}] = {arr[i, j]}; coordinates must be finite")
    big = np.abs(arr) > MAX_COORDINATE_MM
    if big.any():
        i, j = (int(v) for v in np.argwhere(big)[0])
        raise NurbsError(f"control_points[{i}][{j}] = {arr[i, j]:g} mm; coordinates must lie within "
                         f"±{MAX_COORDINATE_MM:g} mm (1 km)")
    if arr.shape[0] and float(np.ptp(arr, axis=0).max()) < MIN_EXTENT_MM:
        raise NurbsError(f"control_points: all within {float(np.ptp(arr, axis=0).max()):g} mm of each "
                         f"other; a path needs a control polygon larger than {MIN_EXTENT_MM:g} mm "
                         "(this one has no length)")
    arr.flags.writeable = False
    return arr


def _check_weights(weights: object, n: int) -> np.ndarray:
    arr = np.ones(n) if weights is None else _as_float_array(weights, "weights")
    if arr.ndim != 1 or arr.size != n:
        raise NurbsError(f"weights: {arr.size} values for {n} control points; "
                         "give one weight per control point")
    bad = ~np.isfinite(arr) | (arr <= 0.0)
    if bad.any():
        i = int(np.argmax(bad))
        raise NurbsError(f"weights[{i}] = {arr[i]}; weights must be finite and > 0")
    if arr.size and np.log(arr.max()) - np.log(arr.min()) > np.log(MAX_WEIGHT_RATIO):
        i, j = int(np.argmax(arr)), int(np.argmin(arr))
        raise NurbsError(f"weights[{i}] / weights[{j}] = {arr[i]:g} / {arr[j]:g} > {MAX_WEIGHT_RATIO:g}; "
                         f"the largest weight may be at most {MAX_WEIGHT_RATIO:g} times the smallest")
    arr.flags.writeable = False
    return arr


def _check_knots(knots: object, n: int, p: int) -> np.ndarray:
    arr = _as_float_array(knots, "knots")
    if arr.ndim != 1:
        raise NurbsError(f"knots: shape {arr.shape} is not allowed; expected a flat list of numbers")
    if n < p + 1:
        raise NurbsError(f"control_points: {n} points are too few for degree {p}; "
                         f"need at least p + 1 = {p + 1}")
    expected = n + p + 1
    if arr.size != expected:
        raise NurbsError(f"knots: length {arr.size}, expected n + p + 1 = {n} + {p} + 1 = {expected} "
                         f"({n} control points, degree {p})")
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.argmax(bad))
        raise NurbsError(f"knots[{i}] = {arr[i]}; knots must be finite")
    big = np.abs(arr) > MAX_KNOT
    if big.any():
        i = int(np.argmax(big))
        raise NurbsError(f"knots[{i}] = {_fmt(arr[i])}; knots must lie within ±{MAX_KNOT:g}")
    dec = np.diff(arr) < 0
    if dec.any():
        i = int(np.argmax(dec)) + 1
        raise NurbsError(f"knots[{i}] = {_fmt(arr[i])} < knots[{i - 1}] = {_fmt(arr[i - 1])}; "
                         "knots must be non-decreasing")
    n_end = p + 1
    for side, ref in (("first", 0), ("last", arr.size - 1)):
        block = np.arange(n_end) if side == "first" else np.arange(arr.size - n_end, arr.size)
        off = block[arr[block] != arr[ref]]
        if off.size:
            j = int(off[0])
            raise NurbsError(f"knots[{j}] = {_fmt(arr[j])}; the knot vector must be clamped: the {side} "
                             f"p + 1 = {n_end} knots must equal knots[{ref}] = {_fmt(arr[ref])}")
    if arr[0] == arr[-1]:
        raise NurbsError(f"knots: all equal to {_fmt(arr[0])}; the parameter range must not be empty")
    span = float(arr[-1] - arr[0])
    if not np.isfinite(span) or span < MIN_KNOT_RANGE * max(1.0, abs(arr[0]), abs(arr[-1])):
        raise NurbsError(f"knots: range [{_fmt(arr[0])}, {_fmt(arr[-1])}] is too narrow (or too wide); "
                         f"the range must be at least {MIN_KNOT_RANGE:g} x max(1, |knot|)")
    interior = arr[p + 1: arr.size - p - 1]
    if interior.size:
        values, first_idx, counts = np.unique(interior, return_index=True, return_counts=True)
        too_many = counts > p
        if too_many.any():
            k = int(np.argmax(too_many))
            i = p + 1 + int(first_idx[k])
            raise NurbsError(f"knots[{i}] = {_fmt(values[k])} repeats {counts[k]} times; an interior knot "
                             f"may repeat at most p = {p} times (more would break the curve)")
        inner = (interior <= arr[0]) | (interior >= arr[-1])
        if inner.any():
            i = p + 1 + int(np.argmax(inner))
            raise NurbsError(f"knots[{i}] = {_fmt(arr[i])}; interior knots must lie strictly inside "
                             f"({_fmt(arr[0])}, {_fmt(arr[-1])}) for a clamped curve")
    arr.flags.writeable = False
    return arr


def curvature_from_derivatives(d1: np.ndarray, d2: np.ndarray) -> np.ndarray:
    """κ = |C′ × C″| / |C′|³ for 2-D or 3-D derivative arrays of shape (..., dim).

    Where |C′| = 0 (a stationary point) κ is undefined and returned as inf.
    """
    if d1.shape[-1] == 2:
        cross = np.abs(d1[..., 0] * d2[..., 1] - d1[..., 1] * d2[..., 0])
    else:
        cross = np.linalg.norm(np.cross(d1, d2), axis=-1)
    speed = np.linalg.norm(d1, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = cross / speed**3
    return np.where(speed > 0.0, kappa, np.inf)


def insert_knot(p: int, knots: np.ndarray, pw: np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray]:
    """Insert ``u`` once into a curve of degree ``p`` with homogeneous control points ``pw``
    (Boehm's knot insertion, The NURBS Book A5.1 with r = 1)."""
    k = int(np.searchsorted(knots, u, side="right")) - 1        # knots[k] <= u < knots[k+1]
    q = np.empty((pw.shape[0] + 1, pw.shape[1]))
    q[:k - p + 1] = pw[:k - p + 1]
    for i in range(k - p + 1, k + 1):
        alpha = (u - knots[i]) / (knots[i + p] - knots[i])
        q[i] = alpha * pw[i] + (1.0 - alpha) * pw[i - 1]
    q[k + 1:] = pw[k:]
    return np.insert(knots, k + 1, u), q


def bezier_segments(curve: Nurbs) -> list[Nurbs]:
    """The curve split at every interior knot into rational Bézier pieces (degree p, p + 1
    control points, knots a^(p+1) b^(p+1)): each interior knot is inserted until its multiplicity
    is p (knot refinement, The NURBS Book §5.3). Each piece equals the curve on its span, and its
    knot vector is uniform clamped (the one LinuxCNC's G5.2 builds)."""
    p = curve.degree
    knots = np.asarray(curve.knots, dtype=float)
    w = np.asarray(curve.weights, dtype=float)
    pw = np.column_stack([curve.control_points * w[:, None], w])
    lo, hi = curve.domain
    interior, counts = np.unique(knots[(knots > lo) & (knots < hi)], return_counts=True)
    for u, m in zip(interior, counts):
        for _ in range(p - int(m)):
            knots, pw = insert_knot(p, knots, pw, float(u))
    breaks = np.concatenate([[lo], interior, [hi]])
    pieces = []
    for j in range(breaks.size - 1):
        block = pw[j * p: j * p + p + 1]
        pieces.append(Nurbs(p, [breaks[j]] * (p + 1) + [breaks[j + 1]] * (p + 1),
                            block[:, :-1] / block[:, -1:], block[:, -1]))
    return pieces
