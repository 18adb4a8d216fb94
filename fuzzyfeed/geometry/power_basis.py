"""A B-spline's per-span power basis (seed 004, "Conversion from B-spline to piecewise power basis
functions", steps 1-2): the Cox–de Boor recursion (seed 002 eq. 2–3) on polynomials instead of
numbers, for every non-empty knot span at once (a blended polyline of a long program has ~10⁴
spans; the loop over them was 3.6 s of camotics bear.nc's schedule). :func:`_span_basis_matrix`
is the recursion for one span, the reference the array form is checked against bit for bit
(tests/test_arc_jit.py)."""

from __future__ import annotations

import numpy as np


def _linear(c0: float, c1: float) -> np.ndarray:
    return np.array([c0, c1])


def _span_basis_matrix(p: int, knots: np.ndarray, i: int) -> np.ndarray:
    """Power-basis coefficients of N_{i-p..i, p} on span [u_i, u_{i+1}) in t = (u - u_i)/h.

    Row k holds the coefficient of t**k, column j the basis function N_{i-p+j, p}. Built with the
    Cox–de Boor recursion (seed 002 eq. 2–3) on polynomials instead of numbers (seed 004 step 1-2).
    """
    a = knots[i]
    h = knots[i + 1] - a
    # basis[j] is N_{i-k+j, k} as a coefficient vector of length p+1 (low → high power)
    basis = [np.zeros(p + 1) for _ in range(p + 1)]
    basis[0][0] = 1.0
    for k in range(1, p + 1):
        new = [np.zeros(p + 1) for _ in range(k + 1)]
        for j in range(k + 1):
            r = i - k + j  # N_{r, k}
            acc = np.zeros(p + 1)
            if j >= 1:  # left term uses N_{r, k-1} = basis[j-1]
                den = knots[r + k] - knots[r]
                if den > 0.0:
                    acc += np.convolve(_linear((a - knots[r]) / den, h / den), basis[j - 1])[: p + 1]
            if j <= k - 1:  # right term uses N_{r+1, k-1} = basis[j]
                den = knots[r + k + 1] - knots[r + 1]
                if den > 0.0:
                    acc += np.convolve(_linear((knots[r + k + 1] - a) / den, -h / den), basis[j])[: p + 1]
            new[j] = acc
        basis = new
    return np.stack(basis, axis=1)


def power_basis(p: int, knots: np.ndarray, points: np.ndarray, weights: np.ndarray):
    """Per-span power-basis coefficients of the homogeneous curve (w·P, w).

    Returns the span breakpoints (distinct knots, length m + 1) and coefficients of shape
    (m, p + 1, dim + 1): coefficient of t**k of span s is ``coeffs[s, k]``.
    """
    homogeneous = np.hstack([points * weights[:, None], weights[:, None]])
    n = points.shape[0]
    if p == 1:   # N = (1 - t, t) on every span: the same as the recursion, without the loop
        i = np.arange(1, n)
        i = i[knots[i + 1] > knots[i]]
        spans = np.concatenate([[knots[1]], knots[i + 1]])
        out = np.stack([homogeneous[i - 1], -homogeneous[i - 1] + homogeneous[i]], axis=1)
        spans.flags.writeable = False
        out.flags.writeable = False
        return spans, out
    i = np.arange(p, n)
    i = i[knots[i + 1] > knots[i]]
    spans = np.concatenate([[knots[p]], knots[i + 1]])
    m = _span_basis_matrices(p, knots, i)
    window = homogeneous[i[:, None] + np.arange(-p, 1)[None, :]]      # (spans, p + 1, dim + 1)
    out = np.matmul(m, window)
    spans.flags.writeable = False
    out.flags.writeable = False
    return spans, out


def _span_basis_matrices(p: int, knots: np.ndarray, i: np.ndarray) -> np.ndarray:
    """:func:`_span_basis_matrix` for every span start ``i`` at once (spans, p + 1, p + 1): the
    same recursion and the same floating-point operations (np.convolve of a linear factor is
    c0·b_m + c1·b_{m-1}, the first term alone at m = 0; a term with a zero knot interval is not
    added), on arrays over the spans: bear.nc's blend fit spent 3.6 s in the loop over its 14k spans."""
    a = knots[i]
    h = knots[i + 1] - a
    ns = i.size
    basis = np.zeros((ns, 1, p + 1))
    basis[:, 0, 0] = 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        for k in range(1, p + 1):
            new = np.zeros((ns, k + 1, p + 1))
            for j in range(k + 1):
                r = i - k + j
                acc = np.zeros((ns, p + 1))
                if j >= 1:
                    den = knots[r + k] - knots[r]
                    term = _times_linear((a - knots[r]) / den, h / den, basis[:, j - 1])
                    acc = np.where((den > 0.0)[:, None], acc + term, acc)
                if j <= k - 1:
                    den = knots[r + k + 1] - knots[r + 1]
                    term = _times_linear((knots[r + k + 1] - a) / den, -h / den, basis[:, j])
                    acc = np.where((den > 0.0)[:, None], acc + term, acc)
                new[:, j] = acc
            basis = new
    return np.ascontiguousarray(basis.transpose(0, 2, 1))


def _times_linear(c0: np.ndarray, c1: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(c0 + c1·t)·b(t) truncated to b's degree, per row: np.convolve(_linear(c0, c1), b)[:p + 1]
    row by row."""
    out = c0[:, None] * b
    out[:, 1:] += c1[:, None] * b[:, :-1]
    return out
