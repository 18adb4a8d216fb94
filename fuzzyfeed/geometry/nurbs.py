"""NURBS curves: a validated immutable value, fast evaluation through the piecewise power basis.

The curve C(u) = Σ N_i,p(u) w_i P_i / Σ N_i,p(u) w_i (seed 002, eq. 1; The NURBS Book eq. 4.1) is
converted once, at construction, into one polynomial per non-empty knot span in homogeneous
coordinates (seed 004, "Conversion from B-spline to piecewise power basis functions", steps 1-3).
Evaluating C, C′ and C″ is then a Horner pass per span plus the quotient rule for the rational
derivatives (The NURBS Book eq. 4.8), vectorised over any number of parameters.

Arc length uses Gauss–Legendre quadrature per span, refined adaptively until two levels agree to a
stated tolerance (seed 004, eq. 8–9); u(s) is found by a safeguarded Newton iteration on s(u).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from fuzzyfeed.geometry._kernels import arc_kernel, evaluate_power_basis, nurbs_compiled
from fuzzyfeed.errors import NurbsError
from fuzzyfeed.geometry.power_basis import power_basis as _power_basis

#: Gauss–Legendre order used per interval for arc length (exact for polynomials of degree 15).
GAUSS_ORDER = 8
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(GAUSS_ORDER)
#: 3-point Gauss–Legendre, for the short Newton steps of u(s), and how short they are (a fraction
#: of their arc-length table interval: the rule's error is ~SHORT_STEP⁶ of the step's length).
_GL3 = np.polynomial.legendre.leggauss(3)
SHORT_STEP = 1e-3
#: Default absolute arc-length tolerance, relative to the control polygon size.
ARC_LENGTH_RTOL = 1e-13
#: Intervals integrated per block (GAUSS_ORDER nodes each): bounds the arc length's temporary
#: memory to a few MB whatever the number of points.
ARC_BLOCK_INTERVALS = 8192


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
#: Most arc-length intervals the adaptive quadrature may create (a work budget, ~30 MB).
MAX_ARC_INTERVALS = 1_000_000


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

    def param_at_length(self, s: np.ndarray | float) -> np.ndarray:
        """u(s): the parameter at each arc length, by safeguarded Newton iteration on s(u)."""
        return self._arc_table.param_at(self, s)


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


# ---------------------------------------------------------------------- arc length
@dataclass(frozen=True, eq=False)
class ArcLengthTable:
    """Adaptive Gauss–Legendre partition of the domain and cumulative arc length at its breaks."""

    breaks: np.ndarray      # parameter breaks, strictly increasing, covering the domain
    cumulative: np.ndarray  # arc length at each break, cumulative[0] = 0
    end_speeds: np.ndarray  # (intervals, 2): |C′| at each interval's two ends, from inside it

    @staticmethod
    def build(curve: Nurbs, rtol: float = ARC_LENGTH_RTOL, max_depth: int = 40) -> ArcLengthTable:
        """Refine each span by halving until GL(whole) and GL(halves) agree (seed 004 eq. 9)."""
        scale = float(np.ptp(curve.control_points, axis=0).max()) or 1.0
        tol = rtol * scale
        spans = curve.span_breaks
        lo, hi = spans[:-1].copy(), spans[1:].copy()
        whole = _gl_lengths(curve, lo, hi)
        done_lo, done_hi, done_len = [], [], []
        for _ in range(max_depth):
            if lo.size == 0:
                break
            mid = 0.5 * (lo + hi)
            left = _gl_lengths(curve, lo, mid)
            right = _gl_lengths(curve, mid, hi)
            halves = left + right
            ok = np.abs(halves - whole) <= tol * np.maximum(1.0, (hi - lo) / (spans[-1] - spans[0]))
            done_lo.append(lo[ok]); done_hi.append(hi[ok]); done_len.append(halves[ok])
            keep = ~ok
            if 2 * int(keep.sum()) + sum(a.size for a in done_lo) > MAX_ARC_INTERVALS:
                raise NurbsError(f"arc length: more than {MAX_ARC_INTERVALS:,} intervals without "
                                 "converging; the curve is too irregular (check weights and knots)")
            lo = np.concatenate([lo[keep], mid[keep]])
            hi = np.concatenate([mid[keep], hi[keep]])
            whole = np.concatenate([left[keep], right[keep]])
        if lo.size:  # depth exhausted (e.g. a cusp): accept the finest estimate
            done_lo.append(lo); done_hi.append(hi); done_len.append(whole)
        lo = np.concatenate(done_lo)
        order = np.argsort(lo)
        lengths = np.concatenate(done_len)[order]
        breaks = np.append(lo[order], np.concatenate(done_hi)[order][-1])
        cumulative = np.concatenate([[0.0], np.cumsum(lengths)])
        # the speed at both ends of each interval, the right end approached from inside (the
        # derivative may jump at a knot): the slopes of the Hermite first guess of u(s)
        ends = np.concatenate([breaks[:-1], np.nextafter(breaks[1:], -np.inf)])
        d = np.empty((2, ends.size, curve.dim))
        evaluate_power_basis(curve._spans, curve._coeffs, ends, 1, d)
        end_speeds = np.linalg.norm(d[1], axis=-1).reshape(2, -1).T.copy()
        for arr in (breaks, cumulative, end_speeds):
            arr.flags.writeable = False
        return ArcLengthTable(breaks, cumulative, end_speeds)

    def _interval(self, u: np.ndarray) -> np.ndarray:
        return np.clip(np.searchsorted(self.breaks, u, side="right") - 1, 0, self.breaks.size - 2)

    def length_at(self, curve: Nurbs, u: np.ndarray | float) -> np.ndarray:
        arr = np.asarray(u, dtype=float)
        flat = np.atleast_1d(arr).ravel()
        k = self._interval(flat)
        s = _gl_lengths(curve, self.breaks[k], flat)
        s += self.cumulative[k]
        return s.reshape(arr.shape) if arr.ndim else float(s[0])

    def param_at(self, curve: Nurbs, s: np.ndarray | float, iterations: int = 30) -> np.ndarray:
        arr = np.asarray(s, dtype=float)
        flat = np.atleast_1d(arr).ravel()
        total = self.cumulative[-1]
        bad = ~np.isfinite(flat) | (flat < -1e-9 * total) | (flat > total * (1 + 1e-12) + 1e-12)
        if bad.any():
            i = int(np.argmax(bad))
            raise NurbsError(f"s[{i}] = {_fmt(flat[i])} is outside the curve's length [0, {_fmt(total)}]")
        u = np.empty(flat.size)
        # block by block (each point's iteration is independent): temporaries stay a few MB;
        # each Newton step evaluates C' at GAUSS_ORDER nodes and the point itself
        compiled = nurbs_compiled(flat.size * (GAUSS_ORDER + 1))
        if compiled:
            # the same iteration point by point, compiled (geometry/_arc_jit.py): the same floats
            span = self.breaks[-1] - self.breaks[0]
            arc_kernel()(curve._spans, curve._coeffs, self.breaks, self.cumulative, self.end_speeds,
                         np.ascontiguousarray(np.clip(flat, 0.0, total)), int(iterations),
                         1e-14 * max(total, 1.0), SHORT_STEP, 2 * np.finfo(float).eps * span,
                         _GL_NODES, _GL_WEIGHTS, _GL3[0], _GL3[1], u)
            return u.reshape(arr.shape) if arr.ndim else float(u[0])
        for start in range(0, flat.size, ARC_BLOCK_INTERVALS):
            block = slice(start, start + ARC_BLOCK_INTERVALS)
            u[block] = self._param_block(curve, np.clip(flat[block], 0.0, total), iterations, compiled)
        return u.reshape(arr.shape) if arr.ndim else float(u[0])

    def _param_block(self, curve: Nurbs, target: np.ndarray, iterations: int, compiled: bool) -> np.ndarray:
        """Safeguarded Newton on s(u) = target inside the table interval holding each target.

        First guess: the cubic Hermite interpolant of u(s) over the interval (slopes 1/|C′| at
        its ends), linear where that would not be monotone (Fritsch–Carlson: m0² + m1² > 9).
        The residual f(u) = s(u) − target is integrated from the interval's start (GAUSS_ORDER
        nodes); after a Newton step shorter than SHORT_STEP of the interval it is updated by
        integrating over the step alone (3 nodes, exact to rounding over so short a stretch).
        """
        total = self.cumulative[-1]
        k = np.clip(np.searchsorted(self.cumulative, target, side="right") - 1, 0, self.breaks.size - 2)
        a, b = self.breaks[k].copy(), self.breaks[k + 1].copy()
        width = b - a
        seg = self.cumulative[k + 1] - self.cumulative[k]
        frac = np.divide(target - self.cumulative[k], seg, out=np.zeros_like(target), where=seg > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            m0 = seg / (self.end_speeds[k, 0] * width)
            m1 = seg / (self.end_speeds[k, 1] * width)
        monotone = np.isfinite(m0) & np.isfinite(m1) & (m0 * m0 + m1 * m1 <= 9.0)
        f2 = frac * frac
        with np.errstate(invalid="ignore", over="ignore"):   # inf slopes at a cusp: not used
            hermite = (f2 * frac - 2.0 * f2 + frac) * m0 + (3.0 * f2 - 2.0 * f2 * frac) + (f2 * frac - f2) * m1
        u = a + width * np.where(monotone, np.clip(hermite, 0.0, 1.0), frac)
        base = self.cumulative[k]
        left = self.breaks[k]
        tol = 1e-14 * max(total, 1.0)
        span = self.breaks[-1] - self.breaks[0]
        active = np.ones(u.size, dtype=bool)
        short = np.zeros(u.size, dtype=bool)   # the last step was short: update f over it
        u_prev = np.empty(u.size)
        f_prev = np.empty(u.size)
        for _ in range(iterations):
            idx = np.flatnonzero(active)
            if idx.size == 0:
                break
            ui = u[idx]
            inc = short[idx]
            f = np.empty(idx.size)
            full = idx[~inc]
            f[~inc] = base[full] + _gl_lengths(curve, left[full], u[full], compiled) - target[full]
            part = idx[inc]
            f[inc] = f_prev[part] + _gl_lengths(curve, u_prev[part], u[part], compiled, _GL3)
            done = np.abs(f) <= tol
            active[idx[done]] = False
            idx, ui, f = idx[~done], ui[~done], f[~done]
            # keep the bracket [a, b] around the root; f is increasing in u
            pos = f > 0
            b[idx[pos]] = ui[pos]
            a[idx[~pos]] = ui[~pos]
            d1 = np.empty((2, ui.size, curve.dim))
            evaluate_power_basis(curve._spans, curve._coeffs, ui, 1, d1, compiled)
            speed = np.sqrt(np.einsum("ij,ij->i", d1[1], d1[1]))
            with np.errstate(divide="ignore", invalid="ignore"):
                step = ui - f / speed
            outside = ~np.isfinite(step) | (step < a[idx]) | (step > b[idx])
            step[outside] = 0.5 * (a[idx][outside] + b[idx][outside])
            moved = np.abs(step - ui)
            u_prev[idx], f_prev[idx] = ui, f
            short[idx] = ~outside & (moved <= SHORT_STEP * width[idx])
            u[idx] = step
            active[idx[moved <= 2 * np.finfo(float).eps * span]] = False
        return u


def _gl_lengths(curve: Nurbs, lo: np.ndarray, hi: np.ndarray, compiled: bool | None = None,
                rule: tuple[np.ndarray, np.ndarray] = (_GL_NODES, _GL_WEIGHTS)) -> np.ndarray:
    """∫_lo^hi |C′(u)| du per interval, by Gauss–Legendre (seed 004 eq. 8): GAUSS_ORDER points
    unless ``rule`` (nodes, weights) says otherwise.

    Streamed: ARC_BLOCK_INTERVALS intervals at a time, so memory is a few MB at any size; the
    weighted sum runs node by node in a fixed order, so the result does not depend on the blocks.
    ``lo`` and ``hi`` lie in the curve's domain (the table's breaks and validated parameters).
    """
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    gl_nodes, gl_weights = rule
    order = gl_nodes.size
    n = lo.size
    if compiled is None:
        compiled = nurbs_compiled(n * order)
    out = np.empty(n)
    spans, coeffs, dim = curve._spans, curve._coeffs, curve.dim
    for start in range(0, n, ARC_BLOCK_INTERVALS):
        block = slice(start, start + ARC_BLOCK_INTERVALS)
        half = 0.5 * (hi[block] - lo[block])
        mid = 0.5 * (hi[block] + lo[block])
        nodes = (mid[:, None] + half[:, None] * gl_nodes[None, :]).ravel()
        d = np.empty((2, nodes.size, dim))
        evaluate_power_basis(spans, coeffs, nodes, 1, d, compiled)
        speed = np.sqrt(np.einsum("ij,ij->i", d[1], d[1])).reshape(-1, order)
        acc = speed[:, 0] * gl_weights[0]
        for j in range(1, order):
            acc += speed[:, j] * gl_weights[j]
        out[block] = half * acc
    return out


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
