"""Smoothing of the controller's feed along the path (the last stage of the fuzzy advisor).

- ``"mean"``: seed 002's average filter (section 2.7.2), a centred moving average of M points.
  At a sharp corner the controller's dip is narrower than M, so the average pulls the corner's feed
  up towards its fast neighbours: on the butterfly's κ ≈ 35 /mm corners the controller asks
  11.7 % and the average gives up to 30 %.
- ``"corner-mean"`` (fuzzyfeed's default): the same average of the controller's output capped
  near each curvature peak (a sample whose κ is at least its neighbours'): within half a window of
  a peak the cap is the controller's output at the peak, beyond it the cap rises by
  ``rise_pct`` (% of F) per further half window. So the average at a peak only takes values at most
  the controller's output there, and the cap, being continuous, adds no kink of its own.
  Far from peaks it is the average.
- ``"none"``: the controller's output as it is (machine tables: their inputs already look ahead
  over the servo's settling distance, and any average would raise a slow spot's feed).
- ``"min-mean"``: a sliding minimum of the whole output over the window (a morphological erosion),
  then the average: never above the controller anywhere, the smoothest, and the slowest — every
  dip, ripple included, widens by M − 1 points.

Why the guarantee holds: point i averages j ∈ [i − h, i + h]; for min-mean each value averaged
there is a minimum over [j − h, j + h] ∋ i, so it is ≤ the controller's output at i; for
corner-mean at a peak p every such j is within the flat part of p's cap.
``benchmarks/filter_choice.py`` measures the
filters on the shipped shapes: largest point-to-point change against the slow-down kept at the κ
peaks and the time it costs. Windows are counted in points (``points``, M) or measured in mm
(``length_mm``, needs the arc length ``s``); in mm each sample is weighted by the length of path it
stands for.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.base.checks import finite_vector
from fuzzyfeed.errors import InputError
from fuzzyfeed.fuzzy.windows import cell_lengths, centred_bounds, range_min, window_mean

#: The filters a rule table may name in ``[features] filter``.
FILTER_KINDS = ("corner-mean", "min-mean", "mean", "none")
DEFAULT_FILTER = "corner-mean"
#: How fast corner-mean's cap rises beyond a peak's half window: % of F per half window (chosen by
#: benchmarks/filter_choice.py).
CORNER_RISE_PCT = 25.0


def curvature_peaks(kappa: np.ndarray) -> np.ndarray:
    """Mask of the samples whose curvature is at least that of each neighbour (local maxima,
    plateaus included; an end point counts if it is at least its one neighbour)."""
    k = np.asarray(kappa, dtype=float)
    padded = np.concatenate([[-np.inf], k, [-np.inf]])
    return (k >= padded[:-2]) & (k >= padded[2:])


def smooth_feed(values: np.ndarray, kind: str = DEFAULT_FILTER, points: int | None = 21,
                s: np.ndarray | None = None, length_mm: float | None = None,
                curvature: np.ndarray | None = None, rise_pct: float = CORNER_RISE_PCT,
                span: tuple[float, float] | None = None, lowest: float | None = None) -> np.ndarray:
    """The controller's feed ``values`` smoothed by filter ``kind`` over a window of ``points``
    samples (M, odd: a centred window) or of ``length_mm`` mm of arc length ``s``. Non-finite
    values are refused (NaN in never becomes a feed out).

    The averaging window is centred and shrinks symmetrically at the ends (the first and last
    points keep their own value); the sliding minimum uses the same half-width, truncated at the
    ends. ``"corner-mean"`` needs the ``curvature`` of every point. ``span`` and ``lowest``: the
    whole path's when ``s`` is a piece of it (:func:`filter_terms`).
    """
    v, lo, hi, weights = filter_terms(values, kind, points, s, length_mm, curvature, rise_pct, span, lowest)
    if lo is None:
        return v.copy()
    return window_mean(v, lo, hi, weights)


def filter_terms(values: np.ndarray, kind: str = DEFAULT_FILTER, points: int | None = 21,
                 s: np.ndarray | None = None, length_mm: float | None = None,
                 curvature: np.ndarray | None = None, rise_pct: float = CORNER_RISE_PCT,
                 span: tuple[float, float] | None = None, lowest: float | None = None):
    """What :func:`smooth_feed` averages: (the values after the sliding minimum or the corner cap,
    window bounds lo, hi, the samples' weights or None); lo is None for ``"none"``. On a piece of
    a path (``span`` = the path's first and last s, ``lowest`` = its lowest value at a curvature
    peak, :func:`corner_cap`) every value whose windows lie inside the piece is the whole path's,
    bit for bit; the average itself is left to the caller, who can carry its cumulative sums from
    piece to piece."""
    v = finite_vector(values, "values", "the filter needs finite values")
    if kind not in FILTER_KINDS:
        raise InputError(f"filter = {kind!r}; must be one of {', '.join(FILTER_KINDS)}")
    n = v.size
    if kind == "none":
        return v, None, None, None
    if length_mm is None:
        if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < 1:
            raise InputError(f"filter_points = {points!r}; must be an integer >= 1")
        if points % 2 == 0:
            raise InputError(f"filter_points = {points}; a centred window needs an odd number of "
                             f"points (use {points - 1} or {points + 1})")
        half = dict(half_points=int(points) // 2)
        weights = None
    else:
        length = float(length_mm)
        if not np.isfinite(length) or length <= 0:
            raise InputError(f"filter_mm = {length_mm!r}; must be a finite number > 0 (mm)")
        half = dict(s=s, half_mm=length / 2, span=span)
        weights = cell_lengths(s)
    lo, hi = centred_bounds(n, symmetric=True, **half)
    if kind == "min-mean":
        v = range_min(v, *centred_bounds(n, symmetric=False, **half))
    elif kind == "corner-mean":
        if curvature is None or np.shape(curvature) != v.shape:
            raise InputError("filter = 'corner-mean' needs the curvature of every point")
        at_peaks = np.where(curvature_peaks(curvature), v, np.inf)
        x, flat = ((np.arange(n, dtype=float), float(half["half_points"])) if "half_points" in half
                   else (np.asarray(s, dtype=float), float(half["half_mm"])))
        v = np.minimum(v, corner_cap(at_peaks, x, flat, rise_pct, span if "half_mm" in half else None,
                                     lowest))
    return v, lo, hi, weights


def corner_cap(at_peaks: np.ndarray, x: np.ndarray, flat: float, rise_pct: float,
               span: tuple[float, float] | None = None, lowest: float | None = None) -> np.ndarray:
    """cap_j = min over peaks p of a_p + slope · max(0, |x_j − x_p| − flat), slope = rise_pct / flat
    (``at_peaks`` = a_p at the peaks, inf elsewhere; ``x`` positions, non-decreasing). When ``x`` is
    a piece of a path: ``span`` its first and last x, ``lowest`` its lowest a_p.

    The flat part is a sliding minimum; the sloped part is the lower envelope of cones evaluated at
    x_j ∓ flat: slope·y + a running minimum of (a_p − slope·x_p) (and mirrored), O(N log N). A cone
    is never below its peak: the envelope is held at or above the path's lowest a_p (rounding aside).
    """
    n = at_peaks.size
    cap = range_min(at_peaks, *_bounds_around(x, flat, span))
    if flat <= 0 or not np.isfinite(at_peaks).any():
        return cap
    slope = rise_pct / flat
    with np.errstate(invalid="ignore"):
        left = np.minimum.accumulate(at_peaks - slope * x)            # peaks at or before k
        right = np.minimum.accumulate((at_peaks + slope * x)[::-1])[::-1]
    lowest = float(at_peaks.min()) if lowest is None else float(lowest)
    y = x - flat                                                      # cones from the left
    k = np.searchsorted(x, y, side="right") - 1
    ok = k >= 0
    cap[ok] = np.minimum(cap[ok], np.maximum(slope * y[ok] + left[k[ok]], lowest))
    y = x + flat                                                      # cones from the right
    k = np.searchsorted(x, y, side="left")
    ok = k < n
    cap[ok] = np.minimum(cap[ok], np.maximum(right[k[ok]] - slope * y[ok], lowest))
    return cap


def _bounds_around(x: np.ndarray, reach: float,
                   span: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Index bounds of the samples within ``reach`` of each sample (positions ``x``)."""
    first, last = (float(x[0]), float(x[-1])) if span is None else span
    tol = 1e-12 * max(abs(last), abs(first), 1.0)
    idx = np.arange(x.size)
    lo = np.minimum(np.searchsorted(x, x - reach - tol, side="left"), idx)
    hi = np.maximum(np.searchsorted(x, x + reach + tol, side="right") - 1, idx)
    return lo, hi


def average_filter(values: np.ndarray, points: int) -> np.ndarray:
    """Seed 002's centred moving average over ``points`` samples; at the ends the window shrinks
    symmetrically (point i averages i − h … i + h with h = min(M // 2, i, N − 1 − i))."""
    return smooth_feed(values, "mean", points)
