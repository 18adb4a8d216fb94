"""Sliding windows along a sampled path, counted in points or measured in mm of arc length.

A window is a pair of inclusive index bounds ``(lo[i], hi[i])`` per point. Seed 002 counts its
windows in points (WS = 30, M = 21 at 2000 samples uniform in u); the same windows given in mm cover
the same stretch of path whatever the sampling (a re-imported or resampled path gets the same
advice). Extremes over windows use a sparse table (O(N log W)), means use cumulative sums.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.errors import InputError


def _check_count(name: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InputError(f"{name} = {value!r}; must be an integer >= 1")
    return int(value)


def _check_length(name: str, value: object) -> float:
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputError(f"{name} = {value!r}; must be a number > 0 (mm)") from None
    if not np.isfinite(v) or v <= 0:
        raise InputError(f"{name} = {value!r}; must be a finite number > 0 (mm)")
    return v


def _check_s(s: np.ndarray) -> np.ndarray:
    s = np.asarray(s, dtype=float)
    if s.ndim != 1 or not np.isfinite(s).all() or (np.diff(s) < 0).any():
        raise InputError("arc length s: must be finite and non-decreasing along the path")
    return s


def _tol(s: np.ndarray, span: tuple[float, float] | None = None) -> float:
    """Rounding allowance on positions (the window edge of a point exactly on it counts it);
    ``span``: the path's first and last s when ``s`` is a piece of it."""
    first, last = (float(s[0]), float(s[-1])) if span is None else span
    return 1e-12 * max(abs(last), abs(first), 1.0)


def forward_bounds(n: int, points: int | None = None, s: np.ndarray | None = None,
                   length_mm: float | None = None,
                   span: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Window [i, i + points − 1] or every point with s_i ≤ s_j ≤ s_i + length_mm, truncated at the
    end of the path (seed 002 eq. 10 counts points). ``span``: the whole path's first and last s
    when ``s`` is a piece of it (the windows of the piece's points whose window lies inside it are
    then the whole path's)."""
    idx = np.arange(n)
    if length_mm is None:
        w = _check_count("window_points", points)
        return idx, np.minimum(idx + w - 1, n - 1)
    length = _check_length("window_mm", length_mm)
    s = _check_s(s)
    hi = np.searchsorted(s, s + length + _tol(s, span), side="right") - 1
    return idx, np.maximum(hi, idx)


def centred_bounds(n: int, half_points: int | None = None, s: np.ndarray | None = None,
                   half_mm: float | None = None, symmetric: bool = True,
                   span: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Centred window of half-width ``half_points`` points or ``half_mm`` mm around each point.

    ``symmetric``: near the ends the half-width shrinks to the distance to the nearer end, so the
    window stays centred and the end points keep their own value (seed 002's average filter);
    otherwise the window is simply truncated at the ends. ``span`` (windows in mm): the whole
    path's first and last s when ``s`` is a piece of it.
    """
    idx = np.arange(n)
    if half_mm is None:
        if isinstance(half_points, bool) or not isinstance(half_points, (int, np.integer)) or half_points < 0:
            raise InputError(f"half window = {half_points!r}; must be an integer >= 0")
        h = np.full(n, int(half_points))
        if symmetric:
            h = np.minimum(h, np.minimum(idx, n - 1 - idx))
        return np.maximum(idx - h, 0), np.minimum(idx + h, n - 1)
    s = _check_s(s)
    half = float(half_mm)
    if not np.isfinite(half) or half < 0:
        raise InputError(f"half window = {half_mm!r} mm; must be a finite number >= 0")
    h = np.full(n, half)
    first, last = (s[0], s[-1]) if span is None else span
    if symmetric:
        h = np.minimum(h, np.minimum(s - first, last - s))
    tol = _tol(s, span)
    lo = np.searchsorted(s, s - h - tol, side="left")
    hi = np.searchsorted(s, s + h + tol, side="right") - 1
    return np.minimum(lo, idx), np.maximum(hi, idx)


def range_min(values: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """out[i] = min(values[lo[i] : hi[i] + 1]) (sparse table: level k holds minima of 2**k values)."""
    v = np.asarray(values, dtype=float)
    lo = np.asarray(lo, dtype=np.int64)
    hi = np.asarray(hi, dtype=np.int64)
    out = np.empty(lo.size)
    if lo.size == 0:
        return out
    length = hi - lo + 1
    k = np.floor(np.log2(length)).astype(np.int64)
    k = np.where((1 << (k + 1)) <= length, k + 1, k)       # guard log2 rounding
    k = np.where((1 << k) > length, k - 1, k)
    level = v
    for j in range(int(k.max()) + 1):
        if j > 0:
            half = 1 << (j - 1)
            level = np.minimum(level[:-half], level[half:])
        sel = k == j
        if sel.any():
            out[sel] = np.minimum(level[lo[sel]], level[hi[sel] - (1 << j) + 1])
    return out


def range_max(values: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """out[i] = max(values[lo[i] : hi[i] + 1])."""
    return -range_min(-np.asarray(values, dtype=float), lo, hi)


def cell_lengths(s: np.ndarray) -> np.ndarray:
    """Length of path each sample stands for: half the distance to each neighbour (Voronoi cells)."""
    s = _check_s(s)
    if s.size == 1:
        return np.ones(1)
    gaps = np.diff(s)
    w = np.zeros(s.size)
    w[:-1] += gaps / 2
    w[1:] += gaps / 2
    if not (w > 0).all():              # repeated points: count them equally rather than not at all
        w = np.maximum(w, w[w > 0].min() if (w > 0).any() else 1.0)
    return w


def window_mean(values: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                weights: np.ndarray | None = None,
                sums: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Mean of values[lo[i] : hi[i] + 1] for each i, optionally weighted (a convex combination of
    the window's values, so it never leaves their range). ``sums``: the cumulative sums (Σw, Σwv)
    with a leading 0, when the caller made them (a piece of a path carries the whole path's)."""
    v = np.asarray(values, dtype=float)
    if sums is not None:
        cw, cv = sums
        out = (cv[hi + 1] - cv[lo]) / (cw[hi + 1] - cw[lo])
    elif weights is None:
        c = np.concatenate([[0.0], np.cumsum(v)])
        out = (c[hi + 1] - c[lo]) / (hi - lo + 1)
    else:
        w = np.asarray(weights, dtype=float)
        cw = np.concatenate([[0.0], np.cumsum(w)])
        cv = np.concatenate([[0.0], np.cumsum(w * v)])
        out = (cv[hi + 1] - cv[lo]) / (cw[hi + 1] - cw[lo])
    # rounding in the cumulative sums must not push a mean outside its window's range
    return np.clip(out, range_min(v, lo, hi), range_max(v, lo, hi))
