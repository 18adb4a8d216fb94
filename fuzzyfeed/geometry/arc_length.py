"""Arc length of a NURBS curve (:class:`fuzzyfeed.geometry.nurbs.Nurbs`), from its piecewise power basis.

s(u) = ∫ |C′(u)| du by Gauss–Legendre quadrature per interval (seed 004, eq. 8), each knot span
halved until GL(whole) and GL(halves) agree to a stated tolerance (eq. 9): :class:`ArcLengthTable`
holds the partition and the cumulative length at its breaks. u(s) is a safeguarded Newton
iteration on s(u) from a monotone cubic Hermite first guess. Both run in blocks of
:data:`ARC_BLOCK_INTERVALS` intervals, so memory is a few MB at any size.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from fuzzyfeed.geometry._kernels import arc_kernel, evaluate_power_basis, nurbs_compiled
from fuzzyfeed.errors import NurbsError

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
#: Most arc-length intervals the adaptive quadrature may create (a work budget, ~30 MB).
MAX_ARC_INTERVALS = 1_000_000


def _fmt(value: float) -> str:
    return f"{value:.12g}"


class PowerBasisCurve(Protocol):
    """What the arc length reads of a curve (a :class:`~fuzzyfeed.geometry.nurbs.Nurbs`): its control
    points (the tolerance's scale), knot-span breaks, dimension and power-basis coefficients."""

    control_points: np.ndarray
    span_breaks: np.ndarray
    dim: int
    _spans: np.ndarray
    _coeffs: np.ndarray


@dataclass(frozen=True, eq=False)
class ArcLengthTable:
    """Adaptive Gauss–Legendre partition of the domain and cumulative arc length at its breaks."""

    breaks: np.ndarray      # parameter breaks, strictly increasing, covering the domain
    cumulative: np.ndarray  # arc length at each break, cumulative[0] = 0
    end_speeds: np.ndarray  # (intervals, 2): |C′| at each interval's two ends, from inside it

    @staticmethod
    def build(curve: PowerBasisCurve, rtol: float = ARC_LENGTH_RTOL, max_depth: int = 40) -> ArcLengthTable:
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

    def length_at(self, curve: PowerBasisCurve, u: np.ndarray | float) -> np.ndarray:
        arr = np.asarray(u, dtype=float)
        flat = np.atleast_1d(arr).ravel()
        k = self._interval(flat)
        s = _gl_lengths(curve, self.breaks[k], flat)
        s += self.cumulative[k]
        return s.reshape(arr.shape) if arr.ndim else float(s[0])

    def param_at(self, curve: PowerBasisCurve, s: np.ndarray | float, iterations: int = 30,
                 chain: float = 0.0) -> np.ndarray:
        """u(s) by safeguarded Newton (:meth:`_param_block`). ``chain`` > 0, for non-decreasing
        ``s`` (servo ticks): the first residual from the last point within ``chain`` of its table
        interval (geometry/_arc_jit.param_at; compiled only; floats within the chain's bound)."""
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
        # once loaded, the compiled u(s) serves calls of any size (the look-ahead's ~10⁴ calls of a
        # few points each spent ~1 ms apiece in the numpy iteration's temporaries); the same floats
        if compiled or chain > 0 or (flat.size and arc_kernel.cache_info().currsize > 0):
            # the same iteration point by point, compiled (geometry/_arc_jit.py): the same floats
            span = self.breaks[-1] - self.breaks[0]
            arc_kernel()(curve._spans, curve._coeffs, self.breaks, self.cumulative, self.end_speeds,
                         np.ascontiguousarray(np.clip(flat, 0.0, total)), int(iterations),
                         1e-14 * max(total, 1.0), SHORT_STEP, 2 * np.finfo(float).eps * span,
                         _GL_NODES, _GL_WEIGHTS, _GL3[0], _GL3[1], float(chain), u)
            return u.reshape(arr.shape) if arr.ndim else float(u[0])
        for start in range(0, flat.size, ARC_BLOCK_INTERVALS):
            block = slice(start, start + ARC_BLOCK_INTERVALS)
            u[block] = self._param_block(curve, np.clip(flat[block], 0.0, total), iterations, compiled)
        return u.reshape(arr.shape) if arr.ndim else float(u[0])

    def _param_block(self, curve: PowerBasisCurve, target: np.ndarray, iterations: int, compiled: bool) -> np.ndarray:
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


def _gl_lengths(curve: PowerBasisCurve, lo: np.ndarray, hi: np.ndarray, compiled: bool | None = None,
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
